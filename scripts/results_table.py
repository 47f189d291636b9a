#!/usr/bin/env python3
"""Prints the tables of docs/RESULTS.md (markdown) from evaluation JSON files
written by `motion-manifold evaluate`, beside the paper's rows for the same
variants.
Usage: scripts/results_table.py [--table paper|generation|project|physical|denoising|prior] NAME=evaluation.json ...
NAME starts with the Table 1 variant (DKGM, DKGM hidden 256, ...); each
paper row is printed once, above the first of our rows of its variant.
  paper      Table 1 in the reference implementation's units (the default),
             with mean +- std over the evaluation's seeds where it has them;
             intervals in clip time (1.2s: the clip's first 1.2 s)
  generation the same with our intervals in generation order (1.2s: the
             first 1.2 s the decoders generate, the clip's end), the order
             the paper's intervals are read in (docs/RESULTS.md)
  project    Table 1 in the evaluation's own units (one norm per frame)
  physical   mean per-joint position error (mm) and joint-rotation error (rad)
  denoising  the denoising experiment, every corruption and method (mm)
  prior      how the test clips' codes match the prior N(0, I): Eq. 12's MMD
             beside its value between two prior draws, the mean and covariance"""
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
HEADER = ("| model | dec | E_r 1.2s | E_p 1.2s | E_r 2.4s | E_p 2.4s | E_r 3.6s | E_p 3.6s | E_r 4.8s | E_p 4.8s "
          "| E_r 6.0s | E_p 6.0s | E_z |\n|---|---|" + "---:|" * 11)


def in_generation_order(errors):
    """The per-interval lists reversed (as evaluation.json's generation_order):
    the decoders generate the clip from its end."""
    return {key: (list(reversed(value)) if isinstance(value, list) else
                  in_generation_order(value) if isinstance(value, dict) else value)
            for key, value in errors.items()}


def cell(value, spread=None):
    return f"{value:.3f}" if spread is None else f"{value:.3f} ± {spread:.3f}"


def row(label, decoder, e_r, e_p, e_z, spread=None):
    """spread: (E_r std, E_p std, E_z std) or None."""
    s_r, s_p, s_z = spread if spread else ([None] * len(e_r), [None] * len(e_p), None)
    cells = [f"{cell(r, sr)} | {cell(p, sp)}" for r, p, sr, sp in zip(e_r, e_p, s_r, s_p)]
    return f"| {label} | {decoder[:3]} | " + " | ".join(cells) + f" | {cell(e_z, s_z)} |"


def load(args):
    for arg in args:
        if "=" not in arg:
            sys.exit(f"results_table.py: expected NAME=evaluation.json, found {arg!r} (--help for the usage)")
        name, path = arg.split("=", 1)
        with open(path) as f:
            yield name, json.load(f)


def table1(models, paper_units, generation_order=False):
    order = in_generation_order if generation_order else (lambda errors: errors)
    print(HEADER)
    printed = set()
    for name, result in models:
        for decoder, errors in result["decoders"].items():
            if paper_units and "paper_units" not in errors:
                continue  # evaluated before the evaluation reported the paper's units
            variant = name.split()[0]
            paper = PAPER.get((variant, decoder))
            if paper and (variant, decoder) not in printed:
                print(row(f"{variant} (paper)", decoder, *paper))
                printed.add((variant, decoder))
            ours = order(errors["paper_units"] if paper_units else errors)
            print(row(f"**{name} (ours, seed {result['seed']})**", decoder, ours["E_r"], ours["E_p"], ours["E_z"]))
            spread = result.get("seed_spread", {}).get("decoders", {}).get(decoder)
            if spread:
                s = order(spread["paper_units"] if paper_units else spread)
                seeds = len(result["seed_spread"]["seeds"])
                print(row(f"{name} (ours, {seeds} seeds: mean ± std)", decoder, s["E_r"]["mean"], s["E_p"]["mean"],
                          s["E_z"]["mean"], (s["E_r"]["std"], s["E_p"]["std"], s["E_z"]["std"])))


def physical(models):
    print("| model | dec | mm 1.2s | mm 2.4s | mm 3.6s | mm 4.8s | mm 6.0s | rad 1.2s | rad 2.4s | rad 3.6s | rad 4.8s "
          "| rad 6.0s |")
    print("|---|---|" + "---:|" * 10)
    for name, result in models:
        for decoder, errors in result["decoders"].items():
            print(f"| {name} | {decoder[:3]} | " + " | ".join(f"{v:.1f}" for v in errors["mpjpe_mm"]) + " | " +
                  " | ".join(f"{v:.3f}" for v in errors["angle_error_rad"]) + " |")


def denoising(models):
    print("| model | corruption | values dropped | corrupted | projected | dropped as missing | observed kept "
          "| interpolated in time |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for name, result in models:
        d = result.get("denoising")
        if not d:
            continue
        for c in d["corruptions"]:
            kind = {"reference": "reference (to the mean)", "zeroed": "paper's text (zeroed)"}.get(c["corruption"])
            if kind is None:
                kind = f"joints zeroed over {c['window_frames'] / 25:.1f} s"
            corrupted = c["corrupted_mpjpe_mm"]

            def mm(key):
                value = c[key]
                return f"{value:.1f} ({100 * (value - corrupted) / corrupted:+.0f}%)"
            print(f"| {name} | {kind} | {100 * c['missing_fraction']:.0f}% | {corrupted:.1f} | {mm('denoised_mpjpe_mm')} "
                  f"| {mm('denoised_missing_mpjpe_mm')} | {mm('filled_missing_mpjpe_mm')} "
                  f"| {mm('time_interpolation_mpjpe_mm')} |")


def prior(models):
    print("| model | MMD codes to N(0, I) | MMD N(0, I) to N(0, I) | \u2016mean\u2016 | largest mean component "
          "| variance mean (min – max) | off-diagonal covariance, mean size |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, result in models:
        m = result.get("prior_match")
        if not m:
            continue
        print(f"| {name} | {m['mmd_codes_to_prior']:.4f} | {m['mmd_prior_to_prior']:.4f} | {m['mean_norm']:.3f} "
              f"| {m['mean_abs_max']:.3f} | {m['variance_mean']:.3f} ({m['variance_min']:.3f} – {m['variance_max']:.3f}) "
              f"| {m['covariance_off_diagonal_abs_mean']:.3f} |")


def main(args):
    table = "paper"
    if not args or args[0] in ("-h", "--help"):
        print(__doc__)
        return
    if args and args[0] == "--table":
        table, args = args[1], args[2:]
    models = list(load(args))
    if table == "paper":
        table1(models, paper_units=True)
    elif table == "generation":
        table1(models, paper_units=True, generation_order=True)
    elif table == "project":
        table1(models, paper_units=False)
    elif table == "physical":
        physical(models)
    elif table == "denoising":
        denoising(models)
    elif table == "prior":
        prior(models)
    else:
        sys.exit(f"results_table.py: --table: expected paper, generation, project, physical, denoising or prior, found {table}")


if __name__ == "__main__":
    main(sys.argv[1:])
