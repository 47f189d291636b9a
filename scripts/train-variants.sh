#!/usr/bin/env bash
# Trains every Table 1 variant with the same short budget and evaluates each
# with the default model's evaluation (30 fixed S5 clips, seed 0): an
# ablation at equal cost, far shorter than the paper's training.
#   scripts/train-variants.sh [ITERATIONS] [HIDDEN]     (default 1000, 256)
#   MM_VARIANTS="DK DKG" scripts/train-variants.sh     (a subset; default all)
# Runs land in runs/variants/<variant>; the evaluations are copied to
# docs/results/variants/<variant>.json for docs/RESULTS.md.
set -euo pipefail
cd "$(dirname "$0")/.."
iterations=${1:-1000}
hidden=${2:-256}
tool=${MM_TOOL:-build/model/tool/motion-manifold}  # MM_TOOL: a copy, to rebuild meanwhile
mkdir -p runs/variants docs/results/variants
[ -f runs/h36m.mmd ] || "$tool" prepare --data data --out runs/h36m.mmd
for variant in ${MM_VARIANTS:-S D DK DKG DKGM DKGMZ Seq2seq}; do
  run=runs/variants/$variant
  "$tool" train --variant "$variant" --dataset runs/h36m.mmd --out "$run" --iterations "$iterations" \
    --hidden "$hidden" --batch 30 --seed 1 2> "$run.log"
  "$tool" evaluate --model "$run/model" --dataset runs/h36m.mmd --out "$run/evaluation.json" > /dev/null
  cp "$run/evaluation.json" "docs/results/variants/$variant.json"
  echo "$variant: $(tail -c 200 "$run.log" | tr '\r' '\n' | grep -E '^(finished|cancelled)' | tail -1)"
done
