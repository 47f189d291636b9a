#!/usr/bin/env python3
"""Formats the results of scripts/service-bench.sh as the Markdown of
docs/PERFORMANCE.md: each load run beside the bench's figure it is held to."""
import csv
import json
import sys
from pathlib import Path

out = Path(sys.argv[1])
bench = json.loads((out / "bench.json").read_text())


def bench_ms(operation, batch):
    # The path the server runs: the packed fp32 weights where the bench has
    # them apart, else the one row of the operation.
    rows = [row for row in bench["results"] if row.get("operation", "").startswith(operation)
            and row.get("batch") == batch and row.get("device", "cpu") == "cpu"]
    for row in rows:
        if "(packed fp32)" in row["operation"]:
            return row["median_ms"]
    if rows:
        return rows[0]["median_ms"]
    raise SystemExit(f"bench.json has no {operation} batch {batch}")


decode_1 = bench_ms("decode", 1)
decode_30 = bench_ms("decode", 30)
clips_30 = 30 / (decode_30 / 1000)
runs = {name: json.loads((out / f"{name}.json").read_text())
        for name in ["decode-grpc-1", "decode-rest-1", "decode-grpc-32", "decode-rest-32", "decode-grpc-1-training"]}

print(f"`motion-manifold bench`: decode (rotation) batch 1 median {decode_1:.1f} ms; batch 30 median "
      f"{decode_30:.1f} ms, i.e. {clips_30:.1f} clips/s.\n")
print("| run | clients | calls ok | errors | clips/s | p50 (ms) | p99 (ms) | p99/p50 | held to | ratio |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---|---:|")
idle_p50 = runs["decode-grpc-1"]["p50_ms"]
targets = {
    "decode-grpc-1": ("p50 <= 1.15 x bench batch-1", runs["decode-grpc-1"]["p50_ms"] / decode_1),
    "decode-rest-1": ("p50 <= 1.3 x bench batch-1", runs["decode-rest-1"]["p50_ms"] / decode_1),
    "decode-grpc-32": (">= 0.9 x bench batch-30 clips/s", runs["decode-grpc-32"]["clips_per_second"] / clips_30),
    "decode-rest-32": (">= 0.9 x bench batch-30 clips/s", runs["decode-rest-32"]["clips_per_second"] / clips_30),
    "decode-grpc-1-training": ("p50 <= 1.5 x idle gRPC p50", runs["decode-grpc-1-training"]["p50_ms"] / idle_p50),
}
for name, run in runs.items():
    target, ratio = targets[name]
    print(f"| {name} | {run['clients']} | {run['calls_ok']} | {run['errors']} | {run['clips_per_second']:.1f} | "
          f"{run['p50_ms']:.1f} | {run['p99_ms']:.1f} | {run['p99_ms'] / run['p50_ms']:.2f} | {target} | {ratio:.2f} |")

job = json.loads((out / "training-job.json").read_text())
print(f"\nThe training job during `decode-grpc-1-training`: {job['spec']['variant']} at iteration "
      f"{job['progress']['iteration']}, {job['progress']['iterations_per_second']:.3f} iterations/s.\n")
with open(out / "activations-rss.csv") as f:
    rows = list(csv.DictReader(f))
first, last = int(rows[1]["rss_kib"]), int(rows[-1]["rss_kib"])
print("Resident memory over activations (KiB): " + ", ".join(f"{r['activations']}: {r['rss_kib']}" for r in rows) +
      f"; from activation 10 to 100 it changed by {100 * (last - first) / first:+.1f}%.")
