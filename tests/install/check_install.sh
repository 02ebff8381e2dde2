#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# ctest "install: ...": installs the build into a temporary prefix and uses
# it as an embedding host would: the installed CLI; a C program built with
# `pkg-config --cflags --libs relief` and the same program loading the
# library by path (relief_plugin_entry); an out-of-tree CMake project with
# find_package(relief CONFIG REQUIRED); `import relief` from the prefix.
# Every door must give the CLI's result on the same bytes.
# Usage: check_install.sh BUILD_DIR SOURCE_DIR PYTHON
set -euo pipefail
build=$1 src=$2 python=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
prefix=$tmp/prefix
step() { echo "== $*"; }
# A program that loads librelief, run with $RELIEF_HOST_PRELOAD preloaded
# when set (the sanitizer build: ASan's runtime must come first in a
# program not built with it, and cmake or cpack must not get it).
run() {
  if [ -n "${RELIEF_HOST_PRELOAD:-}" ]; then LD_PRELOAD=$RELIEF_HOST_PRELOAD "$@"; else "$@"; fi
}

step "cmake --install into $prefix"
cmake --install "$build" --prefix "$prefix" >/dev/null
libdir=$(dirname "$(find "$prefix" -name 'librelief.so.1' | head -n 1)")
test -x "$prefix/bin/relief"
test -f "$prefix/include/relief/relief_c.h"
export PKG_CONFIG_PATH=$libdir/pkgconfig
pyroot=$prefix/lib/python3/dist-packages
normal=$src/examples/data/dem_jacksboro/normal.png

step "the installed CLI"
"$prefix/bin/relief" --version
"$prefix/bin/relief" "$normal" --height:normal=opengl:boundary=periodic -o "$tmp/cli_periodic.exr"
"$prefix/bin/relief" "$normal" --height -o "$tmp/cli_default.exr"
# relief-slurm is installed beside relief and finds it there
echo "'$normal' --slopes -o '$tmp/slurm_job.exr'" > "$tmp/jobs.txt"
"$prefix/bin/relief-slurm" submit "$tmp/jobs.txt" --tasks 2 --dry-run | grep -F "exec $prefix/bin/relief --batch" >/dev/null
st=$("$prefix/bin/relief-slurm" status "$tmp/jobs.txt" --log-dir "$tmp/none") && exit 1  # 1: a job is missing
echo "$st" | grep -F "1 job(s): 0 ok, 0 skipped, 0 failed, 1 missing" >/dev/null
mkdir "$tmp/badlogs"
echo "'$tmp/missing.png' --slopes -o '$tmp/never.exr'" > "$tmp/bad.txt"
"$prefix/bin/relief" --batch "$tmp/bad.txt" --log "$tmp/badlogs/task-0.jsonl" 2>/dev/null && exit 1
st=$("$prefix/bin/relief-slurm" status "$tmp/bad.txt" --log-dir "$tmp/badlogs") && exit 1
echo "$st" | grep -F "1 job(s): 0 ok, 0 skipped, 1 failed, 0 missing" >/dev/null
echo "$st" | grep -F "job 0 (line 1): cannot read '$tmp/missing.png'" >/dev/null
# submit, against a stand-in sbatch that records its arguments
mkdir -p "$tmp/fakebin" "$tmp/sub" "$tmp/sub/logs 5%"
cat > "$tmp/fakebin/sbatch" <<'SH'
#!/bin/sh
printf '%s\n' "$@" > "$FAKE_SBATCH_ARGS"
echo "4242;relief"
SH
chmod +x "$tmp/fakebin/sbatch"
cp "$normal" "$tmp/sub/n.1001.png"
cp "$normal" "$tmp/sub/n.1002.png"
echo "n.<UDIM>.png --slopes -o 'o.<UDIM>.exr'" > "$tmp/sub/jobs.txt"
echo '{"job": 0, "args": ["n.1001.png", "--slopes", "-o", "o.1001.exr"], "status": "ok"}' > "$tmp/sub/logs 5%/task-7.jsonl"
id=$(cd "$tmp/sub" && FAKE_SBATCH_ARGS="$tmp/sbatch.args" PATH="$tmp/fakebin:$PATH" \
     "$prefix/bin/relief-slurm" submit jobs.txt --tasks 2 --log-dir "logs 5%" -- --time=1 | tail -n 1)
test "$id" = 4242
grep -Fx -- "--parsable" "$tmp/sbatch.args" >/dev/null
grep -Fx -- "--output=$tmp/sub/logs 5%%/task-%a.out" "$tmp/sbatch.args" >/dev/null
grep -Fx -- "--time=1" "$tmp/sbatch.args" >/dev/null
test "$(tail -n 1 "$tmp/sbatch.args")" = "$tmp/sub/logs 5%/relief-array.sbatch"
test ! -e "$tmp/sub/logs 5%/task-7.jsonl"  # the last submission's logs are gone
# status lists the jobs as the tasks see them, from the folder submitted from
st=$(cd / && "$prefix/bin/relief-slurm" status "$tmp/sub/jobs.txt" --log-dir "$tmp/sub/logs 5%") && exit 1
echo "$st" | grep -F "2 job(s): 0 ok, 0 skipped, 0 failed, 2 missing" >/dev/null

step "the same bytes as a binary PPM, for the C host"
PYTHONPATH=$pyroot run "$python" - "$normal" "$tmp/normal.ppm" <<'PY'
import sys, relief
n = relief.read(sys.argv[1])
with open(sys.argv[2], "wb") as f:
    f.write(b"P6\n%d %d\n255\n" % (n.shape[1], n.shape[0]))
    f.write(n.tobytes())
PY

step "C: linked with pkg-config, and loaded by path"
# (no -rpath here: relief.pc's Libs carry it, so the program runs as built)
cc -Wall -Wextra -Werror "$src/examples/plugin_host.c" $(pkg-config --cflags --libs relief) -o "$tmp/host_linked"
cc -Wall -Wextra -Werror -DRELIEF_DLOPEN "$src/examples/plugin_host.c" $(pkg-config --cflags relief) \
   -ldl -o "$tmp/host_dlopen"
if readelf -d "$tmp/host_dlopen" | grep -q 'librelief'; then
  echo "host_dlopen must not link librelief"; exit 1
fi
run "$tmp/host_linked" height normal=opengl:boundary=periodic "$tmp/normal.ppm" "$tmp/linked.pfm"
run "$tmp/host_dlopen" "$libdir/librelief.so.1" height normal=opengl:boundary=periodic "$tmp/normal.ppm" "$tmp/dlopen.pfm"
run "$tmp/host_dlopen" "$libdir/librelief.so.1" --list > "$tmp/table.json"
grep -q '"name": "correct"' "$tmp/table.json"
for host in host_linked "host_dlopen $libdir/librelief.so.1"; do
  if run $tmp/$host height rays=-3 "$tmp/normal.ppm" "$tmp/refused.pfm" 2>"$tmp/err"; then
    echo "$host accepted rays=-3"; exit 1
  fi
  grep -q 'rays=-3 must be an integer' "$tmp/err"
  test ! -e "$tmp/refused.pfm"
done
cc -Wall -Wextra -Werror "$src/tests/install/c_abi_checks.c" $(pkg-config --cflags --libs relief) -o "$tmp/abi_linked"
cc -Wall -Wextra -Werror -DRELIEF_DLOPEN "$src/tests/install/c_abi_checks.c" $(pkg-config --cflags relief) \
   -ldl -o "$tmp/abi_dlopen"
run "$tmp/abi_linked"
run "$tmp/abi_dlopen" "$libdir/librelief.so.1"

step "CMake: find_package(relief CONFIG REQUIRED) out of tree"
cmake -S "$src/tests/install/consumer" -B "$tmp/consumer" -DCMAKE_PREFIX_PATH="$prefix" \
      -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$tmp/consumer" >/dev/null
run "$tmp/consumer/consumer" "$normal" "$tmp/cli_default.exr"

step "Python from the prefix, and every door against the CLI"
PYTHONPATH=$pyroot run "$python" - "$normal" "$tmp" <<'PY'
import os, sys
import numpy as np
import relief
normal, tmp = sys.argv[1], sys.argv[2]
assert os.path.dirname(relief.__file__).startswith(tmp), relief.__file__
cli = relief.read(os.path.join(tmp, "cli_periodic.exr"))
sd = float(np.std(cli))
doors = {
    "python": relief.height(relief.read(normal), normal="opengl", boundary="periodic"),
    "C linked": relief.read(os.path.join(tmp, "linked.pfm"))[..., :1],
    "C dlopen": relief.read(os.path.join(tmp, "dlopen.pfm"))[..., :1],
}
for door, h in doors.items():
    worst = float(np.abs(h.astype(np.float64) - cli).max())
    print(f"{door}: max difference {worst:.3g} (std {sd:.3g})")
    assert h.shape == cli.shape and worst <= 1e-5 * sd, door
try:
    relief.height(relief.read(normal), rays=-3)
    raise SystemExit("rays=-3 accepted")
except ValueError as e:
    assert "rays=-3" in str(e)
names = [op["name"] for op in relief.operations()]
assert "height" in names and "correct" in names, names
PY
echo "install: every door agrees"
