#!/usr/bin/env bash
# Set-up command 2: install what is missing, build, run every test in a release build and again
# under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
export POSEKIT_DATA=${POSEKIT_DATA:-$(cd .. && pwd)/shared/datasets/makehuman}
jobs=$(nproc 2>/dev/null || echo 2)
bash scripts/build.sh release
echo "== tests (release)"
(cd build/release && ctest --output-on-failure -j"$jobs")
bash scripts/build.sh asan
echo "== tests (AddressSanitizer + UndefinedBehaviorSanitizer)"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
(cd build/asan && ctest --output-on-failure -j"$jobs")
