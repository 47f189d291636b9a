#!/usr/bin/env bash
# Which way the manifold turns (docs/RESULTS.md, "Motions that travel"): the
# training subjects' walking turns, and the decoded turn of S1's and S5's
# walking takes as recorded and mirrored (scripts/turn_bias.py). Needs the
# built tool and the extracted H3.6M; about 2 min on 2 cores.
#   scripts/turn-results.sh [MODEL_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
model=${1:-models/h36m-dkgm-h100}
bash scripts/extract-h36m.sh
mkdir -p docs/results/turns
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
python3 scripts/turn_bias.py "$model" build/model/tool/motion-manifold data/h3.6m/dataset "$scratch" \
  S1/walking_1 S6/walking_1 S5/walking_1 S5/walking_2 S5/walkingdog_1 S5/walkingtogether_1 \
  | tee docs/results/turns/turns.md
