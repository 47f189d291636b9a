#!/usr/bin/env bash
# The main job on a fresh machine: installs what it needs, builds the tool,
# prepares H3.6M from ../shared and runs the shipped default model
# (models/h36m-dkgm-h100): Table 1 errors and the denoising experiment on the
# 30 fixed S5 test clips, random samples from the prior, and a picture of
# them. Outputs land in runs/demo (git-ignored).
# TRAIN_ITERATIONS=N also trains a small model from scratch for N iterations
# and evaluates it the same way.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/extract-h36m.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMM_BUILD_TESTS=OFF
cmake --build build -j "$(nproc)" --target motion-manifold
tool=build/model/tool/motion-manifold
out=runs/demo
mkdir -p "$out"
[ -f runs/h36m.mmd ] || "$tool" prepare --data data --out runs/h36m.mmd
"$tool" evaluate --dataset runs/h36m.mmd --out "$out/evaluation.json" > /dev/null
"$tool" sample --count 3 --seed 1 --out-dir "$out/samples"
"$tool" render --input "$out/samples/sample_000.txt" --input "$out/samples/sample_001.txt" \
  --input "$out/samples/sample_002.txt" --rate 25 --out "$out/samples.svg"
if [ -n "${TRAIN_ITERATIONS:-}" ]; then
  "$tool" train --variant DKGM --dataset runs/h36m.mmd --out "$out/train" --iterations "$TRAIN_ITERATIONS" \
    --hidden 256 --batch 30
  "$tool" evaluate --model "$out/train/model" --dataset runs/h36m.mmd --out "$out/train/evaluation.json" > /dev/null
fi
echo "demo: outputs in $out"
