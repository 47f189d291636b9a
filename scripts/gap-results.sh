#!/usr/bin/env bash
# The gap, keyframe and transition benchmarks of docs/RESULTS.md ("Gaps:
# filling missing joints"), on every S5 take present at 25 Hz:
# - evaluate-gaps: joints made missing at seeded places (gaps of 0.2, 0.5,
#   1, 2 and 4 s of 1 joint, 5 joints and every joint), filled by hold,
#   slerp, cubic, the manifold as it is, the matched fill as it was, the
#   fitted fill and the borrowed fill (the default: the take's own stretch
#   where one is like the gap's surroundings, the fitted fill elsewhere),
#   measured against the recording (one run of each take, about 6 gaps a
#   take);
# - evaluate-gaps again on the long every-joint gaps alone (2 and 4 s),
#   about 65 a length, where a share of 7 to 12 gaps in the first run is
#   too few to tell the fills from interpolation;
# - evaluate-keyframes: one pose every 0.5, 1 and 2 s of the first 12 s of
#   one take of each action, the rest filled;
# - evaluate-transitions: a 5 s clip of each take joined to one of another
#   action by transitions of 0.5 to 4 s, generated and crossfaded.
# The fills are measured with their defaults (GapFillOptions and
# GapCodeFitOptions: the detail weights chosen on S1 and S6, every joint at
# 4 s lowered by S5's trial-1 takes; the borrowed fill's cost bound chosen
# on S5's trial-1 takes; the bound on an in-betweening window's fit error
# chosen on S1 and S6), as the take path and the service's DenoiseTake
# fill with keep_observed.
# Writes docs/results/gaps/. On the two idle CPU cores the four runs took
# 12.8 minutes, most of it the fitted codes (15 Adam steps
# through the decoder for each gap of 0.6 s or more). Needs the built tool (or
# MM_TOOL naming a copy of it) and the extracted H3.6M.
#   scripts/gap-results.sh [MODEL_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
model=${1:-models/h36m-dkgm-h100}
tool=${MM_TOOL:-build/model/tool/motion-manifold}
s5=data/h3.6m/dataset/S5
inputs=()
for file in "$s5"/*.txt; do inputs+=(--input "$file"); done
# One take of each action for the keyframes and transitions (the _1 take, or _2 where
# there is no _1), paired across actions.
firsts=()
for file in "$s5"/*_1.txt "$s5"/directions_2.txt "$s5"/sittingdown_2.txt; do
  [[ -f $file ]] && firsts+=(--input "$file")
done
out=docs/results/gaps
mkdir -p "$out"
"$tool" evaluate-gaps --model "$model" "${inputs[@]}" --rounds 1 --seed 0 \
  --out "$out/gaps.json" --markdown "$out/gaps.md"
"$tool" evaluate-gaps --model "$model" "${inputs[@]}" --joints 0 --seconds 2 4 --rounds 1 --seed 0 \
  --out "$out/long-gaps.json" --markdown "$out/long-gaps.md"
"$tool" evaluate-keyframes --model "$model" "${firsts[@]}" --interval 0.5 1 2 --take-seconds 12 \
  --out "$out/keyframes.json" --markdown "$out/keyframes.md"
"$tool" evaluate-transitions --model "$model" "${firsts[@]}" --seconds 0.5 1 2 4 --seed 0 \
  --out "$out/transitions.json" --markdown "$out/transitions.md"
