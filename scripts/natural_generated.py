#!/usr/bin/python3
"""Walks of the families that make their own root motion (hvrnn, DFN, MOJO) beside real held-out
walks, judged by the independent check (../shared/checks/natural_motion.py): v_tol95, foot-skating
ratio and mean step duration, as generated/real ratios, and the pelvis' mean ground speed beside
the takes' (a model that stops walking stops sliding too). Two ways of asking for a walk:

  labels    --seconds S of content walk in each style of --styles (default: every style of the
            run), --n samples each (hvrnn: "10 s of content walk, each of the seven styles");
  continue  every held-out original walk take of DATASET's validation split continued from its
            first --observed-frames frames (or --observed seconds) for --seconds, --n samples each;
            only the generated frames are judged (DFN: 20 frames then 10 s; MOJO: 1 s then its 3 s).

The real side is always the same held-out walk takes (their source BVH files).

    scripts/natural_generated.py RUN DATASET --mode labels|continue --out DIR [--n 2] [--seconds 10]
        [--observed-frames 20 | --observed 1] [--styles a,b] [--max-clips 30] [--seed K] [--json OUT.json]
        [--foot-lock] [--temperature T]

Needs Debian's python3-numpy. Prints a Markdown table; --json writes every figure.
"""
import argparse, json, os, sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from natural_eval import CHECK, CHECK_SCALE, check, run, val_clips  # noqa: E402


def trim_bvh(src, dst, first_frame):
    """Writes src without its first `first_frame` frames of motion."""
    lines = open(src).read().splitlines()
    m = next(i for i, l in enumerate(lines) if l.strip().startswith("MOTION"))
    frames_line, time_line = m + 1, m + 2
    motion = [l for l in lines[m + 3:] if l.strip()]
    kept = motion[first_frame:]
    if len(kept) < 2:
        sys.exit(f"{src}: {len(motion)} frames, nothing generated after frame {first_frame}")
    out = lines[:frames_line] + [f"Frames: {len(kept)}", lines[time_line]] + kept
    open(dst, "w").write("\n".join(out) + "\n")


def pelvis_mps(files):
    """Mean ground speed (m/s) of the pelvis (the joint named Hips, else the root) over each file, averaged over the files:
    a model that stops walking has feet that do not slide, so the check's figures need this beside them."""
    if os.path.dirname(CHECK) not in sys.path:
        sys.path.insert(0, os.path.dirname(CHECK))
    import numpy as np
    import natural_motion as nm
    speeds = []
    for f in files:
        pos, names, fps = nm.positions_m(f, CHECK_SCALE)
        low = [n.lower() for n in names]
        pelvis = low.index("hips") if "hips" in low else 0  # Bandai-Namco's own files root at a static joint
        speeds.append(float(np.linalg.norm(np.diff(pos[:, pelvis, [0, 2]], axis=0), axis=-1).mean() * fps))
    return float(np.mean(speeds))


def extra_flags(a):
    """The sampling flags every request shares."""
    return (["--foot-lock"] if a.foot_lock else []) + (["--temperature", str(a.temperature)] if a.temperature != 1.0 else [])


def by_labels(a, styles):
    files = []
    for k, style in enumerate(styles):
        d = os.path.join(a.out, f"walk-{style}")
        run([a.mosyn, "sample", a.run, "--out", d, "--n", str(a.n), "--seed", str(101 + k + a.seed), "--content", "walk",
             "--style", style, "--seconds", str(a.seconds), "--prefix", style, "--threads", a.threads]
            + extra_flags(a))
        files += [os.path.join(d, f"{style}_{i:03d}.bvh") for i in range(a.n)]
    return files


def by_continuing(a, clips, source_dir):
    files = []
    for idx, source, _, _ in clips:
        d = os.path.join(a.out, "continued")
        observed = ["--observed-frames", str(a.observed_frames)] if a.observed_frames else ["--observed", str(a.observed)]
        prefix = f"clip{idx:04d}"
        run([a.mosyn, "sample", a.run, "--out", d, "--n", str(a.n), "--seed", str(idx + a.seed), "--continue",
             os.path.join(source_dir, source), "--seconds", str(a.seconds), "--prefix", prefix, "--threads", a.threads]
            + observed + extra_flags(a))
        for i in range(a.n):
            full = os.path.join(d, f"{prefix}_{i:03d}.bvh")
            # The sidecar says how many of the written frames are the observed ones.
            observed_frames = json.load(open(full[:-4] + ".json"))["continued"]["observed_frames"]
            gen = full[:-4] + "_generated.bvh"
            trim_bvh(full, gen, int(observed_frames))
            files.append(gen)
    return files


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run"); ap.add_argument("dataset")
    ap.add_argument("--mode", choices=["labels", "continue"], required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--n", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--observed-frames", type=int, default=0)
    ap.add_argument("--observed", type=float, default=1.0)
    ap.add_argument("--styles", default="")
    ap.add_argument("--max-clips", type=int, default=30)
    ap.add_argument("--mosyn", default=os.path.join(HERE, "..", "build", "mosyn"))
    ap.add_argument("--threads", default="1")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default="")
    ap.add_argument("--foot-lock", action="store_true", help="sample with --foot-lock (core/foot_lock.h)")
    ap.add_argument("--temperature", type=float, default=1.0, help="sample with this --temperature")
    a = ap.parse_args()
    info, clips = val_clips(a.dataset, ["walk"])
    if a.max_clips and len(clips) > a.max_clips:
        clips = [clips[i * len(clips) // a.max_clips] for i in range(a.max_clips)]
    source_dir = info["source_dirs"][0] if info.get("source_dirs") else info["source_dir"]
    real = [os.path.join(source_dir, c[1]) for c in clips]
    if a.mode == "labels":
        styles = a.styles.split(",") if a.styles else json.load(open(os.path.join(a.run, "config.json")))["dataset"]["style_labels"]
        generated = by_labels(a, styles)
    else:
        generated = by_continuing(a, clips, source_dir)
    result = check(generated, real)
    made, taken = pelvis_mps(generated), pelvis_mps(real)
    result["pelvis_mps"] = dict(generated=made, real=taken, ratio=made / taken if taken > 0 else float("nan"))
    what = f"{a.mode}, {len(generated)} motions"
    metrics = ("v_tol95", "skating", "step_s", "pelvis_mps")
    print(f"| {a.run} ({what}) | v_tol95 cm/s (ratio) | skating (ratio) | step s (ratio) | pelvis m/s (ratio) |")
    print("|---|---|---|---|---|")
    print("| generated | " + " | ".join(f"{result[m]['generated']:.3g} ({result[m]['ratio']:.2f})" for m in metrics) + " |")
    print("| real held-out walks | " + " | ".join(f"{result[m]['real']:.3g}" for m in metrics) + " |")
    if a.json:
        json.dump(dict(run=a.run, dataset=a.dataset, mode=a.mode, n=a.n, seconds=a.seconds, observed_frames=a.observed_frames,
                       observed_s=a.observed, clips=[c[1] for c in clips], results=result), open(a.json, "w"), indent=1)


if __name__ == "__main__":
    main()
