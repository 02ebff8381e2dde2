#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# scripts/mutate-random draws mutants that apply to the tree, each one
# changed line in the glue, and the same seed draws the same ones.
# Usage: check_random.sh SOURCE_DIR SCRATCH_DIR
set -euo pipefail
src=$1
out=$2
rm -rf "$out"
mkdir -p "$out"
cd "$src"
/usr/bin/python3 scripts/mutate-random "$out/a" 150 7
/usr/bin/python3 scripts/mutate-random "$out/b" 150 7
/usr/bin/python3 scripts/mutate-random "$out/c" 150 8
diff -r "$out/a" "$out/b" >/dev/null || { echo "seed 7 drew different mutants twice"; exit 1; }
! diff -r "$out/a" "$out/c" >/dev/null || { echo "seeds 7 and 8 drew the same mutants"; exit 1; }
n=0
for p in "$out"/a/*.patch; do
  n=$((n + 1))
  git apply --check "$p" || { echo "does not apply: $p"; exit 1; }
  stat=$(git apply --numstat "$p")
  case "$stat" in
    "1	1	"cli/*|"1	1	"plugin/src/*|"1	1	"python/*|"1	1	"host/*) ;;
    *) echo "not one changed line of the glue: $p ($stat)"; exit 1 ;;
  esac
  head -n 1 "$p" | grep -Eq '^# [a-z_/]+\.(cpp|h):[0-9]+: ' || { echo "no description: $p"; exit 1; }
done
[ "$n" -eq 150 ] || { echo "drew $n mutants, not 150"; exit 1; }
# Every kind is drawn.
for kind in "becomes '" "the constant" "is negated" "is dropped" "are swapped"; do
  grep -qh "^# .*$kind" "$out"/a/*.patch || { echo "no mutant of the kind '$kind' in 150"; exit 1; }
done
# A mutant near a file's end applies too (its context stops at the last line).
tiny=$out/tiny
mkdir -p "$tiny/cli"
printf 'int f(int a)\n{\n    return a + 1;\n}\nint g(int a) { return a * 2; }\n' >"$tiny/cli/end.cpp"
git -C "$tiny" init -q
(cd "$tiny" && /usr/bin/python3 "$src/scripts/mutate-random" "$out/tiny-mutants" 4 1)
for p in "$out"/tiny-mutants/*.patch; do
  git -C "$tiny" apply --check "$p" || { echo "a mutant of the last lines does not apply: $p"; cat "$p"; exit 1; }
done
echo "150 random mutants apply, one line each, drawn again the same by the same seed"
