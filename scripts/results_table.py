#!/usr/bin/env python3
"""Prints Table 1 rows (markdown) from evaluation JSON files written by
`motion-manifold evaluate`, beside the paper's rows for the same variants.
Usage: scripts/results_table.py NAME=evaluation.json [NAME=evaluation.json ...]
NAME starts with the Table 1 variant (DKGM, DKGM hidden 256, ...); each
paper row is printed once, above the first of our rows of its variant."""
import json
import sys

# Table 1 of Jang & Lee 2020: E_r, E_p at 1.2 .. 6.0 s, then E_z.
PAPER = {
    ("S", "rotation"): ([0.889, 0.971, 0.990, 1.097, 1.195], [0.957, 0.978, 1.040, 1.078, 1.181], 0.317),
    ("D", "rotation"): ([0.823, 0.868, 0.925, 1.039, 1.164], [0.855, 0.923, 0.999, 1.032, 1.167], 0.264),
    ("D", "velocity"): ([0.856, 0.843, 0.877, 1.008, 1.127], [0.889, 0.889, 0.961, 1.081, 1.212], 0.259),
    ("DK", "rotation"): ([1.020, 1.099, 1.110, 1.195, 1.261], [0.561, 0.682, 0.706, 0.761, 0.822], 0.196),
    ("DK", "velocity"): ([1.347, 1.353, 1.323, 1.382, 1.391], [0.600, 0.698, 0.723, 0.756, 0.809], 0.288),
    ("DKG", "rotation"): ([0.986, 1.077, 1.094, 1.180, 1.251], [0.549, 0.657, 0.679, 0.726, 0.810], 0.188),
    ("DKG", "velocity"): ([1.343, 1.345, 1.332, 1.405, 1.415], [0.589, 0.682, 0.702, 0.765, 0.834], 0.307),
    ("DKGM", "rotation"): ([0.997, 1.066, 1.084, 1.162, 1.258], [0.541, 0.659, 0.668, 0.696, 0.780], 0.182),
    ("DKGM", "velocity"): ([1.356, 1.381, 1.338, 1.400, 1.406], [0.590, 0.673, 0.694, 0.735, 0.792], 0.293),
    ("DKGMZ", "rotation"): ([0.906, 0.909, 0.886, 0.954, 1.053], [0.629, 0.730, 0.724, 0.754, 0.788], 0.164),
    ("DKGMZ", "velocity"): ([0.877, 0.883, 0.848, 0.916, 1.030], [0.635, 0.703, 0.689, 0.706, 0.815], 0.157),
    ("Seq2seq", "velocity"): ([0.875, 0.870, 0.891, 1.039, 1.154], [0.863, 0.954, 1.059, 1.177, 1.258], 0.216),
}


def row(label, decoder, e_r, e_p, e_z):
    cells = [f"{r:.3f} | {p:.3f}" for r, p in zip(e_r, e_p)]
    return f"| {label} | {decoder[:3]} | " + " | ".join(cells) + f" | {e_z:.3f} |"


def main(args):
    print("| model | dec | E_r 1.2s | E_p 1.2s | E_r 2.4s | E_p 2.4s | E_r 3.6s | E_p 3.6s | E_r 4.8s | E_p 4.8s "
          "| E_r 6.0s | E_p 6.0s | E_z |")
    print("|---|---|" + "---:|" * 11)
    physical = []
    printed = set()
    for arg in args:
        name, path = arg.split("=", 1)
        with open(path) as f:
            result = json.load(f)
        for decoder, errors in result["decoders"].items():
            variant = name.split()[0]
            paper = PAPER.get((variant, decoder))
            if paper and (variant, decoder) not in printed:
                print(row(f"{variant} (paper)", decoder, *paper))
                printed.add((variant, decoder))
            print(row(f"**{name} (ours)**", decoder, errors["E_r"], errors["E_p"], errors["E_z"]))
            physical.append((name, decoder, errors["mpjpe_mm"], errors["angle_error_rad"]))
    print()
    print("| model | dec | mm 1.2s | mm 2.4s | mm 3.6s | mm 4.8s | mm 6.0s | rad 1.2s | rad 2.4s | rad 3.6s | rad 4.8s | rad 6.0s |")
    print("|---|---|" + "---:|" * 10)
    for name, decoder, mm, rad in physical:
        print(f"| {name} | {decoder[:3]} | " + " | ".join(f"{v:.1f}" for v in mm) + " | " +
              " | ".join(f"{v:.3f}" for v in rad) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
