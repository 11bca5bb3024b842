#!/usr/bin/env bash
# Set-up command 1: install what is missing, build, run the main job on the default data.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh release posekit
data=${POSEKIT_DATA:-../shared/datasets/makehuman}
posekit=build/release/bin/posekit
echo "== posekit info: the MakeHuman base mesh (skin group) from $data"
"$posekit" info "$data/3dobjs/base.obj" --unit dm --group body
