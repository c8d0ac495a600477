#!/usr/bin/env bash
# Rebuilds models/moglow-realtime from the motion archives, every stage written out.
#   bash models/moglow-realtime/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# This model is the look-ahead MoGlow trained further on the paths a real-time controller
# predicts: it starts from run 30 of models/moglow-lookahead's recipe (the look-ahead weights
# before their standing stage), which step 1 rebuilds.
# Wall time (1 training thread): about 7.5 hours for step 1, then 10 minutes.
set -euo pipefail
OUT=${1:?usage: bash models/moglow-realtime/recipe.sh OUT_DIR}
MOSYN=${MOSYN:-build/mosyn}
MOSYN_DATA=${MOSYN_DATA:-../shared/data}
SMOKE=${SMOKE:-0}
HERE=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$OUT/data"

# 1. models/moglow-lookahead's recipe up to its run 30 (it unpacks the Bandai-Namco archive,
#    CC BY-NC 4.0, and prepares `loco20`, whose split every locomotion model is measured on).
RECIPE_UNTIL=run-30 SMOKE=$SMOKE MOSYN=$MOSYN MOSYN_DATA=$MOSYN_DATA bash "$HERE/../moglow-lookahead/recipe.sh" "$OUT/lookahead"
LA="$OUT/lookahead"
LOCO="walk,walk-turn-left,walk-turn-right,run"; LIMIT=""
BN="$LA/data/bandai-namco/Bandai-Namco-Research-Motiondataset-2"
if [ "$SMOKE" = 1 ]; then LIMIT="--max-train-seconds 60"; BN="$LA/data/smoke/bandai-namco/Bandai-Namco-Research-Motiondataset-2"; fi

# 2. `locostand20-s07`: the split of `loco20` with the six standing contents of the same archive
#    added (waving, raising hands: the locomotion takes hold almost no standing), 20 fps,
#    mirrored, joint positions, the root path filtered by a 0.7-s Gaussian, the standardisation
#    of the starting weights.
STAND="wave-both-hands,wave-left-hand,wave-right-hand,raise-up-both-hands,raise-up-left-hand,raise-up-right-hand"
"$MOSYN" data prepare "$BN" --out "$OUT/data/locostand20-s07" --form positions --contents "$LOCO,$STAND" \
    --fps 20 --window 80 --hop 40 --mirror --root-smoothing 0.7 --stats-from "$LA/run-30" \
    --split-from "$LA/data/loco20" $LIMIT --overwrite

# 3. Training from the look-ahead's run 30: every window's look-ahead is the path the runtime's
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
    --init-from "$LA/run-30" --overwrite
cp "$OUT/run/config.json" "$OUT/config.json"
