#!/usr/bin/env bash
# The server under CPU contention (docs/PERFORMANCE.md, "Under CPU
# contention"): 32 concurrent gRPC Decode clients of the default model for
# SECONDS each, with the server's default threads, on an idle machine and
# with a busy loop (another process) beside it, then with the loop and
# OpenMP's passive waiting (OMP_WAIT_POLICY=PASSIVE), then with the loop and
# --threads 1. Run it on an otherwise idle machine.
# Results: JSON files and summary.md in $OUT (default docs/results/contention).
#   scripts/contention-bench.sh [SECONDS=20]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-20}
build=${BUILD:-build}
out=${OUT:-docs/results/contention}
server=$build/server/motion-manifold-server
load=$build/client/motion-manifold-load
work=runs/contention-bench
rm -rf "$work" && mkdir -p "$out" "$work"
busy=""
pid=""
cleanup() {
  [ -n "$pid" ] && kill "$pid" 2> /dev/null || true
  [ -n "$busy" ] && kill "$busy" 2> /dev/null || true
}
trap cleanup EXIT

run() {  # name busy(0|1) [server flags...]; the environment passes through
  local name=$1 loop=$2
  shift 2
  rm -f "$work/ready.json"
  "$server" --model-store models --grpc-port 0 --rest-port 0 --address 127.0.0.1 \
    --ready-file "$work/ready.json" "$@" > "$work/$name.log" 2>&1 &
  pid=$!
  for _ in $(seq 600); do [ -f "$work/ready.json" ] && break; sleep 0.1; done
  local port
  port=$(python3 -c "import json; print(json.load(open('$work/ready.json'))['grpc_port'])")
  if [ "$loop" = 1 ]; then
    sh -c 'while :; do :; done' &
    busy=$!
  fi
  echo "== $name" >&2
  "$load" --protocol grpc --port "$port" --operation decode --clients 32 --seconds "$seconds" --warmup 2 \
    --json "$out/$name.json" >&2
  if [ -n "$busy" ]; then kill "$busy"; wait "$busy" 2> /dev/null || true; busy=""; fi
  kill "$pid"; wait "$pid" 2> /dev/null || true; pid=""
}
run idle 0
run busy 1
OMP_WAIT_POLICY=PASSIVE run busy-passive 1
OMP_WAIT_POLICY=PASSIVE run idle-passive 0
run busy-threads-1 1 --threads 1

python3 - "$out" << 'PY'
import json, sys, pathlib
out = pathlib.Path(sys.argv[1])
rows = ["| run | clips/s | p50 ms | p99 ms |", "| --- | --- | --- | --- |"]
for name in ["idle", "idle-passive", "busy", "busy-passive", "busy-threads-1"]:
    r = json.load(open(out / f"{name}.json"))
    rows.append(f"| {name} | {r.get('clips_per_second', r.get('throughput', 0)):.1f} | "
                f"{r.get('p50_ms', 0):.1f} | {r.get('p99_ms', 0):.1f} |")
(out / "summary.md").write_text("\n".join(rows) + "\n")
print("\n".join(rows))
PY
