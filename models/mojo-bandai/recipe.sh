#!/usr/bin/env bash
# Rebuilds models/mojo-bandai from the motion archives, every stage written out.
#   bash models/mojo-bandai/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# OUT_DIR ends as a model directory (config.json, stats.json, checkpoint.pt, log.jsonl).
# Wall time (1 training thread): about 3 hours after the dataset (20,000 steps).
set -euo pipefail
OUT=${1:?usage: bash models/mojo-bandai/recipe.sh OUT_DIR}
MOSYN=${MOSYN:-build/mosyn}
MOSYN_DATA=${MOSYN_DATA:-../shared/data}
SMOKE=${SMOKE:-0}
mkdir -p "$OUT/data"

# 1. The Bandai-Namco archive (CC BY-NC 4.0): dataset 2, unpacked once (SMOKE: its walks only,
#    a minute of them in training).
source "$(dirname "$0")/../../scripts/recipe_archive.sh"

# 2. `bandai2-markers15`: all ten contents of dataset 2 at 15 fps (the paper's rate), the 41 CMU
#    surface markers rigidly attached to the skeleton, in the heading frame of the hip path
#    filtered by the default 0.35-s Gaussian, windows of 60 frames (15 observed + 45 predicted)
#    with hop 10, mirrored, 10% of the files held out (split seed 0).
"$MOSYN" data prepare "$BN" --out "$OUT/data/bandai2-markers15" --form markers --fps 15 --window 60 --hop 10 \
    --mirror $LIMIT --overwrite

# --- Training, the last (only) stage ----------------------------------------------------------
# 3. From scratch, the family's defaults (the paper's config, DLow on the 9 lowest DCT bands),
#    DLow batches of 8 pasts x 50 samples, batch 32, Adam with 1,000 warm-up steps to 1e-3,
#    20,000 steps: the CVAE stage 15,000, the DLow stage 5,000 (`dlow_fraction` 0.25). The
#    original ran steps 1-9,430 under a 40,000-step plan, then was resumed under this 20,000-step
#    plan and stopped 3,317 steps into the DLow stage; here that stage runs to its end.
STEPS=20000; BATCH=32; VAL_WINDOWS=256
if [ "$SMOKE" = 1 ]; then STEPS=2; BATCH=4; VAL_WINDOWS=8; fi
cat > "$OUT/train-config.json" <<JSON
{"model": {"dlow_batch": 8},
 "train": {"batch": $BATCH, "lr": 0.001, "warmup": 1000, "steps": $STEPS, "checkpoint_every": 500,
           "validate_every": 500, "val_windows": $VAL_WINDOWS, "seed": 1, "threads": 1}}
JSON
"$MOSYN" train mojo --data "$OUT/data/bandai2-markers15" --out "$OUT/run" --config "$OUT/train-config.json" --overwrite

# --- Export: the last step (best.pt holds the best CVAE checkpoint; the stages' losses differ) ---
# Shipped with root planting (src/nn/root_planting.h, its defaults): sampling takes each frame's
# root step from the foot on the floor; the fitted bodies are unchanged.
"$MOSYN" export "$OUT/run" --out "$OUT" --checkpoint checkpoint.pt --overwrite --root-planting '{}'
