#!/usr/bin/python3
"""Table 2 of Ghorbani et al. 2020 on mosyn's data: the full hierarchical model and its ablations
(SL: no word encoder/decoder, NL: all alpha = 1, NC: no classifier loss) scored the same way by
`mosyn eval --protocols label_generation` (K samples of every content x style combination, an
evaluation classifier that is not the one inside the loss), beside the real clips, as Markdown.

    scripts/hvrnn_table2.py --data DATASET --classifier EVAL_CLASSIFIER --out DIR \
        --run full=RUN [--run SL=RUN --run NL=RUN --run NC=RUN] [--k 20] [--seconds 0] [--seed 1]

Train the ablations with the full model's config and `"preset": "SL"` (or NL, NC) in its "model"
object. The JSON of every evaluation stays in DIR.
"""
import argparse, json, os, subprocess, sys

ROWS = [("label_generation.is_content", "IS content"), ("label_generation.is_style", "IS style"),
        ("label_generation.fid", "FID"), ("label_generation.content_acc", "content recognised (%)"),
        ("label_generation.style_acc", "style recognised (%)")]


def evaluate(a, name, run):
    out = os.path.join(a.out, name + ".json")
    cmd = [a.mosyn, "eval", run, "--data", a.data, "--classifier", a.classifier, "--protocols", "label_generation",
           "--label-samples", str(a.k), "--label-seconds", str(a.seconds), "--seed", str(a.seed),
           "--threads", str(a.threads), "--out", out]
    print("+", " ".join(cmd), file=sys.stderr)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return json.load(open(out))["metrics"]


def fmt(v):
    return "n/a" if v is None else f"{v:.3g}" if abs(v) < 1000 else f"{v:.0f}"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True)
    p.add_argument("--classifier", required=True)
    p.add_argument("--run", action="append", required=True, help="NAME=RUN_DIR, e.g. full=models/hvrnn-bandai")
    p.add_argument("--out", required=True)
    p.add_argument("--k", type=int, default=20, help="samples per content x style combination (paper: 1000)")
    p.add_argument("--seconds", type=float, default=0, help="seconds per sample (0: the dataset's window)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--mosyn", default=os.path.join(os.path.dirname(__file__), "..", "build", "mosyn"))
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    results = {}
    for spec in a.run:
        name, _, run = spec.partition("=")
        if not run:
            p.error(f"--run takes NAME=RUN_DIR, got '{spec}'")
        results[name] = evaluate(a, name, run)
    first = next(iter(results.values()))
    print(f"| model | samples | " + " | ".join(label for _, label in ROWS) + " |")
    print("|---" * (len(ROWS) + 2) + "|")
    for name, m in results.items():
        cells = [fmt(m.get(key, {}).get("model")) for key, _ in ROWS]
        print(f"| {name} | {fmt(m['label_generation.samples']['model'])} | " + " | ".join(cells) + " |")
    real = [fmt(first.get(key, {}).get("real")) for key, _ in ROWS]
    print(f"| real data | {fmt(first['label_generation.samples']['real'])} | " + " | ".join(real) + " |")
    print("\nFID per requested label (real: the real clips' split-half floor):\n")
    keys = [k for k in first if k.startswith("label_generation.fid.")]
    print("| label | " + " | ".join(results) + " | real floor |")
    print("|---" * (len(results) + 2) + "|")
    for k in keys:
        cells = [fmt(results[n].get(k, {}).get("model")) for n in results]
        print(f"| {k[len('label_generation.fid.'):]} | " + " | ".join(cells) + f" | {fmt(first[k]['real'])} |")


if __name__ == "__main__":
    main()
