#!/usr/bin/env bash
# Rebuilds models/moglow-residual from the motion archives, every stage written out.
#   bash models/moglow-residual/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# OUT_DIR ends as a model directory (config.json, stats.json, checkpoint.pt, log.jsonl).
# Wall time (2 idle cores, 1 training thread): about 30 minutes after the dataset.
set -euo pipefail
OUT=${1:?usage: bash models/moglow-residual/recipe.sh OUT_DIR}
MOSYN=${MOSYN:-build/mosyn}
MOSYN_DATA=${MOSYN_DATA:-../shared/data}
SMOKE=${SMOKE:-0}
mkdir -p "$OUT/data"

# 1. The Bandai-Namco archive (CC BY-NC 4.0): dataset 2, unpacked once (SMOKE: its walks only,
#    a minute of them in training).
LOCO="walk,walk-turn-left,walk-turn-right,run"; LIMIT=""
if [ "$SMOKE" = 1 ]; then
  LIMIT="--max-train-seconds 60"
  BN="$OUT/data/smoke/bandai-namco/Bandai-Namco-Research-Motiondataset-2"
  [ -d "$BN" ] || { mkdir -p "$OUT/data/smoke"; tar -xzf "$MOSYN_DATA/bandai-namco-motion.tar.gz" -C "$OUT/data/smoke" \
      --wildcards '*/Bandai-Namco-Research-Motiondataset-2/cfg/*' '*/dataset-2_walk_*'; }
else
  BN="$OUT/data/bandai-namco/Bandai-Namco-Research-Motiondataset-2"
  [ -d "$BN" ] || tar -xzf "$MOSYN_DATA/bandai-namco-motion.tar.gz" -C "$OUT/data" bandai-namco/Bandai-Namco-Research-Motiondataset-2
fi

# 2. `loco20`: the four locomotion contents at 20 fps, joint positions, mirrored, windows of 80
#    frames (hop 40), the root path filtered by the default 0.35-s Gaussian, 10% of the files
#    held out (split seed 0: the held-out files of every locomotion model of mosyn).
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco20" --form positions --contents "$LOCO" \
    --fps 20 --window 80 --hop 40 --mirror $LIMIT --overwrite

STEPS=2409; BATCH=40; VAL_WINDOWS=256
if [ "$SMOKE" = 1 ]; then STEPS=2; BATCH=4; VAL_WINDOWS=8; fi

# --- Training, the last stage ------------------------------------------------------------------
# 3. From scratch: each frame modelled as its difference from the previous frame carried along the
#    root's step (residual), noise 0.1 on the history it conditions on, data dropout 0.3; Adam
#    with 200 warm-up steps to 1e-3; 2,409 steps of 40 windows, the last step exported.
cat > "$OUT/train-config.json" <<JSON
{"model": {"num_steps": 8, "hidden": 128, "lstm_layers": 1, "tau": 10, "dropout": 0.3, "labels": true,
           "residual": true, "history_noise": 0.1},
 "train": {"batch": $BATCH, "window": 80, "lr": 0.001, "warmup": 200, "steps": $STEPS, "checkpoint_every": 100,
           "validate_every": 500, "val_windows": $VAL_WINDOWS, "seed": 1, "threads": 1}}
JSON
"$MOSYN" train moglow --data "$OUT/data/loco20" --out "$OUT/run" --config "$OUT/train-config.json" --overwrite
"$MOSYN" export "$OUT/run" --out "$OUT" --checkpoint checkpoint.pt --overwrite
