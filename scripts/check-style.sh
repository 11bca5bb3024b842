#!/usr/bin/env bash
# The layout and size checks CI runs (seconds, no build): every C++ file as .clang-format lays it
# out, and no function over 150 lines but those scripts/function-size-allowance.txt still allows
# (each no longer than it is allowed). `scripts/check-style.sh --fix` formats the files in place.
# clang-tidy (.clang-tidy) needs a build's compile_commands.json and runs by hand:
#   run-clang-tidy -p build/release -quiet 'modules/.*\.cpp'
set -euo pipefail
cd "$(dirname "$0")/.."
if git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  mapfile -t files < <(git ls-files '*.cpp' '*.h')
else  # an unpacked source tree
  mapfile -t files < <(find modules datasets tools viewers python examples tests \( -name '*.cpp' -o -name '*.h' \) | sort)
fi
[ ${#files[@]} -gt 0 ] || { echo "check-style: no C++ files found" >&2; exit 1; }
if [ "${1:-}" = "--fix" ]; then
  clang-format -i --style=file "${files[@]}"
  echo "check-style: formatted ${#files[@]} files"
  exit 0
fi
if ! clang-format --dry-run --Werror --style=file "${files[@]}" 2> /tmp/posekit-format.$$; then
  grep -m 20 'error:' /tmp/posekit-format.$$ >&2 || true
  rm -f /tmp/posekit-format.$$
  echo "check-style: files not laid out as .clang-format says; run scripts/check-style.sh --fix" >&2
  exit 1
fi
rm -f /tmp/posekit-format.$$
echo "check-style: ${#files[@]} files laid out as .clang-format says"
python3 scripts/function-sizes.py --check
