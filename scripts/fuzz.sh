#!/usr/bin/env bash
# scripts/fuzz.sh [SECONDS] [TARGET...]: fuzz posekit's file readers, measuring and pose fitting with
# libFuzzer under AddressSanitizer + UndefinedBehaviorSanitizer, each target for SECONDS (default 60),
# one per core at a time. Targets: ply obj off stl pcd xyz bvh pose_json pkm pks measure (the default: all
# these), and fit, only when named (it trains a model on the small dataset once: POSEKIT_DATA must
# point at the MakeHuman assets).
#   1. builds the targets in the sanitizer build with clang (scripts/build.sh asan: build/asan),
#   2. writes the seed corpus with the tests (release build: FuzzSeeds.*, *.WritesFuzzSeeds*),
#   3. runs each target on build/fuzz/corpus/<target> (kept between runs) plus the seeds.
# A finding (crash, sanitizer report, an exception other than posekit::Error, a single allocation over
# 256 MB, over 1 GB resident, an input taking over 10 s) fails the run; its input is kept as
# build/fuzz/findings/<target>-<kind>-<hash>. Prints executions and executions per second per target.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(ply obj off stl pcd xyz bvh pose_json pkm pks measure)
fit=OFF
for t in "${targets[@]}"; do [ "$t" = fit ] && fit=ON; done
case "$seconds" in ''|*[!0-9]*) echo "fuzz.sh: SECONDS must be a whole number, got '$seconds'" >&2; exit 2 ;; esac
command -v clang++ >/dev/null || { echo "fuzz.sh: needs clang (apt-get install clang libclang-rt-14-dev)" >&2; exit 1; }

export POSEKIT_DATA=${POSEKIT_DATA:-$(cd .. && pwd)/shared/datasets/makehuman}  # the measure and fit seeds' bodies
if [ -f build/asan/CMakeCache.txt ] && ! grep -q '^CMAKE_CXX_COMPILER:.*clang' build/asan/CMakeCache.txt; then
  echo "fuzz.sh: build/asan was configured with another compiler than clang, so it has no fuzz targets: remove build/asan" >&2
  exit 1
fi
jobs=$(nproc 2>/dev/null || echo 2)
CC=clang CXX=clang++ bash scripts/build.sh asan $(printf 'fuzz_%s ' "${targets[@]}")

bash scripts/build.sh release posekit_io_tests posekit_deformation_tests posekit_registration_tests posekit_shape_tests posekit
seeds=$PWD/build/fuzz/seeds
rm -rf "$seeds" && mkdir -p "$seeds" build/fuzz/findings
POSEKIT_FUZZ_SEEDS=$seeds build/release/tests/posekit_io_tests --gtest_filter='FuzzSeeds.*' >/dev/null
POSEKIT_FUZZ_SEEDS=$seeds build/release/tests/posekit_deformation_tests --gtest_filter='PoseModel.WritesFuzzSeeds*' >/dev/null
POSEKIT_FUZZ_SEEDS=$seeds build/release/tests/posekit_registration_tests --gtest_filter='ShapeSpace.WritesFuzzSeeds*' >/dev/null
POSEKIT_FUZZ_SEEDS=$seeds build/release/tests/posekit_shape_tests --gtest_filter='Measurements.WritesFuzzSeeds*' >/dev/null
if [ "$fit" = ON ]; then
  # fit's target fits this model (trained once on the small dataset) to a small body of the seeds.
  export POSEKIT_FUZZ_MODEL=$PWD/build/fuzz/fit-model.pkm POSEKIT_FUZZ_SUBJECT=$seeds/measure/woman_small.ply
  if [ ! -f "$POSEKIT_FUZZ_MODEL" ]; then
    build/release/bin/posekit dataset make --small --force --out build/fuzz/fit-dataset >/dev/null
    build/release/bin/posekit train --dataset build/fuzz/fit-dataset --out "$POSEKIT_FUZZ_MODEL" >/dev/null
  fi
fi

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
run_one() {
  local target=$1 seconds=$2 log=build/fuzz/$1.log
  mkdir -p "build/fuzz/corpus/$target" "$seeds/$target"
  local tmp max_len=16384
  case "$target" in measure|fit) max_len=65536 ;; esac  # small bodies, not only small files
  tmp=$(mktemp -d)
  if TMPDIR=$tmp "build/asan/tests/fuzz/fuzz_$target" "build/fuzz/corpus/$target" "$seeds/$target" \
      -max_total_time="$seconds" -rss_limit_mb=1024 -malloc_limit_mb=256 -timeout=10 -max_len="$max_len" \
      -print_final_stats=1 -artifact_prefix="build/fuzz/findings/$target-" >"$log" 2>&1; then
    local runs rate
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log")
    printf 'fuzz %-10s %3ss  %10s executions  %6s/s  corpus %s files  no finding\n' \
      "$target" "$seconds" "$runs" "$rate" "$(ls "build/fuzz/corpus/$target" | wc -l)"
  else
    printf 'fuzz %-10s FINDING (see %s):\n' "$target" "$log"
    grep -E "ERROR|SUMMARY|fuzz: not a posekit|Test unit written" "$log" | head -5 | sed 's/^/    /'
    rm -rf "$tmp"
    return 1
  fi
  rm -rf "$tmp"
}
export -f run_one
export seeds
status=0
# POSEKIT_FUZZ_PARALLEL: targets at once (default: one per core).
printf '%s\n' "${targets[@]}" | xargs -P "${POSEKIT_FUZZ_PARALLEL:-$jobs}" -I{} bash -c 'run_one "$@"' _ {} "$seconds" || status=1
exit $status
