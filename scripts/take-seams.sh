#!/usr/bin/env bash
# Measures where a take's windows meet (docs/RESULTS.md, "Whole takes"):
# every S5 take of the 15 actions (the paper's test subject, trial 1) through
# the model as one take, crossfaded and cut, with the first one's per-frame
# error over time as a picture. Needs the built tool and the extracted H3.6M.
#   scripts/take-seams.sh [MODEL_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
model=${1:-models/h36m-dkgm-h100}
tool=build/model/tool/motion-manifold
s5=data/h3.6m/dataset/S5
inputs=()
for action in walking eating smoking discussion directions greeting phoning posing purchases sitting \
  sittingdown takingphoto waiting walkingdog walkingtogether; do
  [ -f "$s5/${action}_1.txt" ] && inputs+=(--input "$s5/${action}_1.txt")
done
mkdir -p docs/results
"$tool" take-seams --model "$model" "${inputs[@]}" --out docs/results/take-seams.json --svg docs/take-error.svg
