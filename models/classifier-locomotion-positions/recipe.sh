#!/usr/bin/env bash
# Rebuilds models/classifier-locomotion-positions from the motion archives, every stage written out.
#   bash models/classifier-locomotion-positions/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# OUT_DIR ends as a model directory (config.json, stats.json, checkpoint.pt, log.jsonl).
# Wall time (1 training thread): about half a minute after the dataset.
set -euo pipefail
OUT=${1:?usage: bash models/classifier-locomotion-positions/recipe.sh OUT_DIR}
MOSYN=${MOSYN:-build/mosyn}
MOSYN_DATA=${MOSYN_DATA:-../shared/data}
SMOKE=${SMOKE:-0}
mkdir -p "$OUT/data"

# 1. The Bandai-Namco archive (CC BY-NC 4.0): dataset 2, unpacked once (SMOKE: its walks only,
#    a minute of them in training).
LOCO="walk,walk-turn-left,walk-turn-right,run"
source "$(dirname "$0")/../../scripts/recipe_archive.sh"

# 2. `loco-positions`: the four locomotion contents at 30 fps, joint positions (the form every
#    family can be scored in: rotations follow positions by forward kinematics), mirrored, windows of 120
#    frames (hop 30), 10% of the files held out (split seed 0).
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco-positions" --form positions --contents "$LOCO" --fps 30 --mirror $LIMIT --overwrite

# 3. Training from scratch: 600 steps of 64 windows, 50 warm-up steps to 1e-3; the last step (the
#    lowest validation loss) is the model.
STEPS=600; BATCH=64; VAL_WINDOWS=256
if [ "$SMOKE" = 1 ]; then STEPS=2; BATCH=4; VAL_WINDOWS=8; fi
cat > "$OUT/train-config.json" <<JSON
{"model": {},
 "train": {"batch": $BATCH, "lr": 0.001, "warmup": 50, "steps": $STEPS, "checkpoint_every": 100,
           "validate_every": 100, "val_windows": $VAL_WINDOWS, "seed": 1, "threads": 1}}
JSON
"$MOSYN" train classifier --data "$OUT/data/loco-positions" --out "$OUT/run" --config "$OUT/train-config.json" --overwrite
"$MOSYN" export "$OUT/run" --out "$OUT" --checkpoint checkpoint.pt --overwrite
