#!/usr/bin/env bash
# Set-up command 1: install what is missing, build, run the main job on the default data.
#   bash scripts/run-main.sh          the short job (about a minute after the build): a body, a
#                                     measurement, a pose, a comparison with a scan, a small report
#   bash scripts/run-main.sh --full   the paper's whole evaluation: the 16-subject dataset, every
#                                     model trained, the full report (about 8 minutes after the build)
set -euo pipefail
cd "$(dirname "$0")/.."
full=0
case "${1:-}" in
  --full) full=1 ;;
  "") ;;
  *) echo "usage: bash scripts/run-main.sh [--full]" >&2; exit 2 ;;
esac
bash scripts/install-deps.sh
bash scripts/build.sh release posekit
data=${POSEKIT_DATA:-$(cd .. && pwd)/shared/datasets/makehuman}
export POSEKIT_DATA=$data
posekit=build/release/bin/posekit
out=out
mkdir -p "$out"

if [ "$full" = 0 ]; then
  start=$SECONDS
  echo "== a body from sliders, with its 16-part labels and joints (MakeHuman's CC0 assets in $data)"
  "$posekit" body --gender 1 --weight 0.8 --height 0.55 --labels --joints "$out/quick_body_joints.json" --out "$out/quick_body.ply"
  echo "== a small evaluation dataset: a template in 31 poses, two customized subjects with ground truth and scans"
  "$posekit" dataset make --small --out "$out/quick" --force > /dev/null
  echo "== measurements of a subject, from its mesh and from its simulated scan (truth: $out/quick/subjects/f01/measurements.json)"
  "$posekit" measure "$out/quick/subjects/f01/rest.ply" --contours "$out/quick_f01_tapes.obj"
  "$posekit" measure "$out/quick/scans/f01/rest.pcd"
  echo "== pose deformation: learn T^Q (Eq. 3-5), pose the subject in a held-out pose and along real motion capture"
  "$posekit" train --dataset "$out/quick" --calibration-bodies 16 --out "$out/quick.pkm"
  "$posekit" pose --model "$out/quick.pkm" --subject "$out/quick/subjects/f01/rest.ply" \
    --pose "$out/quick/subjects/f01/posed/squat_half.json" --out "$out/quick_f01_squat_half.ply"
  cmu=$(dirname "$data")/motions/cmu/01_01.bvh
  if [ -f "$cmu" ]; then
    "$posekit" pose --model "$out/quick.pkm" --subject "$out/quick/subjects/f01/rest.ply" --pose "$cmu" --frames 0:240 \
      --out "$out/quick_walk/frame.ply" --mkdir
  fi
  echo "== the posed subject against a scan of the person in that pose: distances, girths, heatmap, glTF"
  "$posekit" compare "$out/quick_f01_squat_half.ply" "$out/quick/scans/f01/squat_half.pcd" --measure \
    --png "$out/quick_f01_squat_half.png" --out "$out/quick_f01_squat_half.glb"
  echo "== a small report: the paper's figures and tables on the small dataset"
  "$posekit" report --dataset "$out/quick" --model "$out/quick.pkm" --out "$out/quick_report" --runs 1 --nicp-subjects 0 \
    --customization-bodies 30
  echo "== done in $((SECONDS - start)) s after the build: open $out/quick_report/index.html"
  echo "== the paper's whole evaluation (16 subjects, every model, the full report): bash scripts/run-main.sh --full"
  exit 0
fi

echo "== the MakeHuman base mesh (skin group) from $data"
"$posekit" info "$data/3dobjs/base.obj" --unit dm --group body
echo "== a body from sliders, with its 16-part labels and joint centres"
"$posekit" body --gender 1 --weight 0.8 --height 0.55 --labels --save-spec "$out/subject.json" \
  --joints "$out/subject_joints.json" --out "$out/subject_rest.ply"
echo "== the same body posed by the MakeHuman benchmark BVH (linear blend and dual quaternion skinning)"
"$posekit" body --spec "$out/subject.json" --pose "$data/poses/benchmark.bvh" --out "$out/subject_benchmark_lbs.ply"
"$posekit" body --spec "$out/subject.json" --pose "$data/poses/benchmark.bvh" --skinning dqs --out "$out/subject_benchmark_dqs.ply"
echo "== the evaluation dataset: template, pose dataset, 16 subjects with ground truth, scans, photos"
"$posekit" dataset make --out "$out/dataset" --force
"$posekit" dataset info "$out/dataset"
echo "== measurements of a customized subject, from its mesh and from its simulated scan (ground truth in measurements.json)"
"$posekit" measure "$out/dataset/subjects/f01/rest.ply"
"$posekit" measure "$out/dataset/scans/f01/rest.pcd"
echo "== ct-FFD registration of the template to a subject (Table 1 is in the report below)"
"$posekit" register "$out/dataset/template/rest.ply" "$out/dataset/subjects/f01/rest.ply" \
  --out "$out/f01_correspondence.json" --deformed "$out/template_on_f01.ply"
echo "== pose deformation: learn T^Q on the pose dataset, pose a customized subject, accuracy and speed"
"$posekit" train --dataset "$out/dataset" --out "$out/model.pkm"
"$posekit" segment "$out/dataset/subjects/m05/rest.ply" --model "$out/model.pkm" --out "$out/m05_parts.ply" \
  --joints "$out/m05_joints.json"
"$posekit" pose --model "$out/model.pkm" --subject "$out/dataset/subjects/m05/rest.ply" \
  --pose "$out/dataset/subjects/m05/posed/squat_half.json" --out "$out/m05_squat_half.ply"
"$posekit" pose --model "$out/model.pkm" --subject "$out/subject_rest.ply" --pose "$data/poses/benchmark.bvh" \
  --out "$out/subject_benchmark_learned.ply"
"$posekit" eval pose --dataset "$out/dataset" --model "$out/model.pkm"
motions=$(dirname "$data")/motions
"$posekit" bench pose --dataset "$out/dataset" --runs 3 --poses 20 --motion "$motions/cmu/01_01.bvh"
echo "== meshes alone, anatomical ground truth: train without pose JSONs; the cross-generator test with joint offsets"
mkdir -p "$out/meshes_only"
cp "$out"/dataset/pose_dataset/*.ply "$out/meshes_only/"
"$posekit" train --dataset "$out/meshes_only" --calibration-bodies 0 --out "$out/meshes_only.pkm" --fit-report "$out/meshes_only_fits.json"
"$posekit" eval pose --dataset "$out/meshes_only" --every 5
"$posekit" dataset make --driving anatomical --out "$out/anatomical" --force
"$posekit" dataset make --driving anatomical-alternative --out "$out/anatomical_alt" --force
"$posekit" train --dataset "$out/anatomical" --joint-offsets --out "$out/anatomical.pkm"
"$posekit" eval pose --dataset "$out/anatomical_alt" --model "$out/anatomical.pkm"
echo "== validation against a scan: distances, coverage, girth discrepancies, heatmap (off-screen VTK)"
"$posekit" compare "$out/m05_squat_half.ply" "$out/dataset/scans/m05/squat_half.pcd" --out "$out/m05_squat_half_errors.ply" \
  --png "$out/m05_squat_half_errors.png"
"$posekit" compare "$out/dataset/subjects/f01/rest.ply" "$out/dataset/scans/f01/rest.pcd" --measure
"$posekit" bench compare --runs 3
echo "== customization from two photos (section 3.2): the population model, one subject, all 16 against truth"
"$posekit" customize train --out "$out/customization.pkc"
"$posekit" customize --front "$out/dataset/photos/f01/front.png" --side "$out/dataset/photos/f01/side.png" \
  --camera "$out/dataset/photos/f01/camera.json" --model "$out/customization.pkc" --out "$out/f01_from_photos.ply" --measure
"$posekit" customize eval --dataset "$out/dataset" --model "$out/customization.pkc" --variation all --json "$out/customization_eval.json"
"$posekit" bench customize --dataset "$out/dataset" --model "$out/customization.pkc" --runs 3
echo "== the report: the paper's figures and tables regenerated from the dataset"
"$posekit" report --dataset "$out/dataset" --model "$out/model.pkm" --customization "$out/customization.pkc" --out "$out/report"
echo "== results in $out/ (PLY files open in MeshLab, CloudCompare, ParaView; scans are PCD in mm)"
echo "== open $out/report/index.html"
