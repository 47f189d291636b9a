#!/usr/bin/env python3
"""Prints a markdown table of training-log columns (train_log.csv, written by
`motion-manifold train`) averaged over equal windows of iterations, one row
per run: how a term moves over training, in numbers beside its curve.
Usage: scripts/log_windows.py --column NAME [--column NAME ...] [--windows K] RUN=train_log.csv ..."""
import csv
import sys


def read_column(path, column):
    with open(path) as f:
        return [(int(r["iteration"]), float(r[column])) for r in csv.DictReader(f)]


def windows_of(rows, spans):
    """The mean of `rows` in each span; nan where a shorter run has no row."""
    means = []
    for low, high in spans:
        values = [v for i, v in rows if low < i <= high]
        means.append(sum(values) / len(values) if values else float("nan"))
    return means


def main(args):
    columns, count, runs = [], 4, []
    while args:
        if args[0] == "--column":
            columns.append(args[1])
            args = args[2:]
        elif args[0] == "--windows":
            count = int(args[1])
            args = args[2:]
        else:
            runs.append(args[0].split("=", 1))
            args = args[1:]
    if not columns or not runs:
        sys.exit(__doc__)
    # One set of windows for every run: equal spans of the longest run.
    last = max(read_column(path, columns[0])[-1][0] for _, path in runs)
    spans = [(last * k // count, last * (k + 1) // count) for k in range(count)]
    print("| run | term | " + " | ".join(f"it. {low + 1}–{high}" for low, high in spans) + " |")
    print("|---|---|" + "---:|" * count)
    for column in columns:
        for name, path in runs:
            means = windows_of(read_column(path, column), spans)
            print(f"| {name} | {column} | " + " | ".join(f"{m:.3f}" for m in means) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
