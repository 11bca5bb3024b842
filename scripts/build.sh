#!/usr/bin/env bash
# scripts/build.sh <release|asan> [targets...]: configure (once) and build into build/<type>.
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:-release}; shift || true
case "$kind" in
  release) flags=(-DCMAKE_BUILD_TYPE=Release) ;;
  asan)    flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DPOSEKIT_SANITIZE=ON) ;;
  *) echo "build.sh: unknown build '$kind' (release|asan)" >&2; exit 2 ;;
esac
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
if [ ! -f "build/$kind/CMakeCache.txt" ]; then
  cmake -S . -B "build/$kind" "${generator[@]}" "${flags[@]}" >/dev/null
fi
jobs=$(nproc 2>/dev/null || echo 2)
if [ $# -gt 0 ]; then
  cmake --build "build/$kind" --parallel "$jobs" --target "$@"
else
  cmake --build "build/$kind" --parallel "$jobs"
fi
