#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The documentation holds together: every "§N" or "§N.M" a source comment
# cites is a heading of docs/design.md ("## N." or "### N.M"); every
# relative link and image of README.md and docs/*.md names a file that
# exists; the README stays a front page (at most 200 lines); and nothing
# sends users to folders they do not have (../shared).
# Usage: check_docs.sh PROJECT_SOURCE_DIR
set -euo pipefail
cd "$1"
bad=0
fail() { echo "docs: $*"; bad=$((bad + 1)); }

headings=$(grep -E '^#{2,3} [0-9]+(\.[0-9]+)*[. ]' docs/design.md | sed -E 's/^#+ ([0-9]+(\.[0-9]+)*).*/\1/')
while IFS= read -r hit; do
  file=${hit%%:*}
  for s in $(grep -oE '§[0-9]+(\.[0-9]+)*' <<<"${hit#*:}" | sed 's/§//'); do
    grep -qxF "$s" <<<"$headings" || fail "$file cites §$s, which is no heading of docs/design.md"
  done
done < <(git ls-files -z | xargs -0 grep -I -H '§' -- 2>/dev/null | grep -v '^docs/design.md:' || true)

for md in README.md docs/*.md; do
  dir=$(dirname "$md")
  while IFS= read -r target; do
    target=${target%%#*}
    [ -z "$target" ] && continue
    case $target in http://*|https://*|mailto:*) continue ;; esac
    [ -e "$dir/$target" ] || fail "$md links to $target, which does not exist"
  done < <(grep -oE '\]\([^)]+\)' "$md" | sed -E 's/^\]\(//; s/\)$//; s/ .*//')
done

lines=$(wc -l <README.md)
[ "$lines" -le 200 ] || fail "README.md has $lines lines (200 at most: the rest belongs in docs/)"
if grep -nE '\.\./shared|/work/shared' README.md docs/*.md; then
  fail "the documentation points at ../shared, which users do not have"
fi
# Every source file says its licence (SPDX), the project's (LICENSE).
while IFS= read -r f; do
  case $f in tests/fuzz/*|tests/mutants/*|*.md|*.png|*.csv|*.patch|*.supp|*.pc.in|LICENSE|.gitignore) continue ;; esac
  case $f in
    *.cpp|*.h|*.c|*.cl|*.py|*.sh|*.cmake|*.in|*CMakeLists.txt) ;;
    *) head -c 2 "$f" | grep -q '#!' || continue ;;
  esac
  head -n 2 "$f" | grep -q 'SPDX-License-Identifier: Apache-2.0' || fail "$f has no SPDX-License-Identifier: Apache-2.0 line"
done < <(git ls-files)

[ $bad -eq 0 ] && echo "docs: citations, links, the README and licence lines hold"
exit $((bad > 0))
