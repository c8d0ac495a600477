#!/usr/bin/env bash
# Rebuilds models/classifier-bandai2 from the motion archives, every stage written out.
#   bash models/classifier-bandai2/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# OUT_DIR ends as a model directory (config.json, stats.json, checkpoint.pt, log.jsonl).
# Wall time (1 training thread): about 2 minutes after the dataset.
set -euo pipefail
OUT=${1:?usage: bash models/classifier-bandai2/recipe.sh OUT_DIR}
MOSYN=${MOSYN:-build/mosyn}
MOSYN_DATA=${MOSYN_DATA:-../shared/data}
SMOKE=${SMOKE:-0}
mkdir -p "$OUT/data"

# 1. The Bandai-Namco archive (CC BY-NC 4.0): dataset 2, unpacked once (SMOKE: its walks only,
#    a minute of them in training).
source "$(dirname "$0")/../../scripts/recipe_archive.sh"

# 2. `bandai2-rot200`: all ten contents of dataset 2 at its own 30 fps, joint rotations, mirrored,
#    windows of 200 frames (hop 50), 10% of the files held out (split seed 0).
"$MOSYN" data prepare "$BN" --out "$OUT/data/bandai2-rot200" --form rotations --mirror --window 200 --hop 50 $LIMIT --overwrite

# 3. Training from scratch on windows of 40 frames drawn from every clip (the raise-up clips and
#    most runs and turns are shorter than 200 frames), batch 100, 1,000 warm-up steps to 1e-3,
#    seed 7, 3,000 steps (the original ran 6,000 and kept step 3,000, its lowest validation loss;
#    the learning rate depends on the step only, so stopping at 3,000 gives the same weights).
STEPS=3000; BATCH=100; VAL_WINDOWS=256
if [ "$SMOKE" = 1 ]; then STEPS=2; BATCH=4; VAL_WINDOWS=8; fi
cat > "$OUT/train-config.json" <<JSON
{"model": {},
 "train": {"batch": $BATCH, "window": 40, "lr": 0.001, "warmup": 1000, "steps": $STEPS, "checkpoint_every": 250,
           "validate_every": 500, "val_windows": $VAL_WINDOWS, "seed": 7, "threads": 1}}
JSON
"$MOSYN" train classifier --data "$OUT/data/bandai2-rot200" --out "$OUT/run" --config "$OUT/train-config.json" --overwrite
"$MOSYN" export "$OUT/run" --out "$OUT" --checkpoint checkpoint.pt --overwrite
