#!/usr/bin/env bash
# Measures the generated root paths and the feet on the floor
# (docs/RESULTS.md, "Motions that travel"): every S5 take at 25 Hz cut into
# 6 s clips every 2 s, each encoded and decoded by the model with its
# trajectory network, against the recorded root and two baselines, and the
# skating of recorded, reconstructed, sampled and interpolated motion with
# and without the feet planted. Writes the tables (markdown), the JSON and
# the top-down path picture. Needs the built tool and the extracted H3.6M.
#   scripts/trajectory-results.sh [MODEL_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
model=${1:-models/h36m-dkgm-h100}
tool=build/model/tool/motion-manifold
bash scripts/extract-h36m.sh
mkdir -p docs/results/trajectory
"$tool" evaluate-trajectory --model "$model" --data data --out docs/results/trajectory/evaluation.json \
  --svg docs/results/trajectory/paths.svg > docs/results/trajectory/tables.md
cat docs/results/trajectory/tables.md
