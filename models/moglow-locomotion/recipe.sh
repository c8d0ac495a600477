#!/usr/bin/env bash
# Rebuilds models/moglow-locomotion from the motion archives, every stage written out.
#   bash models/moglow-locomotion/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# OUT_DIR ends as a model directory (config.json, stats.json, checkpoint.pt, log.jsonl).
# Wall time (1 training thread): about 4 hours after the dataset (9,222 steps).
set -euo pipefail
OUT=${1:?usage: bash models/moglow-locomotion/recipe.sh OUT_DIR}
MOSYN=${MOSYN:-build/mosyn}
MOSYN_DATA=${MOSYN_DATA:-../shared/data}
SMOKE=${SMOKE:-0}
mkdir -p "$OUT/data"

# 1. The Bandai-Namco archive (CC BY-NC 4.0): dataset 2, unpacked once (SMOKE: its walks only,
#    a minute of them in training).
LOCO="walk,walk-turn-left,walk-turn-right,run"
source "$(dirname "$0")/../../scripts/recipe_archive.sh"

# 2. `loco20`: the four locomotion contents at 20 fps, joint positions, mirrored, windows of 80
#    frames (hop 40), the root path filtered by the default 0.35-s Gaussian, 10% of the files
#    held out (split seed 0: the held-out files of every locomotion model of mosyn).
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco20" --form positions --contents "$LOCO" \
    --fps 20 --window 80 --hop 40 --mirror $LIMIT --overwrite

# Three runs, each from the weights of the one before (--init-from). One config but for the data
# dropout: K = 8 flow steps, one 128-unit LSTM per coupling, 10 frames of history, labels, Adam
# with 200 warm-up steps to 1e-3, batch 40 windows of 80 frames.
BATCH=40; VAL_WINDOWS=256; S1=1722; S2=3500; S3=4000
if [ "$SMOKE" = 1 ]; then BATCH=4; VAL_WINDOWS=8; S1=2; S2=2; S3=2; fi
config() {  # config DROPOUT STEPS > file
  cat <<JSON
{"model": {"num_steps": 8, "hidden": 128, "lstm_layers": 1, "tau": 10, "dropout": $1, "labels": true},
 "train": {"batch": $BATCH, "window": 80, "lr": 0.001, "warmup": 200, "steps": $2, "checkpoint_every": 200,
           "validate_every": 500, "val_windows": $VAL_WINDOWS, "seed": 1, "threads": 1}}
JSON
}

# 3. From scratch, the paper's 95% data dropout for positions: 1,722 steps.
config 0.95 $S1 > "$OUT/train-config-1.json"
"$MOSYN" train moglow --data "$OUT/data/loco20" --out "$OUT/run-1" --config "$OUT/train-config-1.json" --overwrite

# 4. 60% dropout (the paper's value for its later model): 3,500 steps.
config 0.6 $S2 > "$OUT/train-config-2.json"
"$MOSYN" train moglow --data "$OUT/data/loco20" --out "$OUT/run-2" --config "$OUT/train-config-2.json" \
    --init-from "$OUT/run-1" --overwrite

# 5. The same config, 4,000 steps more (the original ran 4,551 and kept step 4,000, its best
#    validation; the learning rate depends on the step only, so the weights are the same).
config 0.6 $S3 > "$OUT/train-config.json"
"$MOSYN" train moglow --data "$OUT/data/loco20" --out "$OUT/run" --config "$OUT/train-config.json" \
    --init-from "$OUT/run-2" --overwrite
"$MOSYN" export "$OUT/run" --out "$OUT" --checkpoint checkpoint.pt --overwrite
