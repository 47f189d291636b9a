#!/usr/bin/env bash
# Trains DKGM with each loss-form set at one budget and seed, evaluates every
# run with the default model's evaluation (30 fixed S5 clips, five clip sets)
# and writes what docs/RESULTS.md compares: Table 1 in the paper's units,
# the physical errors, the codes' match to the prior, the discriminator's
# accuracy over training, the training curves and samples side by side.
#   scripts/compare-loss-forms.sh [ITERATIONS]          (default 2000)
#   MM_FORMS="frame-norm reference" scripts/compare-loss-forms.sh
# A form set is a preset, `frame-norm` (the default's), `paper` (the paper's
# equations as written) or `reference`, or one reference form alone on the
# frame-norm losses: `angle`, `position`, `mmd`, `adversarial`. Runs land in
# runs/losses/<set> (a run whose model exists is not trained again); the
# evaluations are copied to docs/results/losses/<set>.json, and the tables
# of Table 1, physical errors and prior match list every set evaluated there
# so far. The discriminator's windows and the samples picture compare the
# sets of this invocation: table-discriminator-<sets>.md, samples-<sets>.svg.
# Each run trains on one thread, so two can run side by side on two cores
# (two invocations of one set each, then one of both for their pictures).
set -euo pipefail
cd "$(dirname "$0")/.."
iterations=${1:-2000}
tool=${MM_TOOL:-build/model/tool/motion-manifold}  # MM_TOOL: a copy, to rebuild meanwhile
out=docs/results/losses
mkdir -p runs/losses "$out"
[ -f runs/h36m.mmd ] || "$tool" prepare --data data --out runs/h36m.mmd
forms=(${MM_FORMS:-frame-norm reference})

# The form sets, in the tables' order, and what each is: its training
# options (`options`) and its name in pictures and tables (`label`).
known_sets=(frame-norm paper reference angle position mmd adversarial)
describe() {
  case $1 in
    frame-norm) options="--losses frame-norm" label="DKGM frame-norm losses" ;;
    paper | reference) options="--losses $1" label="DKGM $1's losses" ;;
    angle) options="--loss-angle triplet-mean" label="DKGM frame-norm + reference's angle" ;;
    position) options="--loss-position standardized-triplet-mean" label="DKGM frame-norm + reference's position" ;;
    mmd) options="--loss-mmd seven-scales" label="DKGM frame-norm + reference's MMD" ;;
    adversarial) options="--loss-adversarial batch-sum" label="DKGM frame-norm + reference's adversarial" ;;
    *) echo "compare-loss-forms.sh: unknown form set $1" >&2; exit 2 ;;
  esac
}

for set in "${forms[@]}"; do
  describe "$set"
  run=runs/losses/$set
  if [ ! -f "$run/model/manifest.json" ]; then
    # shellcheck disable=SC2046
    OMP_NUM_THREADS=1 "$tool" train --variant DKGM --dataset runs/h36m.mmd --out "$run" --iterations "$iterations" \
      --hidden 256 --batch 30 --seed 1 $options 2> "$run.log"
  fi
  [ -f "$run/evaluation.json" ] ||
    "$tool" evaluate --model "$run/model" --dataset runs/h36m.mmd --out "$run/evaluation.json" > /dev/null
  cp "$run/evaluation.json" "$out/$set.json"
  "$tool" plot-log --log "$run/train_log.csv" --columns L_ang,L_pos,L_W,L_G,L_D,D_acc --smooth 10 \
    --title "$label" --out "$out/curves-$set.svg"
  "$tool" sample --model "$run/model" --count 3 --seed 7 --out-dir "$run/samples"
done

named=()
for set in "${known_sets[@]}"; do
  describe "$set"
  if [ -f "$out/$set.json" ]; then named+=("$label=$out/$set.json"); fi
done
for table in paper physical prior; do
  python3 scripts/results_table.py --table "$table" "${named[@]}" > "$out/table-$table.md"
done
logs=()
for set in "${forms[@]}"; do logs+=("$set=runs/losses/$set/train_log.csv"); done
these=$(IFS=-; echo "${forms[*]}")
python3 scripts/log_windows.py --column D_acc --column L_G --column L_D --windows 4 "${logs[@]}" \
  > "$out/table-discriminator-$these.md"

# The same three prior codes decoded by each model, one row per model and sample.
inputs=() labels=()
for set in "${forms[@]}"; do
  for i in 0 1 2; do
    inputs+=(--input "runs/losses/$set/samples/sample_00$i.txt")
    labels+=(--label "$set, sample $((i + 1))")
  done
done
"$tool" render "${inputs[@]}" "${labels[@]}" --title "Samples from N(0, I), seed 7: DKGM by loss forms" \
  --out "$out/samples-$these.svg"
echo "compare-loss-forms: tables, curves and samples in $out"
