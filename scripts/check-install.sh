#!/usr/bin/env bash
# Installs the release build into build/install, builds examples/ against the installed package
# (find_package(posekit 0.2), not the build tree) and against pkg-config, and runs them on data the
# installed CLI writes. Called by run-tests.sh after the release tests.
set -euo pipefail
cd "$(dirname "$0")/.."
export POSEKIT_DATA=${POSEKIT_DATA:-$(cd .. && pwd)/shared/datasets/makehuman}
prefix=$PWD/build/install
rm -rf "$prefix" build/examples
cmake --install build/release --prefix "$prefix" > /dev/null
"$prefix/bin/posekit" --version
cmake -S examples -B build/examples -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build build/examples -j"$(nproc 2>/dev/null || echo 2)" > /dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The release tests' small dataset when they made one (the same command's output), else made here.
if [ -f build/release/tests/shared-data/small/manifest.json ]; then
  ln -s "$PWD/build/release/tests/shared-data/small" "$work/ds"
else
  "$prefix/bin/posekit" dataset make --small --out "$work/ds" > /dev/null
fi
"$prefix/bin/posekit" train --dataset "$work/ds" --out "$work/model.pkm" > /dev/null
build/examples/measure_scan "$work/ds/subjects/f01/rest.ply" | tee "$work/measure.txt"
grep -Eq "^ +waist +[0-9]+\.[0-9] cm" "$work/measure.txt"
build/examples/pose_bvh "$work/model.pkm" "$work/ds/subjects/f01/rest.ply" "$POSEKIT_DATA/poses/benchmark.bvh" "$work/posed" 1
# A CMU motion (another skeleton): retargeted to the subject's joints by the library.
cmu_bvh="$POSEKIT_DATA/../motions/cmu/01_01.bvh"
if [ -f "$cmu_bvh" ]; then
  build/examples/pose_bvh "$work/model.pkm" "$work/ds/subjects/f01/rest.ply" "$cmu_bvh" "$work/cmu" 2
  "$prefix/bin/posekit" info "$work/cmu_1.ply" --json | grep -q '"watertight": true'
fi
# What a program that only poses a mesh links: posekit's static libraries and the shared ones.
echo "examples/pose_bvh links posekit:" $(grep -o 'libposekit_[a-z]*\.a' build/examples/CMakeFiles/pose_bvh.dir/link.txt | sort -u | sed 's/libposekit_//; s/\.a//')
echo "examples/pose_bvh loads:" $(ldd build/examples/pose_bvh | awk '{print $1}' | grep -v -E '^(linux-vdso|/lib64)' | sed 's/\.so.*//' | sort -u)
if ldd build/examples/pose_bvh | grep -E 'libvtk|libopencv|libpcl'; then
  echo "examples/pose_bvh links VTK, OpenCV or PCL" >&2
  exit 1
fi
"$prefix/bin/posekit" info "$work/posed_0.ply" --json | grep -q '"watertight": true'
# Python: the installed module poses a body from numpy arrays.
(cd "$work" && PYTHONPATH="$prefix/lib/python3/dist-packages" /usr/bin/python3 "$OLDPWD/examples/python/pose_and_measure.py" \
   "$work/model.pkm" "$work/ds/subjects/f01/rest.ply")
PYTHONPATH="$prefix/lib/python3/dist-packages" /usr/bin/python3 -c "import posekit, numpy as np; V, F = posekit.read_mesh('$work/posed.ply'); print('import posekit', posekit.__version__, V.shape)"
# pkg-config: a program that prints the library's version and the vertex count of a body.
cat > "$work/pc.cpp" <<'CPP'
#include <iostream>
#include "posekit/io/mesh_io.h"
#include "posekit/version.h"
int main(int argc, char** argv) {
  std::cout << "posekit " << posekit::version() << ": " << posekit::read_mesh(argv[1]).V.rows() << " vertices\n";
}
CPP
export PKG_CONFIG_PATH="$prefix/lib/pkgconfig"
# shellcheck disable=SC2046
g++ -std=c++17 "$work/pc.cpp" -o "$work/pc" $(pkg-config --cflags posekit) $(pkg-config --libs --static posekit)
"$work/pc" "$work/ds/subjects/f01/rest.ply"
echo "== install check: find_package and pkg-config consumers built and ran"
