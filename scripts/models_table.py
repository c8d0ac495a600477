#!/usr/bin/env python3
"""The one table of models/README.md: every shipped generating model beside the held-out real
clips of its own dataset, read from what `mosyn compare` wrote (compare.json).

    scripts/models_table.py COMPARE_DIR/compare.json > table.md

One row per model; each cell is "model / real" where the measure has a real value (the held-out
clips of the model's dataset), the model's alone where it has none (diversity among one control's
samples, prediction against a constant-velocity baseline). The walk measures are those of the
held-out clips of content walk (the models sampled along their controls, for their labels, or
continuing them, as each family takes input). Python's standard library only.
"""
import json
import math
import sys

# (key, column title, format); the real value is shown when the compare has one.
MEASURES = [
    ("locomotion.walk.footsteps.v_tol95_cmps", "walks: heel v_tol95 (cm/s)", "{:.0f}"),
    ("locomotion.walk.foot_skating_ratio", "walks: foot skating", "{:.2f}"),
    ("locomotion.walk.footsteps.duration_mean_s", "walks: step (s)", "{:.2f}"),
    ("locomotion.walk.pelvis_ground_speed_mps", "walks: pelvis (m/s)", "{:.2f}"),
    ("foot_skating_ratio", "all clips: foot skating", "{:.2f}"),
    ("diversity.apd_m", "APD of one control's samples (m)", "{:.1f}"),
    ("prediction.ade_over_cv", "prediction ADE / constant velocity", "{:.2f}"),
]


def number(v):
    return v is not None and not (isinstance(v, float) and math.isnan(v))


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    try:
        compare = json.load(open(sys.argv[1]))
        columns, rows = compare["columns"], {r["key"]: r["values"] for r in compare["rows"]}
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"{sys.argv[1]}: not a compare.json of `mosyn compare` ({e})")
    real_of = {c["dataset"]: i for i, c in enumerate(columns) if c["kind"] == "real"}
    print("| model | dataset | " + " | ".join(title for _, title, _ in MEASURES) + " |")
    print("|---" * (len(MEASURES) + 2) + "|")
    for i, c in enumerate(columns):
        if c["kind"] != "run":
            continue
        cells = []
        for key, _, fmt in MEASURES:
            values = rows.get(key)
            model = values[i] if values else None
            real = values[real_of[c["dataset"]]] if values else None
            if not number(model):
                cells.append("n/a")
            elif number(real):
                cells.append(fmt.format(model) + " / " + fmt.format(real))
            else:
                cells.append(fmt.format(model))
        dataset = c["dataset"].rstrip("/").split("/")[-1]
        print(f"| [{c['name']}]({c['name']}/README.md) | `{dataset}` | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
