#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Regenerates the pictures of the README's "Checking a result": the preview
# sheet of the bundled DEM sample and a rendering of its displaced mesh.
# Needs a built relief (RELIEF=path, default build/cli/relief), oiiotool,
# and for the rendering Debian's f3d and xvfb (apt install f3d xvfb xauth).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
relief=${RELIEF:-$here/../../build/cli/relief}
data=$here/../data/dem_jacksboro
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# The sheet, the height, its mesh and the round trip in one run.
"$relief" "$data/normal.png" --dup --height -o "$tmp/h.exr" --report "$here/report_dem_jacksboro.json" \
  --preview -o "$here/preview_dem_jacksboro.png"

# A 128x96 crop at 4x relief with a 1-unit error, so the triangles show.
oiiotool "$tmp/h.exr" --cut 128x96+40+40 --origin +0+0 -o "$tmp/crop.exr"
"$relief" "$tmp/crop.exr" --mesh:patch=16:error=1:scale=4:out="$tmp/crop.glb"
xvfb-run -a -s "-screen 0 1400x1000x24" f3d "$tmp/crop.glb" --output="$here/mesh_dem_jacksboro_crop.png" \
  --up=+Z --resolution=1200,800 --edges --camera-elevation-angle=50 --camera-azimuth-angle=-20
