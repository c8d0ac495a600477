#!/usr/bin/python3
"""MOJO's tables (Zhang et al. 2021, Tables 2, 3, 4 and 6) on mosyn's data: every variant scored by
`mosyn eval --protocols prediction,body_validity` on the same held-out windows (same clips, prefix,
horizon and seed), printed as Markdown.

    scripts/mojo_tables.py --markers DATASET --mojo RUN [--dct RUN] [--positions DATASET --joints RUN]
        --out DIR [--n 50] [--max-clips 60] [--prefix 1] [--horizon 3] [--seed 1] [--threads 2]

Variants: MOJO and MOJO-DCT (runs on the marker form) each with the recursive projection and
without it ("-proj", the paper's name for "minus projection": a copy of the run directory whose
config.json says "projection": false, weights linked), and "MOJO w. J." (the same family trained on
the joint-position form). The JSON of every evaluation stays in DIR.
"""
import argparse, json, os, subprocess, sys

PREDICTION = [("prediction.apd_m", "APD (m)"), ("prediction.ade_m", "ADE (m)"), ("prediction.fde_m", "FDE (m)"),
              ("prediction.mmade_m", "MMADE (m)"), ("prediction.mmfde_m", "MMFDE (m)"), ("prediction.fse", "FSE")]
RIGID = [("validity.rigid_head_mm", "head (mm)"), ("validity.rigid_upper_torso_mm", "upper torso (mm)"),
         ("validity.rigid_lower_torso_mm", "lower torso (mm)")]


def without_projection(run, where):
    """A copy of run whose config turns the projection off; every other file linked."""
    os.makedirs(where, exist_ok=True)
    for name in os.listdir(run):
        target = os.path.join(where, name)
        if os.path.lexists(target):
            os.remove(target)
        if name == "config.json":
            config = json.load(open(os.path.join(run, name)))
            config.setdefault("model", {})["projection"] = False
            json.dump(config, open(target, "w"), indent=2)
        else:
            os.symlink(os.path.abspath(os.path.join(run, name)), target)
    return where


def evaluate(a, name, run, dataset):
    out = os.path.join(a.out, name.replace(" ", "_").replace(".", "") + ".json")
    cmd = [a.mosyn, "eval", run, "--data", dataset, "--n", str(a.n), "--max-clips", str(a.max_clips),
           "--prefix", str(a.prefix), "--horizon", str(a.horizon), "--seed", str(a.seed),
           "--protocols", "prediction,body_validity", "--threads", str(a.threads), "--out", out]
    print("+", " ".join(cmd), file=sys.stderr)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    rows = {r["key"]: r for r in json.load(open(out))["rows"]}
    return rows, json.load(open(out))["prediction_windows"]


def fmt(v):
    return "n/a" if v is None else f"{v:.4g}"


def table(title, columns, results, real_label=None):
    lines = [f"\n{title}\n", "| method | " + " | ".join(c[1] for c in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for name, rows in results:
        lines.append(f"| {name} | " + " | ".join(fmt(rows.get(k, {}).get("model")) for k, _ in columns) + " |")
    if real_label and results:
        rows = results[0][1]
        lines.append(f"| {real_label} | " + " | ".join(fmt(rows.get(k, {}).get("real")) for k, _ in columns) + " |")
    print("\n".join(lines))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--markers", required=True)
    ap.add_argument("--positions")
    ap.add_argument("--mojo", required=True)
    ap.add_argument("--dct")
    ap.add_argument("--joints")
    ap.add_argument("--out", required=True)
    ap.add_argument("--n", type=int, default=50)
    ap.add_argument("--max-clips", type=int, default=60)
    ap.add_argument("--prefix", type=float, default=1.0)
    ap.add_argument("--horizon", type=float, default=3.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--mosyn", default="build/mosyn")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    variants = [("MOJO", a.mojo, a.markers),
                ("MOJO-proj", without_projection(a.mojo, os.path.join(a.out, "runs", "mojo-noproj")), a.markers)]
    if a.dct:
        variants += [("MOJO-DCT", a.dct, a.markers),
                     ("MOJO-DCT-proj", without_projection(a.dct, os.path.join(a.out, "runs", "dct-noproj")), a.markers)]
    if a.joints and a.positions:
        variants.append(("MOJO w. J.", a.joints, a.positions))
    results, windows = [], 0
    for name, run, dataset in variants:
        rows, windows = evaluate(a, name, run, dataset)
        results.append((name, rows))
    markers = [r for r in results if r[0] != "MOJO w. J."]
    print(f"{windows} windows of the validation split, {a.prefix:g} s observed, {a.horizon:g} s predicted, "
          f"{a.n} samples each; '-proj' = without the recursive projection.")
    table("Table 2 (prediction, joints relative to the pelvis)", PREDICTION, results)
    table("Table 3 (rigid-part deformation of the raw predicted markers)", RIGID, markers, "real windows")
    table("Table 4 (heel-marker foot skating)", [("validity.heel_skating", "skating ratio")], markers, "ground truth")
    joints = [r for r in results if r[0] in ("MOJO", "MOJO w. J.")]
    table("Table 6 (markers against joints; BDF on the limb bones)", PREDICTION + [("validity.bdf_m", "BDF (m)")], joints)


if __name__ == "__main__":
    main()
