#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# ctest "install: cpack -G DEB ...": builds the Debian package from the build
# tree and checks its control fields and contents, then runs the CLI it
# carries, unpacked (no dpkg -i: the test must not change the machine).
# Usage: check_package.sh BUILD_DIR
set -euo pipefail
build=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cpack --config "$build/CPackConfig.cmake" -G DEB -B "$tmp" >/dev/null
deb=$(ls "$tmp"/*.deb)
echo "package: $(basename "$deb")"
depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
for need in libopenimageio libopencolorio ocl-icd-libopencl1 'pocl-opencl-icd | opencl-icd' python3-numpy 'python3 (>= 3.'; do
  case "$depends" in *"$need"*) ;; *) echo "Depends lacks $need"; exit 1 ;; esac
done
echo "Recommends: $(dpkg-deb -f "$deb" Recommends)"
dpkg-deb -f "$deb" Recommends | grep -q libopenimageio-dev
dpkg-deb -c "$deb" | awk '{print $6}' > "$tmp/files"
# (lib/ or lib/<multiarch>/, as the build's CMAKE_INSTALL_LIBDIR says)
for f in '\./usr/bin/relief' '\./usr/bin/relief-slurm' '\./usr/include/relief/relief_c\.h' '\./usr/include/relief/relief\.h' \
         '\./usr/include/relief/export\.h' '\./usr/lib/(.*/)?librelief\.so\.1' \
         '\./usr/lib/(.*/)?cmake/relief/reliefConfig\.cmake' '\./usr/lib/(.*/)?pkgconfig/relief\.pc' \
         '\./usr/lib/python3/dist-packages/relief/__init__\.py'; do
  grep -Eqx "$f" "$tmp/files" || { echo "the package lacks $f"; cat "$tmp/files"; exit 1; }
done
grep -q '^./usr/lib/python3/dist-packages/relief/_relief\..*\.so$' "$tmp/files"
dpkg-deb -x "$deb" "$tmp/root"
"$tmp/root/usr/bin/relief" --version
