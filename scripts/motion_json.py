#!/usr/bin/env python3
"""Prints an H3.6M text file as the service's JSON motion, for curl:
    scripts/motion_json.py FILE [--rate 50] [--start 0] [--body TEMPLATE]
takes the model's clip (150 frames at 25 Hz: 300 lines at 50 Hz, or 150 at
25 Hz) from line `start` and prints {"frames", "columns", "frame_rate",
"layout", "values"}, or the request TEMPLATE with MOTION replaced by it:
    scripts/motion_json.py walk.txt --body '{"motions": [MOTION]}' | curl -d @- .../v1/encode"""
import argparse
import json

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("file")
parser.add_argument("--rate", type=int, choices=[25, 50], default=50)
parser.add_argument("--start", type=int, default=0, help="first line (at the file's rate)")
parser.add_argument("--body", help="a request in which MOTION stands for the motion")
args = parser.parse_args()
frames = 150 * args.rate // 25
with open(args.file) as f:
    rows = [line for line in f if line.strip()][args.start:args.start + frames]
if len(rows) < frames:
    raise SystemExit(f"{args.file}: expected {frames} lines from line {args.start}, found {len(rows)}")
values = [float(v) for row in rows for v in row.split(",")]
motion = json.dumps({"frames": frames, "columns": len(values) // frames, "frame_rate": args.rate,
                     "layout": "h36m-expmap-99", "values": values})
print(args.body.replace("MOTION", motion) if args.body else motion)
