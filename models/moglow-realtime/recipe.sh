#!/usr/bin/env bash
# Rebuilds models/moglow-realtime from the motion archives, every stage written out.
#   bash models/moglow-realtime/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# The starting weights are models/moglow-lookahead's (its own recipe.sh rebuilds them): this
# model is the look-ahead MoGlow trained further on the paths a real-time controller predicts.
# Wall time (2 idle cores, 1 training thread): about 10 minutes after the datasets.
set -euo pipefail
OUT=${1:?usage: bash models/moglow-realtime/recipe.sh OUT_DIR}
MOSYN=${MOSYN:-build/mosyn}
MOSYN_DATA=${MOSYN_DATA:-../shared/data}
SMOKE=${SMOKE:-0}
HERE=$(cd "$(dirname "$0")" && pwd)
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

# 2. Datasets at 20 fps, mirrored, positions. loco20 fixes the train/validation split (10% of the
#    files held out, split seed 0) that every locomotion model of mosyn is measured on; locostand20-s07
#    keeps that split and adds the six standing contents of the same archive (waving, raising
#    hands: the locomotion takes hold almost no standing), with the root path filtered by a 0.7-s
#    Gaussian and the standardisation of the starting weights.
STAND="wave-both-hands,wave-left-hand,wave-right-hand,raise-up-both-hands,raise-up-left-hand,raise-up-right-hand"
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco20" --form positions --contents "$LOCO" \
    --fps 20 --window 80 --hop 40 --mirror $LIMIT --overwrite
"$MOSYN" data prepare "$BN" --out "$OUT/data/locostand20-s07" --form positions --contents "$LOCO,$STAND" \
    --fps 20 --window 80 --hop 40 --mirror --root-smoothing 0.7 --stats-from "$HERE/../moglow-lookahead" \
    --split-from "$OUT/data/loco20" $LIMIT --overwrite

# 3. Training from models/moglow-lookahead: every window's look-ahead is the path the runtime's
#    controller predicts (predicted_lookahead 1), the foot terms of the starting weights' last
#    stage, the standing windows drawn at 0.15 of their share (19% of the draws).
STEPS=300; BATCH=40; VALIDATE=250; VAL_WINDOWS=256
if [ "$SMOKE" = 1 ]; then STEPS=2; BATCH=4; VALIDATE=1000; VAL_WINDOWS=8; fi
cat > "$OUT/train-config.json" <<JSON
{"model": {"num_steps": 8, "hidden": 128, "lstm_layers": 1, "tau": 10, "dropout": 0.3, "labels": true,
           "residual": true, "history_noise": 0.01, "lookahead": [5, 10, 20], "predicted_lookahead": 1.0,
           "lead_in_s": 3.0, "foot_contact_weight": 1.0, "foot_contact_rollout": 40, "pelvis_follow_weight": 3.0,
           "stance_weight": 10.0, "phase_locked_frames": 10, "cold_start_fraction": 0.5},
 "train": {"batch": $BATCH, "window": 80, "window_sampling": "frames", "lr": 0.0001, "warmup": 100,
           "steps": $STEPS, "checkpoint_every": 100, "validate_every": $VALIDATE, "val_windows": $VAL_WINDOWS, "seed": 71, "threads": 1,
           "label_weights": {"wave-both-hands:*": 0.15, "wave-left-hand:*": 0.15, "wave-right-hand:*": 0.15,
                             "raise-up-both-hands:*": 0.15, "raise-up-left-hand:*": 0.15,
                             "raise-up-right-hand:*": 0.15}}}
JSON
"$MOSYN" train moglow --data "$OUT/data/locostand20-s07" --out "$OUT/run" --config "$OUT/train-config.json" \
    --init-from "$HERE/../moglow-lookahead" --overwrite
cp "$OUT/run/config.json" "$OUT/config.json"
