#!/usr/bin/env bash
# Times a whole take through the service over REST, end to end as a client
# sees it (docs/PERFORMANCE.md, "Whole takes"): a take of S5 files one after
# another, MINUTES long (default 10), brought to 120 Hz as a BVH of the
# H3.6M skeleton, POSTed to /v1/takes:reconstruct with the reply asked for
# as BVH; the server's peak memory (VmHWM) read from /proc before and after.
# Needs the built server and tool and the extracted H3.6M; run it on an idle
# machine.
#   scripts/take-bench.sh [MINUTES] [PORT]
set -euo pipefail
cd "$(dirname "$0")/.."
minutes=${1:-10}
port=${2:-18480}
work=$(mktemp -d)
trap 'kill "$server" 2>/dev/null || true; rm -rf "$work"' EXIT
frames=$((minutes * 60 * 50))
# Concatenated motion text is one take: the root's columns are per-frame changes.
touch "$work/take.txt"
while [ "$(wc -l < "$work/take.txt")" -lt "$frames" ]; do
  cat data/h3.6m/dataset/S5/*.txt >> "$work/take.txt"
done
head -n "$frames" "$work/take.txt" > "$work/take50.txt"
build/model/tool/motion-manifold take resample --input "$work/take50.txt" --rate 50 --to 120 --out "$work/take.bvh" >&2
mkdir -p "$work/models"
ln -s "$PWD/models/h36m-dkgm-h100" "$work/models/h36m-dkgm-h100"
build/server/motion-manifold-server --model-store "$work/models" --address 127.0.0.1 \
  --grpc-port 0 --rest-port "$port" > "$work/server.log" 2>&1 &
server=$!
for _ in $(seq 100); do curl -sf "http://127.0.0.1:$port/readyz" > /dev/null && break; sleep 0.2; done
peak() { awk '/VmHWM/ {print $2 / 1024}' "/proc/$server/status"; }
before=$(peak)
bytes=$(stat -c %s "$work/take.bvh")
for run in 1 2 3; do
  curl -sS -o "$work/out.bvh" -D "$work/headers" -w "run $run: %{time_total} s end to end (%{size_upload} bytes up, %{size_download} down)\n" \
    -H 'Content-Type: application/x-bvh' -H 'Accept: application/x-bvh' --data-binary "@$work/take.bvh" \
    "http://127.0.0.1:$port/v1/takes:reconstruct"
done
grep -i '^x-take' "$work/headers"
echo "frames in: $(awk '/^Frames:/ {print $2}' "$work/take.bvh"), out: $(awk '/^Frames:/ {print $2}' "$work/out.bvh")"
echo "server peak memory: $before MiB before the takes, $(peak) MiB after (body $((bytes / 1048576)) MiB)"
