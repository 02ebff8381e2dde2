#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# The sanitizer build's CLI run by hand, without the environment the other
# tests give it: the options and suppressions compiled in must be enough
# for a clean run (no "AddressSanitizer failed to deallocate", no leak
# report of PoCL's). Usage: check_as_built.sh RELIEF NORMALS.png TMPDIR
set -eu
relief=$1 normals=$2 tmp=$3
mkdir -p "$tmp"
status=0
env -u ASAN_OPTIONS -u LSAN_OPTIONS -u UBSAN_OPTIONS \
  "$relief" "$normals" --dup --height -o "$tmp/as-built-h.exr" --preview -o "$tmp/as-built-sheet.png" \
  2>"$tmp/as-built.err" || status=$?
cat "$tmp/as-built.err"
if [ "$status" -ne 0 ] || grep -q Sanitizer "$tmp/as-built.err"; then
  echo "the sanitizer build does not run as built (exit $status)" >&2
  exit 1
fi
