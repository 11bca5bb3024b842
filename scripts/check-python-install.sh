#!/usr/bin/env bash
# The two Python routes of the README, each into a fresh venv over Debian's packages, offline:
# `pip install --no-build-isolation .` (then the module's tests run against that install), and a
# wheel from `python3 -m build --wheel --no-isolation` installed on its own.
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python=/usr/bin/python3
"$python" -m venv --system-site-packages "$work/pip"
"$work/pip/bin/pip" install -q --no-build-isolation --no-index . 2>&1 | grep -v "^\s*$" || true
"$work/pip/bin/python" -c "import posekit, sys; assert posekit.__file__.startswith('$work/pip'), posekit.__file__; print('pip route:', posekit.__version__, posekit.__file__)"
POSEKIT_CLI=$PWD/build/release/bin/posekit "$work/pip/bin/python" -m pytest -q python/tests
"$python" -m build --wheel --no-isolation --outdir "$work/dist" . >"$work/build.log" 2>&1 || { cat "$work/build.log"; exit 1; }
"$python" -m venv --system-site-packages "$work/wheel"
"$work/wheel/bin/pip" install -q --no-index "$work"/dist/posekit-*.whl
(cd "$work" && "$work/wheel/bin/python" -c "
import posekit
assert posekit.__file__.startswith('$work/wheel'), posekit.__file__
assert len(posekit.joint_names) == 15 and len(posekit.part_names) == 16
import pathlib
assert (pathlib.Path(posekit.__file__).parent / 'posekit.pyi').is_file(), 'no type stubs beside the module'
print('wheel route:', posekit.__version__, posekit.__file__)")
