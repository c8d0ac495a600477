#!/usr/bin/python3
"""Walking samples of a model beside real held-out walks, judged by the independent check
(../shared/checks/natural_motion.py): v_tol95, foot-skating ratio and mean step duration, as
generated/real ratios. Two settings, as issue "natural motion" asks:

  1. along the validation split's own controls: for every held-out original (not mirrored) clip of
     the given contents, --n samples along its (smoothed) control with its content label (and,
     with --take-styles, its style, as `mosyn eval` asks), against the clips' source BVH;
  2. along synthetic paths drawn as a user would (curve, zigzag, stop-and-go, straight lines at
     0.8-1.8 m/s), against the same real clips.

    scripts/natural_eval.py RUN DATASET --out DIR [--contents walk] [--n 2] [--max-clips 30]
        [--mosyn build/mosyn] [--style S | --take-styles] [--temperature T] [--warmup S] [--seed K] [--foot-lock]
        [--realtime] [--json OUT.json]

With the default 2 samples a take (28 motions for the 14 held-out walks) the step ratio scatters
by about 0.15 from one --seed to the next on the same weights (recurrent VAE run 20: 0.98, 0.72,
0.71); to choose between models use --n 6 and several seeds (models/rvae-locomotion/README.md).

Needs Debian's python3-numpy. Prints a Markdown table; --json writes every figure. A second table
splits the check's toe-slide rule by the pelvis' ground speed (1-s mean): where a model's feet slide
more than the takes' (for MoGlow, the drawn paths' excess lay in their starts, stops and stands,
speeds the held-out takes never reach).
"""
import argparse, inspect, json, os, re, struct, subprocess, sys

HERE = os.path.dirname(os.path.abspath(__file__))
CHECK = os.path.normpath(os.path.join(HERE, "..", "..", "shared", "checks", "natural_motion.py"))

# name -> (path, speed m/s): what a user draws. Coordinates in metres.
PATHS = {
    "curve": ("0,0 0,3 2,5 5,5 7,3", 1.3),
    "zigzag": ("0,0 2,2 0,4 2,6 0,8", 1.2),
    "stop-and-go": ("0,0 0,3,2 3,5,2 3,8", 1.3),
    "straight-0.8": ("0,0 0,8", 0.8),
    "straight-1.3": ("0,0 0,10", 1.3),
    "straight-1.8": ("0,0 0,12", 1.8),
}


def val_clips(dataset, contents):
    """(index in the val split, source, content, style) of original clips of the given contents."""
    info = json.load(open(os.path.join(dataset, "dataset.json")))
    labels = info["content_labels"]
    pd, cd = info["layout"]["pose_dim"], info["layout"]["control_dim"]
    data = open(os.path.join(dataset, "val.bin"), "rb").read()
    n = struct.unpack_from("<I", data, 20)[0]
    off, out = 8 + 16 + 8, []
    for i in range(n):
        (slen,) = struct.unpack_from("<I", data, off); off += 4
        source = data[off:off + slen].decode(); off += slen
        content, style, flags, frames = struct.unpack_from("<iiBI", data, off); off += 13
        off += 4 * frames * (pd + cd)
        name = labels[content] if 0 <= content < len(labels) else ""
        styles = info.get("style_labels", [])
        style_name = styles[style] if 0 <= style < len(styles) else ""
        if flags == 0 and name in contents:
            out.append((i, source, name, style_name))
    return info, out


# Pelvis ground-speed bands (m/s, 1-s mean) of the speed split: standing, starting / stopping, slow,
# walking, fast.
SPEED_BANDS_MPS = (0.0, 0.2, 0.6, 1.0, 1.5, float("inf"))
# File units to metres, as the check's default --scale: Bandai-Namco and mosyn's samples of it are in cm.
CHECK_SCALE = 0.01


def slides_by_speed(files):
    """Per SPEED_BANDS_MPS band: [frame steps sliding, frame steps] by the check's toe rule (a toe
    within h_thr of its own 5th-percentile height moving faster than v_thr: its foot_skating_ratio,
    which returns only the clip mean, so the rule is restated here with the check's own thresholds),
    each step t-1 -> t binned by the pelvis' ground speed averaged over the second around it."""
    if os.path.dirname(CHECK) not in sys.path:
        sys.path.insert(0, os.path.dirname(CHECK))
    import numpy as np
    import natural_motion as nm
    rule = inspect.signature(nm.foot_skating_ratio).parameters
    h_thr, v_thr = rule["h_thr"].default, rule["v_thr"].default
    counts = [[0, 0] for _ in SPEED_BANDS_MPS[:-1]]
    for f in files:
        pos, names, fps = nm.positions_m(f, CHECK_SCALE)
        if pos.shape[0] < 2:
            continue
        low = [n.lower() for n in names]
        pelvis = low.index("hips") if "hips" in low else 0
        step_mps = np.linalg.norm(np.diff(pos[:, pelvis, [0, 2]], axis=0), axis=-1) * fps
        k = max(1, int(round(fps)))
        # The mean over the frames that exist (no zero padding: a take cut mid-stride reads as walking).
        pelvis_mps = np.convolve(step_mps, np.ones(k), mode="same") / np.convolve(np.ones_like(step_mps), np.ones(k), mode="same")
        toes = pos[:, nm.foot_indices(names), :]
        floor = np.percentile(toes[:, :, 1], 5, axis=0)
        near = (toes[:-1, :, 1] - floor) < h_thr
        toe_mps = np.linalg.norm(np.diff(toes[:, :, [0, 2]], axis=0), axis=-1) * fps
        sliding = (near & (toe_mps > v_thr)).any(axis=1)
        band = np.digitize(pelvis_mps, SPEED_BANDS_MPS[1:-1])
        for b in range(len(counts)):
            counts[b][0] += int(sliding[band == b].sum())
            counts[b][1] += int((band == b).sum())
    return counts


def print_speed_split(rows):
    """rows: (name, slides_by_speed counts). A Markdown table: share sliding (frame steps) per band."""
    heads = [f"{lo:g}-{hi:g}" if hi != float("inf") else f"{lo:g}+" for lo, hi in zip(SPEED_BANDS_MPS, SPEED_BANDS_MPS[1:])]
    print("\n| toe frames sliding, by pelvis speed (m/s, 1-s mean) | " + " | ".join(heads) + " |")
    print("|---|" + "---|" * len(heads))
    for name, counts in rows:
        cells = [f"{s / n:.2f} ({n})" if n else "-" for s, n in counts]
        print(f"| {name} | " + " | ".join(cells) + " |")


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("failed: " + " ".join(cmd) + "\n" + r.stderr)
    return r.stdout


def check(generated, real):
    out = run(["/usr/bin/python3", CHECK, *generated, "--real", *real])
    vals = {}
    for line in out.splitlines():
        m = re.match(r"(\w+)\s+generated\s+(\S+)\s+real\s+(\S+)\s+ratio\s+(\S+)", line)
        if m:
            vals[m.group(1)] = dict(generated=float(m.group(2)), real=float(m.group(3)), ratio=float(m.group(4)))
    return vals


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run"); ap.add_argument("dataset")
    ap.add_argument("--out", required=True)
    ap.add_argument("--contents", default="walk")
    ap.add_argument("--n", type=int, default=2)
    ap.add_argument("--max-clips", type=int, default=30)
    ap.add_argument("--mosyn", default=os.path.join(HERE, "..", "build", "mosyn"))
    ap.add_argument("--style", default="")
    ap.add_argument("--take-styles", action="store_true", help="walk each held-out take's control in the take's own style")
    ap.add_argument("--foot-lock", action="store_true")
    ap.add_argument("--realtime", action="store_true",
                    help="play every control frame by frame through the real-time Generator (mosyn sample --realtime)")
    ap.add_argument("--json", default="")
    ap.add_argument("--threads", default="1")
    ap.add_argument("--temperature", default="1")
    ap.add_argument("--seed", type=int, default=0, help="added to every sample's seed (0: the seeds of earlier reports)")
    ap.add_argument("--warmup", default="", help="seconds of lead-in (mosyn sample --warmup); default the family's")
    a = ap.parse_args()
    info, clips = val_clips(a.dataset, a.contents.split(","))
    if a.max_clips and len(clips) > a.max_clips:
        clips = [clips[i * len(clips) // a.max_clips] for i in range(a.max_clips)]
    source_dir = info["source_dirs"][0] if info.get("source_dirs") else info["source_dir"]
    real = [os.path.join(source_dir, c[1]) for c in clips]
    extra = ["--temperature", a.temperature] + (["--foot-lock"] if a.foot_lock else []) + (["--realtime"] if a.realtime else []) + (["--warmup", a.warmup] if a.warmup else [])
    path_style = ["--style", a.style] if a.style else []
    results = {}
    gen = []
    for idx, source, content, style in clips:
        d = os.path.join(a.out, "val")
        # The check compares sets of one content; --take-styles pairs each take with its own style
        # too (as `mosyn eval` does), --style asks every sample for one style.
        take_style = a.style or (style if a.take_styles else "")
        label = ["--content", content] + (["--style", take_style] if take_style else []) if takes_labels(a.run) else []
        run([a.mosyn, "sample", a.run, "--out", d, "--n", str(a.n), "--seed", str(idx + a.seed), "--data", a.dataset,
             "--clip", str(idx), "--prefix", f"clip{idx:04d}", "--threads", a.threads] + label + extra)
        gen += [os.path.join(d, f"clip{idx:04d}_{k:03d}.bvh") for k in range(a.n)]
    results["validation controls"] = check(gen, real)
    all_paths = []
    for name, (path, speed) in PATHS.items():
        d = os.path.join(a.out, name)
        label = ["--content", "walk"] if takes_labels(a.run) else []
        run([a.mosyn, "sample", a.run, "--out", d, "--n", "4", "--seed", str(7 + a.seed), "--path", path, "--speed", str(speed),
             "--prefix", name, "--threads", a.threads] + label + path_style + extra)
        files = [os.path.join(d, f"{name}_{k:03d}.bvh") for k in range(4)]
        all_paths += files
        results["path " + name] = check(files, real)
    results["all synthetic paths"] = check(all_paths, real)
    print(f"| {a.run} ({len(clips)} held-out {a.contents} clips) | v_tol95 cm/s (ratio) | skating (ratio) | step s (ratio) |")
    print("|---|---|---|---|")
    for k, v in results.items():
        cells = [f"{v[m]['generated']:.3g} ({v[m]['ratio']:.2f})" for m in ("v_tol95", "skating", "step_s")]
        print(f"| {k} | " + " | ".join(cells) + " |")
    r = results["validation controls"]
    print(f"| real clips | {r['v_tol95']['real']:.3g} | {r['skating']['real']:.3g} | {r['step_s']['real']:.3g} |")
    split = [("real clips", slides_by_speed(real)), ("validation controls", slides_by_speed(gen)),
             ("all synthetic paths", slides_by_speed(all_paths))]
    print_speed_split(split)
    if a.json:
        slides = {name: dict(bands_mps=list(SPEED_BANDS_MPS[:-1]), sliding=[c[0] for c in counts], steps=[c[1] for c in counts])
                  for name, counts in split}
        json.dump(dict(run=a.run, dataset=a.dataset, clips=[c[1] for c in clips], n=a.n, paths=PATHS,
                       foot_lock=a.foot_lock, realtime=a.realtime, style=a.style, take_styles=a.take_styles, results=results, toe_slides_by_pelvis_speed=slides),
                  open(a.json, "w"), indent=1)


def takes_labels(run_dir):
    cfg = json.load(open(os.path.join(run_dir, "config.json")))
    return bool(cfg.get("model", {}).get("labels", False))


if __name__ == "__main__":
    main()
