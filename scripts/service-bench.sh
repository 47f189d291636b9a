#!/usr/bin/env bash
# The service's performance figures in one run on an idle machine
# (docs/PERFORMANCE.md): `motion-manifold bench` for the model alone, then the
# real server on the shipped default model driven by motion-manifold-load:
#   1. one client at a time, Decode of one code, over gRPC and over REST;
#   2. 32 concurrent Decode clients for 60 s (gRPC, then REST);
#   3. one gRPC Decode client while a training job (DKGM at the paper's size)
#      runs in the background;
#   4. the server's resident memory over 100 model activations.
# Results: JSON files and summary.md in $OUT (default docs/results/service).
#   scripts/service-bench.sh [SECONDS_SINGLE=20] [SECONDS_CONCURRENT=60]
set -euo pipefail
cd "$(dirname "$0")/.."
single=${1:-20}
concurrent=${2:-60}
build=${BUILD:-build}
out=${OUT:-docs/results/service}
tool=$build/model/tool/motion-manifold
server=$build/server/motion-manifold-server
load=$build/client/motion-manifold-load
work=runs/service-bench
rm -rf "$work" && mkdir -p "$out" "$work/models" "$work/state" "$work/data"
for model in models/*/; do ln -s "$(pwd)/$model" "$work/models/$(basename "$model")"; done
[ -f runs/h36m.mmd ] || "$tool" prepare --data data --out runs/h36m.mmd
cp runs/h36m.mmd "$work/data/h36m.mmd"

echo "== motion-manifold bench" >&2
"$tool" bench --iterations 5 --out "$out/bench.json" > "$out/bench.md"

"$server" --model-store "$work/models" --state-dir "$work/state" --data-root "$work/data" \
  --grpc-port 0 --rest-port 0 --address 127.0.0.1 --ready-file "$work/ready.json" --auth-token bench \
  > "$work/server.log" 2>&1 &
pid=$!
trap 'kill $pid 2>/dev/null || true' EXIT
for _ in $(seq 600); do [ -f "$work/ready.json" ] && break; sleep 0.1; done
grpc_port=$(python3 -c "import json; print(json.load(open('$work/ready.json'))['grpc_port'])")
rest_port=$(python3 -c "import json; print(json.load(open('$work/ready.json'))['rest_port'])")
rest=http://127.0.0.1:$rest_port

run_load() {  # name protocol clients seconds
  local port=$grpc_port
  [ "$2" = rest ] && port=$rest_port
  echo "== $1" >&2
  "$load" --protocol "$2" --port "$port" --operation decode --clients "$3" --seconds "$4" --warmup 2 \
    --json "$out/$1.json" >&2
}
run_load decode-grpc-1 grpc 1 "$single"
run_load decode-rest-1 rest 1 "$single"
run_load decode-grpc-32 grpc 32 "$concurrent"
run_load decode-rest-32 rest 32 "$concurrent"

echo "== training in the background" >&2
job=$(curl -sf -H 'Authorization: Bearer bench' -H 'Content-Type: application/json' \
  -d '{"dataset": "h36m.mmd", "variant": "DKGM", "iterations": 100000, "seed": 1}' "$rest/v1/jobs" |
  python3 -c "import json, sys; print(json.load(sys.stdin)['id'])")
for _ in $(seq 600); do
  curl -sf "$rest/v1/jobs/$job" | python3 -c "import json, sys; j = json.load(sys.stdin); sys.exit(0 if j['progress']['iteration'] >= 1 else 1)" && break
  sleep 1
done
run_load decode-grpc-1-training grpc 1 "$single"
curl -sf "$rest/v1/jobs/$job" > "$out/training-job.json"
curl -sf -X POST -H 'Authorization: Bearer bench' "$rest/v1/jobs/$job:cancel" > /dev/null

echo "== memory over 100 activations" >&2
rss() { awk '/VmRSS/ {print $2}' "/proc/$pid/status"; }
{
  echo "activations,rss_kib"
  echo "0,$(rss)"
  for i in $(seq 100); do
    name=h36m-dkgm-cpu
    [ $((i % 2)) -eq 0 ] && name=h36m-dkgm-h100
    curl -sf -X POST -H 'Authorization: Bearer bench' "$rest/v1/models/$name:activate" > /dev/null
    curl -sf -H 'Content-Type: application/json' -d '{"count": 1, "seed": 1}' "$rest/v1/sample" > /dev/null
    [ $((i % 10)) -eq 0 ] && echo "$i,$(rss)"
  done
} > "$out/activations-rss.csv"

kill -TERM $pid
wait $pid || true
trap - EXIT
python3 scripts/service_bench_summary.py "$out" > "$out/summary.md"
cat "$out/summary.md"
