#!/usr/bin/env bash
# scripts/kill-resume.sh [REPEATS] [WORK_DIR]: kills `posekit batch measure` with SIGKILL at a random
# moment, REPEATS times (default 50), resumes each killed run to its end, and checks that the summary
# is byte-identical to an uninterrupted run's and that no temporary file is left. The inputs: 13
# MakeHuman bodies in 5 formats (PLY, OBJ, OFF, STL, and XYZ points in mm), 65 files.
# Needs a release build (scripts/build.sh release posekit) and the MakeHuman assets (POSEKIT_DATA).
set -euo pipefail
cd "$(dirname "$0")/.."
repeats=${1:-50}
work=${2:-build/kill-resume}
posekit=${POSEKIT_CLI:-$PWD/build/release/bin/posekit}
export POSEKIT_DATA=${POSEKIT_DATA:-$(cd .. && pwd)/shared/datasets/makehuman}
[ -x "$posekit" ] || { echo "kill-resume.sh: no $posekit (bash scripts/build.sh release posekit)" >&2; exit 1; }
case "$repeats" in ''|*[!0-9]*) echo "kill-resume.sh: REPEATS must be a whole number" >&2; exit 2 ;; esac

inputs=$work/inputs
if [ ! -f "$inputs/.complete" ]; then
  rm -rf "$inputs" && mkdir -p "$inputs"
  k=0
  for gender in 0 1; do
    for weight in 0.2 0.5 0.8; do
      for height in 0.3 0.7; do
        [ $k -lt 13 ] || break
        stem=$inputs/body$(printf '%02d' $k)
        "$posekit" body --gender $gender --weight $weight --height $height --out "$stem.ply" >/dev/null 2>&1
        for ext in obj off stl; do "$posekit" convert "$stem.ply" "$stem.$ext" 2>/dev/null; done
        "$posekit" convert "$stem.ply" "$stem.xyz" --to-unit mm 2>/dev/null
        k=$((k + 1))
      done
    done
  done
  # The 13th: a body of middle proportions.
  "$posekit" body --out "$inputs/body12.ply" >/dev/null 2>&1
  for ext in obj off stl; do "$posekit" convert "$inputs/body12.ply" "$inputs/body12.$ext" 2>/dev/null; done
  "$posekit" convert "$inputs/body12.ply" "$inputs/body12.xyz" --to-unit mm 2>/dev/null
  touch "$inputs/.complete"
fi
count=$(find "$inputs" -type f ! -name .complete | wc -l)

reference=$work/reference
rm -rf "$reference"
start=$(date +%s.%N)
"$posekit" batch measure --inputs "$inputs" --out "$reference" --jobs 2 >/dev/null 2>&1 || true
full=$(awk -v a="$(date +%s.%N)" -v b="$start" 'BEGIN { printf "%.2f", a - b }')
echo "kill-resume: $count inputs, an uninterrupted run takes ${full} s; $repeats kills"

identical=0 stray=0 killed_before_end=0
for r in $(seq 1 "$repeats"); do
  out=$work/run
  rm -rf "$out"
  # Kill at a random moment within the run's length (a few runs also before or after).
  delay=$(awk -v seed="$r" -v full="$full" 'BEGIN { srand(seed); printf "%.3f", rand() * full * 1.1 }')
  "$posekit" batch measure --inputs "$inputs" --out "$out" --jobs 2 >/dev/null 2>&1 &
  pid=$!
  sleep "$delay"
  if kill -9 "$pid" 2>/dev/null; then killed_before_end=$((killed_before_end + 1)); fi
  wait "$pid" 2>/dev/null || true
  "$posekit" batch measure --inputs "$inputs" --out "$out" --jobs 2 >/dev/null 2>&1 || true
  if cmp -s "$out/summary.json" "$reference/summary.json" && cmp -s "$out/summary.csv" "$reference/summary.csv"; then
    identical=$((identical + 1))
  else
    echo "  repeat $r (killed after ${delay} s): the resumed summary differs" >&2
  fi
  left=$(find "$out" -name '*.tmp-*' | wc -l)
  if [ "$left" -gt 0 ]; then
    stray=$((stray + 1))
    echo "  repeat $r: $left temporary file(s) left" >&2
  fi
done
echo "kill-resume: $repeats runs ($killed_before_end killed before their end): $identical byte-identical summaries, $stray with temporaries left"
[ "$identical" -eq "$repeats" ] && [ "$stray" -eq 0 ]
