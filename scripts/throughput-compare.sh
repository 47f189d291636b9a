#!/usr/bin/env bash
# The server's Decode throughput for two builds, one after the other on one
# idle machine (docs/PERFORMANCE.md, "Inference at the CPU's limit"): for
# each, the real server on the shipped default model and motion-manifold-load
# with 1 and then 32 concurrent gRPC Decode clients. Then the new build again
# with every --precision in PRECISIONS (default: bf16 and int8, each where
# available). OLD_BUILD "-" measures the new build alone.
# Prints a Markdown table; the load reports stay in runs/throughput/.
#   scripts/throughput-compare.sh OLD_BUILD NEW_BUILD [SECONDS=30]
set -euo pipefail
cd "$(dirname "$0")/.."
old=$1
new=$2
seconds=${3:-30}
work=runs/throughput
rm -rf "$work" && mkdir -p "$work/models"
for model in models/*/; do ln -s "$(pwd)/$model" "$work/models/$(basename "$model")"; done

measure() {  # label build [server options...]
  local label=$1 build=$2
  shift 2
  rm -f "$work/ready.json"
  "$build/server/motion-manifold-server" --model-store "$work/models" --grpc-port 0 --rest-port 0 \
    --address 127.0.0.1 --ready-file "$work/ready.json" "$@" > "$work/$label-server.log" 2>&1 &
  local pid=$!
  for _ in $(seq 600); do [ -f "$work/ready.json" ] && break; sleep 0.1; done
  local port
  port=$(python3 -c "import json; print(json.load(open('$work/ready.json'))['grpc_port'])")
  for clients in 1 32; do
    echo "== $label, $clients clients" >&2
    "$new/client/motion-manifold-load" --protocol grpc --port "$port" --operation decode --clients "$clients" \
      --seconds "$seconds" --warmup 2 --json "$work/$label-$clients.json" >&2
  done
  kill -TERM $pid
  wait $pid || true
}

if [ "$old" != - ]; then measure old "$old"; fi
measure new-fp32 "$new"
for precision in ${PRECISIONS:-bf16 int8}; do
  measure "new-$precision" "$new" --precision "$precision" || echo "$precision: not measured" >&2
done

python3 - "$work" <<'PYTHON'
import json, pathlib, sys
work = pathlib.Path(sys.argv[1])
print("| build | clients | calls ok | errors | clips/s | p50 (ms) | p99 (ms) | p99/p50 |")
print("|---|---:|---:|---:|---:|---:|---:|---:|")
for path in sorted(work.glob("*-[0-9]*.json"), key=lambda p: (p.stem.rsplit("-", 1)[0] != "old", p.stem)):
    label, clients = path.stem.rsplit("-", 1)
    r = json.loads(path.read_text())
    print(f"| {label} | {clients} | {r['calls_ok']} | {r['errors']} | {r['clips_per_second']:.1f} | "
          f"{r['p50_ms']:.1f} | {r['p99_ms']:.1f} | {r['p99_ms'] / r['p50_ms']:.2f} |")
PYTHON
