#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The code follows .clang-format (clang-format 14, Debian 12's; another
# version formats differently, so it skips: exit 77).
# Usage: check_format.sh SOURCE_DIR [CLANG_FORMAT]
set -euo pipefail
cd "$1"
cf=${2:-clang-format}
version=$("$cf" --version 2>/dev/null || true)
case $version in
  *" version 14."*) ;;
  *) echo "skipped: .clang-format is checked with clang-format 14 (found: ${version:-none})"; exit 77 ;;
esac
mapfile -t files < <(git ls-files '*.cpp' '*.h' '*.c' '*.cl')
if ! "$cf" --dry-run -Werror "${files[@]}"; then
  echo "the files above do not follow .clang-format: run clang-format -i on them"
  exit 1
fi
echo "${#files[@]} files follow .clang-format"
