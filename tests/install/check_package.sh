#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# ctest "install: cpack -G DEB ...": builds the Debian packages from the
# build tree (librelief1, librelief-dev, relief, python3-relief), checks
# their control fields, contents and lintian's verdict, then runs the CLI
# they carry and builds a C program against librelief1 + librelief-dev
# alone, unpacked (no dpkg -i: the test must not change the machine).
# Usage: check_package.sh BUILD_DIR
set -euo pipefail
build=$1
src=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "check_package: $*" >&2; exit 1; }
# A program not built with the sanitizers that loads librelief gets ASan's
# runtime first through $RELIEF_HOST_PRELOAD (the sanitizer build only:
# cpack, lintian and the compiler must not).
run() {
  if [ -n "${RELIEF_HOST_PRELOAD:-}" ]; then LD_PRELOAD=$RELIEF_HOST_PRELOAD "$@"; else "$@"; fi
}
cpack --config "$build/CPackConfig.cmake" -G DEB -B "$tmp" >/dev/null
version=$(sed -n 's/^relief (\([^)]*\)).*/\1/p' "$src/packaging/changelog" | head -1)
arch=$(dpkg --print-architecture)
multiarch=$(dpkg-architecture -qDEB_HOST_MULTIARCH)
deb() { echo "$tmp/${1}_${version}_${arch}.deb"; }
for p in librelief1 librelief-dev relief python3-relief; do
  [ -f "$(deb $p)" ] || fail "no package $p: $(ls "$tmp")"
  [ "$(dpkg-deb -f "$(deb $p)" Package)" = "$p" ] || fail "$p: wrong Package field"
  echo "$p: Depends: $(dpkg-deb -f "$(deb $p)" Depends)"
  dpkg-deb -c "$(deb $p)" | awk '{print $6}' > "$tmp/$p.files"
  for f in "./usr/share/doc/$p/copyright" "./usr/share/doc/$p/changelog.gz"; do
    grep -qx "$f" "$tmp/$p.files" || fail "$p lacks $f"
  done
done
has() {  # package, then the dependency texts it must name
  local p=$1 depends; shift
  depends=$(dpkg-deb -f "$(deb "$p")" Depends)
  for need in "$@"; do
    case "$depends" in *"$need"*) ;; *) fail "$p: Depends lacks $need ($depends)" ;; esac
  done
}
has librelief1 libopenimageio libopencolorio ocl-icd-libopencl1 'pocl-opencl-icd | opencl-icd' fonts-dejavu-core
has librelief-dev "librelief1 (= $version)"
has relief "librelief1 (= $version)" python3
has python3-relief "librelief1 (= $version)" python3-numpy 'python3 (>= 3.'
# the C ABI needs no OpenImageIO development files
case "$(dpkg-deb -f "$(deb librelief-dev)" Depends)" in *openimageio*) fail "librelief-dev depends on OpenImageIO" ;; esac
dpkg-deb -f "$(deb librelief-dev)" Recommends | grep -q libopenimageio-dev || fail "librelief-dev should recommend libopenimageio-dev"
dpkg-deb -f "$(deb librelief1)" Section | grep -qx libs || fail "librelief1 is not in section libs"
files() {  # package, then the paths (regular expressions) it must hold
  local p=$1; shift
  for f in "$@"; do grep -Eqx "$f" "$tmp/$p.files" || fail "$p lacks $f: $(cat "$tmp/$p.files")"; done
}
files librelief1 "\./usr/lib/$multiarch/librelief\.so\.1(\..*)?"
files librelief-dev '\./usr/include/relief/relief_c\.h' '\./usr/include/relief/relief\.h' '\./usr/include/relief/export\.h' \
  "\./usr/lib/$multiarch/librelief\.so" "\./usr/lib/$multiarch/cmake/relief/reliefConfig\.cmake" \
  "\./usr/lib/$multiarch/pkgconfig/relief\.pc" "\./usr/lib/$multiarch/pkgconfig/relief-cxx\.pc"
files relief '\./usr/bin/relief' '\./usr/bin/relief-slurm' '\./usr/share/man/man1/relief\.1\.gz' \
  '\./usr/share/man/man1/relief-slurm\.1\.gz'
files python3-relief '\./usr/lib/python3/dist-packages/relief/__init__\.py' \
  '\./usr/lib/python3/dist-packages/relief/_relief\..*\.so'
# each file in one package only
sort "$tmp"/*.files | grep -v '/$' | uniq -d | grep -v '^\./usr/share/doc/$' > "$tmp/twice" || true
[ ! -s "$tmp/twice" ] || fail "files in two packages: $(cat "$tmp/twice")"
# the man page is the table's --help
dpkg-deb -x "$(deb relief)" "$tmp/tools"
zcat "$tmp/tools/usr/share/man/man1/relief.1.gz" | grep -q '^.SS "Modifiers (:key=value) of --height:"' ||
  fail "relief.1 lacks --height's modifiers"
# lintian: no errors (its warnings are listed in docs/embedding.md)
if command -v lintian >/dev/null; then
  lintian --tag-display-limit 0 "$tmp"/*.deb > "$tmp/lintian" 2>&1 || true
  cat "$tmp/lintian"
  ! grep -q '^E: ' "$tmp/lintian" || fail "lintian reports errors"
fi
# the packages' CLI runs, and a C program builds and runs against the
# library packages alone: pkg-config sees only their files, not
# OpenImageIO's
root=$tmp/root
for p in librelief1 librelief-dev relief; do dpkg-deb -x "$(deb $p)" "$root"; done
LD_LIBRARY_PATH="$root/usr/lib/$multiarch" "$root/usr/bin/relief" --version
export PKG_CONFIG_LIBDIR="$root/usr/lib/$multiarch/pkgconfig" PKG_CONFIG_PATH=
cc -Wall -Wextra -Werror "$src/tests/install/c_abi_checks.c" $(pkg-config --cflags --libs relief) -o "$tmp/c_host"
run "$tmp/c_host"
! pkg-config --exists relief-cxx || fail "relief-cxx resolved without OpenImageIO's pkg-config file"
echo "check_package: the packages hold"
