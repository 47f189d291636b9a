#!/usr/bin/env bash
# The main job on a fresh machine: installs what it needs, builds the tool,
# prepares H3.6M from ../shared, trains a small motion manifold for a few
# minutes on the CPU, evaluates it on S5 (Table 1 metrics) and decodes random
# samples from the prior. Outputs land in runs/demo (git-ignored).
# Environment: ITERATIONS (default 300), HIDDEN (default 256).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/extract-h36m.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMM_BUILD_TESTS=OFF
cmake --build build -j "$(nproc)" --target motion-manifold
tool=build/model/tool/motion-manifold
out=runs/demo
mkdir -p "$out"
[ -f "$out/h36m.mmd" ] || "$tool" prepare --data data --out "$out/h36m.mmd"
"$tool" train --variant DKGM --dataset "$out/h36m.mmd" --out "$out/train" \
  --iterations "${ITERATIONS:-300}" --hidden "${HIDDEN:-256}" --batch 8
"$tool" evaluate --model "$out/train/model" --dataset "$out/h36m.mmd" --out "$out/evaluation.json"
"$tool" sample --model "$out/train/model" --count 3 --seed 1 --out-dir "$out/samples"
echo "demo: outputs in $out"
