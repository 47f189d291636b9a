#!/usr/bin/env bash
# The gap benchmark of docs/RESULTS.md ("Gaps: filling missing joints"):
# every S5 take present, at 25 Hz, with joints made missing at seeded places
# (gaps of 0.2, 0.5, 1, 2 and 4 s of 1 joint, 5 joints and every joint),
# filled by hold, slerp, cubic, the manifold as it is and the border-matched
# manifold, measured against the recording. Writes docs/results/gaps/.
# Two runs of each take (about 8 gaps per take, 20 per configuration); on
# two CPU cores it takes about 5 minutes. Needs the built tool and the
# extracted H3.6M.
#   scripts/gap-results.sh [MODEL_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
model=${1:-models/h36m-dkgm-h100}
tool=build/model/tool/motion-manifold
s5=data/h3.6m/dataset/S5
inputs=()
for file in "$s5"/*.txt; do inputs+=(--input "$file"); done
mkdir -p docs/results/gaps
"$tool" evaluate-gaps --model "$model" "${inputs[@]}" --rounds 2 --seed 0 \
  --out docs/results/gaps/gaps.json --markdown docs/results/gaps/gaps.md
