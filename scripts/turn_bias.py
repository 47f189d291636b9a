#!/usr/bin/env python3
"""Which way the manifold turns (docs/RESULTS.md, "Motions that travel").

Prints two Markdown tables:
- each subject's recorded root turn about the up axis over 6 s of its walking
  takes (walking, walkingdog, walkingtogether): the mean of the signed total
  (which way round they walk) and of its size;
- for each take given, the decoded turn against the recorded one, the take as
  recorded and mirrored (left and right swapped, `take mirror`): the slope of
  the decoded 6 s totals regressed on the recorded ones through 0 (1: the
  decoded motion turns as much as the recording, negative: the other way),
  the per-frame correlation, and the rms error of the 6 s totals.

Turn: the layout's column 4, the root's rotation about its up axis since the
previous 50 Hz frame (radians); the 25 Hz reconstructions hold every second
one. Totals over 6 s windows every 2 s.

  scripts/turn_bias.py MODEL_DIR TOOL DATA_DIR OUT_DIR TAKE...   (TAKE: S5/walking_1, ...)
"""
import math
import os
import statistics
import subprocess
import sys

WALKING = ["walking", "walkingdog", "walkingtogether"]
SUBJECTS = ["S1", "S6", "S7", "S8", "S9", "S11", "S5"]


def turns(path, step):
    with open(path) as f:
        rows = [line for line in f if line.strip()]
    return [float(row.split(",")[4]) for row in rows[::step]]


def window_totals(values, frames, hop):
    return [sum(values[s:s + frames]) for s in range(0, len(values) - frames + 1, hop)]


def correlation(a, b):
    ma, mb = statistics.mean(a), statistics.mean(b)
    num = sum((x - ma) * (y - mb) for x, y in zip(a, b))
    den = math.sqrt(sum((x - ma) ** 2 for x in a) * sum((y - mb) ** 2 for y in b))
    return num / den if den else 0.0


def compare(recorded_50hz, decoded_25hz):
    r, d = turns(recorded_50hz, 2), turns(decoded_25hz, 1)
    n = min(len(r), len(d))
    r, d = r[:n], d[:n]
    corr, tr, td = [], [], []
    for s in range(0, n - 150 + 1, 50):
        corr.append(correlation(r[s:s + 150], d[s:s + 150]))
        # Each 25 Hz frame holds one of two 50 Hz steps: twice the sum is the turn.
        tr.append(2 * sum(r[s:s + 150]))
        td.append(2 * sum(d[s:s + 150]))
    slope = sum(x * y for x, y in zip(tr, td)) / sum(x * x for x in tr)
    rms = math.sqrt(statistics.mean([(x - y) ** 2 for x, y in zip(tr, td)]))
    return slope, statistics.mean(corr), rms, statistics.mean(tr)


def main():
    model, tool, data, out_dir = sys.argv[1:5]
    takes = sys.argv[5:]
    os.makedirs(out_dir, exist_ok=True)
    print("| subject | walking takes | mean turn over 6 s (rad) | mean size of the turn (rad) |")
    print("|---|---:|---:|---:|")
    for subject in SUBJECTS:
        totals, count = [], 0
        for action in WALKING:
            for trial in (1, 2):
                path = os.path.join(data, subject, f"{action}_{trial}.txt")
                if not os.path.exists(path):
                    continue
                count += 1
                totals += window_totals(turns(path, 1), 300, 100)
        if totals:
            print(f"| {subject} | {count} | {statistics.mean(totals):+.2f} | {statistics.mean(abs(t) for t in totals):.2f} |")
    print()
    print("| take | as | recorded turn over 6 s (rad) | decoded / recorded (slope) | per-frame correlation | rms error of the 6 s turn (rad) |")
    print("|---|---|---:|---:|---:|---:|")
    for take in takes:
        recorded = os.path.join(data, take + ".txt")
        name = take.replace("/", "_")
        mirrored = os.path.join(out_dir, name + "-mirrored.txt")
        subprocess.run([tool, "take", "mirror", "--model", model, "--input", recorded, "--out", mirrored],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        for label, source in (("recorded", recorded), ("mirrored", mirrored)):
            decoded = os.path.join(out_dir, f"{name}-{label}-decoded.txt")
            subprocess.run([tool, "take", "reconstruct", "--model", model, "--input", source, "--at-model-rate",
                            "--out", decoded], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            slope, corr, rms, mean_turn = compare(source, decoded)
            print(f"| {take} | {label} | {mean_turn:+.2f} | {slope:.2f} | {corr:.2f} | {rms:.2f} |")
            os.remove(decoded)
        os.remove(mirrored)


if __name__ == "__main__":
    main()
