#!/usr/bin/env bash
# Rebuilds models/hvrnn-bandai from the motion archives, every stage written out.
#   bash models/hvrnn-bandai/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# OUT_DIR ends as a model directory (config.json, stats.json, checkpoint.pt, log.jsonl).
# The classifier loss reads models/classifier-bandai2-train (its own recipe.sh rebuilds it).
# Wall time (1 training thread): about 9 hours after the dataset (seven runs, 22,945 steps).
set -euo pipefail
OUT=${1:?usage: bash models/hvrnn-bandai/recipe.sh OUT_DIR}
MOSYN=${MOSYN:-build/mosyn}
MOSYN_DATA=${MOSYN_DATA:-../shared/data}
SMOKE=${SMOKE:-0}
mkdir -p "$OUT/data"

# 1. The Bandai-Namco archive (CC BY-NC 4.0): dataset 2, unpacked once (SMOKE: its walks only,
#    a minute of them in training).
source "$(dirname "$0")/../../scripts/recipe_archive.sh"

# 2. `bandai2-rot200`: all ten contents of dataset 2 at its own 30 fps, joint rotations, the root
#    path filtered by the default 0.35-s Gaussian, mirrored, windows of 200 frames (hop 50), 10%
#    of the files held out (split seed 0).
"$MOSYN" data prepare "$BN" --out "$OUT/data/bandai2-rot200" --form rotations --mirror --window 200 --hop 50 \
    $LIMIT --overwrite

# Seven runs, each from the weights of the one before (--init-from). The paper's sizes (preset
# `full`: words of 3 frames, two 512-unit GRU layers, latent 96, hierarchical joint weights),
# batch 32 windows of up to 200 frames (shorter clips padded), gradient-norm clip 0.1, the
# classifier loss through models/classifier-bandai2-train with its feature term at 0.002.
BATCH=32; WINDOW=200; VAL_WINDOWS=256
S1=1500; KEEP1=checkpoint-1250.pt; S2=1400; S3=12500; S4A=1284; S4B=4000; S4C=1261; S5=1000
if [ "$SMOKE" = 1 ]; then BATCH=2; WINDOW=30; VAL_WINDOWS=2; S1=2; KEEP1=checkpoint-2.pt; S2=2; S3=2; S4A=2; S4B=2; S4C=2; S5=2; fi
BASE='"preset": "full", "classifier_run": "models/classifier-bandai2-train", "classifier_feature_weight": 0.002'
# From run 2 on, the schedules stay at their final values (the weights come annealed).
HELD='"kl_warmup": 0.0, "kl_anneal": 0.0, "classifier_ramp": 0.0, "word_drop_ramp": 0.0'
config() {  # config MODEL_KEYS STEPS LR EVERY [SEED] > file
  cat <<JSON
{"model": {$BASE${1:+, $1}},
 "train": {"batch": $BATCH, "window": $WINDOW, "steps": $2, "lr": $3, "warmup": 0, "grad_clip": 0.1, "seed": ${5:-1}, "checkpoint_every": $4,
           "validate_every": $4, "val_windows": $VAL_WINDOWS, "threads": 1}}
JSON
}
train() {  # train RUN CONFIG [INIT_FROM] [FLAGS...]
  local run=$1 config=$2 init=${3:-}; shift 3 || shift $#
  "$MOSYN" train hvrnn --data "$OUT/data/bandai2-rot200" --out "$OUT/$run" --config "$config" \
      ${init:+--init-from "$OUT/$init"} --overwrite "$@"
}

# 3. Run 1, from scratch, the preset's schedules over a 1,500-step plan (KL warm-up 10% then
#    annealed over 40%, word dropout and classifier loss ramped in), peak 1e-3; its step 1,250
#    (the best validation) goes on. The original stopped at 1,316 steps, trained on the clips of
#    at least 200 frames only, with a first loss classifier since retrained on 40-frame windows;
#    here every clip trains, through the shipped loss classifier.
[ "$SMOKE" = 1 ] && E1=1 || E1=250
config "" $S1 0.001 $E1 > "$OUT/train-config-1.json"
train run-1 "$OUT/train-config-1.json" "" --keep-checkpoints
"$MOSYN" export "$OUT/run-1" --out "$OUT/stage-1" --checkpoint "$KEEP1" --overwrite
# 4. Run 2, every clip from its start for up to 200 frames: 1,400 steps (its best validation).
config "$HELD" $S2 0.001 100 > "$OUT/train-config-2.json"
train run-2 "$OUT/train-config-2.json" stage-1
# 5. Run 3, free bits (each word's KL counts at least 0.5 nats; the latent carried little):
#    12,500 steps (of 13,100; its best validation went on).
FREE='"kl_free_nats": 0.5'
config "$HELD, $FREE" $S3 0.001 500 > "$OUT/train-config-3.json"
train run-3 "$OUT/train-config-3.json" run-2
# 6. Run 4a, the word decoder also sees the frame before its word (its new inputs start at zero),
#    peak 5e-4: 1,284 steps.
PREV='"decoder_previous_frame": true'
config "$HELD, $FREE, $PREV" $S4A 0.0005 250 > "$OUT/train-config-4a.json"
train run-4a "$OUT/train-config-4a.json" run-3
# 7. Run 4b, the boundary term at 1 (each word also decoded from a prior draw, its first frame's
#    error in the loss): 4,000 steps.
config "$HELD, $FREE, $PREV, \"boundary_weight\": 1.0" $S4B 0.0005 250 > "$OUT/train-config-4b.json"
train run-4b "$OUT/train-config-4b.json" run-4a

# 8. Run 4c, the boundary term at 2: 1,261 steps.
config "$HELD, $FREE, $PREV, \"boundary_weight\": 2.0" $S4C 0.0005 250 > "$OUT/train-config-4c.json"
train run-4c "$OUT/train-config-4c.json" run-4b

# --- The last training stage: run 5 -------------------------------------------------------------
# 9. The shared terms on free draws (src/nn/objectives/draw_objectives.h): every word also decoded
#    from a prior draw at its teacher-forced state, the drawn words' heels held to the data's
#    phase-free stance and speed distribution (1 each), their toes not to slide (3), their root as
#    fast as the window's within 1.2x (1). Peak 2e-4, seed 5: 1,000 steps, the last is the model.
DRAW='"draw_stance_weight": 1.0, "draw_speed_distribution_weight": 1.0, "draw_toe_slide_weight": 3.0, "draw_speed_weight": 1.0, "draw_speed_tolerance": 1.2'
config "$HELD, $FREE, $PREV, \"boundary_weight\": 2.0, $DRAW" $S5 0.0002 250 5 > "$OUT/train-config.json"
train run "$OUT/train-config.json" run-4c

# --- Export -------------------------------------------------------------------------------------
# 10. Shipped with root planting (src/nn/root_planting.h, its defaults): sampling takes each
#     frame's root step from the foot on the floor, the poses unchanged.
"$MOSYN" export "$OUT/run" --out "$OUT" --checkpoint checkpoint.pt --overwrite --root-planting '{}'
