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
# One program per exported target, each found as a component of its own (find_package(posekit
# COMPONENTS <module>): that component's packages only) and linked again by its pkg-config file
# (posekit-<module>.pc, --static): every static library and third-party library a module needs is
# named by both. The calls are linked, not run.
consumers=$work/consumers
mkdir -p "$consumers"
declare -A call=(
  [core]='#include "posekit/core/units.h"|posekit::parse_unit(argv[1]);'
  [io]='#include "posekit/io/mesh_io.h"|posekit::read_mesh(argv[1]);'
  [body]='#include "posekit/body/makehuman_model.h"|posekit::load_makehuman_model(argv[1]);'
  [shape]='#include "posekit/shape/measurements.h"|posekit::measure_body(Eigen::MatrixXd(), Eigen::MatrixXi());'
  [registration]='#include "posekit/registration/registration.h"|posekit::register_bodies(posekit::TriangleMesh(), posekit::TriangleMesh());'
  [segmentation]='#include "posekit/segmentation/segmentation.h"|posekit::segment_body(Eigen::MatrixXd(), Eigen::MatrixXi(), posekit::LayeredRepresentation());'
  [deformation]='#include "posekit/deformation/dataset_training.h"|posekit::train_on_dataset(argv[1]);'
  [datasets]='#include "posekit/datasets/dataset.h"|posekit::make_dataset(argv[1], posekit::DatasetOptions());'
  [customization]='#include "posekit/customization/photo_customization.h"|posekit::customize_from_silhouettes(posekit::silhouette_from_photo(argv[1], "f"), posekit::silhouette_from_photo(argv[2], "s"), posekit::read_photo_cameras(argv[3]), posekit::load_customization_model(argv[4]));'
  [fitting]='#include "posekit/fitting/body_fit.h"|posekit::fit_body_model(posekit::BodyModel(posekit::read_shape_space(argv[1]), *posekit::load_makehuman_model(argv[2])), Eigen::MatrixXd());'
  [evaluation]='#include "posekit/evaluation/body_evaluation.h"|posekit::evaluate_bodies(argv[1]);'
  [population]='#include "posekit/population/ansur.h"|posekit::read_survey(argv[1]);'
  [viewers]='#include "posekit/viewers/viewer.h"|posekit::render_panels_png({}, posekit::ViewOptions(), argv[1]);'
)
modules=$(grep -o 'set(posekit_MODULES [a-z ]*)' "$prefix/lib/cmake/posekit/posekitConfig.cmake" | sed 's/set(posekit_MODULES //; s/)//')
printf 'cmake_minimum_required(VERSION 3.16)\nproject(posekit_consumers CXX)\nset(CMAKE_CXX_STANDARD 17)\n' > "$consumers/CMakeLists.txt"
for m in $modules; do
  [ -n "${call[$m]:-}" ] || { echo "check-install: no consumer program for the exported target posekit::$m: add one" >&2; exit 1; }
  mkdir -p "$consumers/$m"
  { echo "${call[$m]%%|*}"; echo '#include <iostream>'
    echo "int main(int argc, char** argv) { if (argc > 99) { ${call[$m]#*|} } std::cout << \"posekit::$m linked\\n\"; }"; } > "$consumers/$m/main.cpp"
  printf 'find_package(posekit 0.2 REQUIRED COMPONENTS %s)\nadd_executable(use_%s main.cpp)\ntarget_link_libraries(use_%s PRIVATE posekit::%s)\n' "$m" "$m" "$m" "$m" > "$consumers/$m/CMakeLists.txt"
  echo "add_subdirectory($m)" >> "$consumers/CMakeLists.txt"
done
cmake -S "$consumers" -B "$consumers/build" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$consumers/build" -j"$(nproc 2>/dev/null || echo 2)" > /dev/null
for m in $modules; do
  "$consumers/build/$m/use_$m"
  # shellcheck disable=SC2046
  g++ "$consumers/build/$m/CMakeFiles/use_$m.dir/main.cpp.o" -o "$consumers/pc_$m" $(pkg-config --libs --static posekit-$m)
  "$consumers/pc_$m" > /dev/null
done
echo "consumers: $(echo $modules | wc -w) exported targets, each linked by find_package(posekit COMPONENTS <it>) and by pkg-config --static posekit-<it>"
echo "== install check: find_package and pkg-config consumers built and ran"
