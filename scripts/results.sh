#!/usr/bin/env bash
# Regenerates everything docs/RESULTS.md shows from a trained model: the
# Table 1 evaluation with the denoising experiment, the pictures of the four
# applications of Sec. 5 and the training curves. Needs the built tool
# (cmake --build build --target motion-manifold) and the extracted H3.6M.
#   scripts/results.sh [MODEL_DIR] [TRAIN_LOG]
# The evaluation is written to MODEL_DIR/evaluation.json, the file that the
# model card describes, DescribeModel serves and the table loop of
# docs/RESULTS.md reads (scripts/results_table.py NAME=MODEL_DIR/evaluation.json).
set -euo pipefail
cd "$(dirname "$0")/.."
model=${1:-models/h36m-dkgm-h100}
log=${2:-$model/train_log.csv}
tool=build/model/tool/motion-manifold
s5=data/h3.6m/dataset/S5
out=docs/results
work=runs/results
mkdir -p "$out" "$work"
[ -f runs/h36m.mmd ] || "$tool" prepare --data data --out runs/h36m.mmd

# Table 1 and denoising over the 30 fixed S5 clips.
"$tool" evaluate --model "$model" --dataset runs/h36m.mmd --out "$model/evaluation.json" > /dev/null

# Sec. 5.2: random samples from the prior.
"$tool" sample --model "$model" --count 3 --seed 7 --out-dir "$work/samples"
"$tool" render --input "$work/samples/sample_000.txt" --input "$work/samples/sample_001.txt" \
  --input "$work/samples/sample_002.txt" --label "sample 1" --label "sample 2" --label "sample 3" --rate 25 \
  --title "Random samples from the prior N(0, I)" --out "$out/samples.svg"

# Sec. 5.3: interpolation from sitting to walking (S5).
"$tool" interpolate --model "$model" --from "$s5/sitting_1.txt" --to "$s5/walking_1.txt" --steps 5 \
  --start-from 400 --out-dir "$work/interpolation"
"$tool" render --input "$s5/sitting_1.txt" $(for i in 0 1 2 3 4; do echo --input "$work/interpolation/interpolation_00$i.txt"; done) \
  --input "$s5/walking_1.txt" --rate 50,25,25,25,25,25,50 --start 400,0,0,0,0,0,0 --length 150 \
  --label "S5 sitting" --label "t = 0" --label "t = 0.25" --label "t = 0.5" --label "t = 0.75" --label "t = 1" \
  --label "S5 walking" --title "Interpolation sitting to walking (linear in z)" --out "$out/interpolation.svg"

# Sec. 5.4: denoising with the paper's corruption (half the joint angles
# zeroed), projected as it is and with the zeros treated as missing.
"$tool" denoise --model "$model" --input "$s5/walking_2.txt" --corrupt-probability 0.5 --corruption zeroed --seed 3 \
  --corrupted-out "$work/corrupted.txt" --out "$work/denoised.txt"
"$tool" denoise --model "$model" --input "$s5/walking_2.txt" --corrupt-probability 0.5 --corruption zeroed --seed 3 \
  --zeros-are-missing --out "$work/denoised-zeros-missing.txt"
"$tool" render --input "$s5/walking_2.txt" --input "$work/corrupted.txt" --input "$work/denoised.txt" \
  --input "$work/denoised-zeros-missing.txt" --rate 50,25,25,25 --length 150 --label "ground truth" \
  --label "corrupted" --label "projected" --label "zeros as missing" \
  --title "Denoising: S5 walking, each joint angle zeroed with p = 0.5" --out "$out/denoising.svg"

# Sec. 5.5: analogy a - b + c.
"$tool" analogy --model "$model" --a "$s5/walkingdog_1.txt" --b "$s5/walking_1.txt" --c "$s5/sitting_1.txt" \
  --start-c 400 --out "$work/analogy.txt"
"$tool" render --input "$s5/walkingdog_1.txt" --input "$s5/walking_1.txt" --input "$s5/sitting_1.txt" \
  --input "$work/analogy.txt" --rate 50,50,50,25 --start 0,0,400,0 --length 150 \
  --label "a: walking dog" --label "b: walking" --label "c: sitting" --label "a - b + c" \
  --title "Analogy: walking dog - walking + sitting (S5)" --out "$out/analogy.svg"

# Training curves.
"$tool" plot-log --log "$log" --columns L_ang,L_pos,L_M,L_W,L_G,L_D --smooth 10 --out "$out/training_curves.svg"
echo "results: evaluation in $model/evaluation.json (scripts/results_table.py prints its tables), pictures in $out"
