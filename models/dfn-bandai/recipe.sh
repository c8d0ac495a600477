#!/usr/bin/env bash
# Rebuilds models/dfn-bandai from the motion archives, every stage written out.
#   bash models/dfn-bandai/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# OUT_DIR ends as a model directory (config.json, stats.json, checkpoint.pt, log.jsonl).
# Wall time (1 training thread): about 5 hours after the dataset (five runs, 15,985 steps).
set -euo pipefail
OUT=${1:?usage: bash models/dfn-bandai/recipe.sh OUT_DIR}
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

# Five runs, each from the weights of the one before (--init-from). The paper's sizes (the
# family's defaults: code 16 with a 12-d pose part, horizon 10, state 128, FK layer), batch 32,
# Adam with a Noam warm-up scaled to each stage's share of the run. `stage_steps` gives each
# stage's steps (autoencoder, future, dynamics; 0 keeps a trained stage as it is).
BATCH=32; VAL_WINDOWS=256
S1='[600, 400, 485]'; S2=6000; S3=2500; S5=4000; S19=2000; KEEP=checkpoint-500.pt
if [ "$SMOKE" = 1 ]; then BATCH=4; VAL_WINDOWS=8; S1='[1, 1, 1]'; S2=2; S3=2; S5=2; S19=2; KEEP=checkpoint.pt; fi
config() {  # config MODEL_KEYS STEPS LR WARMUP SEED WINDOW VALIDATE_EVERY > file
  cat <<JSON
{"model": {$1},
 "train": {"batch": $BATCH, "steps": $2, "lr": $3, "warmup": $4, "seed": $5, "window": $6, "checkpoint_every": 100,
           "validate_every": $7, "val_windows": $VAL_WINDOWS, "threads": 1}}
JSON
}
train() {  # train RUN CONFIG [INIT_FROM] [FLAGS...]
  local run=$1 config=$2 init=${3:-}; shift 3 || shift $#
  "$MOSYN" train dfn --data "$OUT/data/bandai2-rot200" --out "$OUT/$run" --config "$config" \
      ${init:+--init-from "$OUT/$init"} --overwrite "$@"
}

# 3. Run 1, from scratch, all three stages on 200-frame windows, peak 1e-3 with 1,000 warm-up
#    steps over a 2,000-step plan (stages 600 / 400 / 1,000). It was stopped at step 1,485, 485
#    steps into the dynamics stage; here that stage is 485 steps long, so its warm-up scales to
#    243 steps instead of 500 (the autoencoder and future stages, kept from here on, are as trained).
config "\"stage_steps\": $S1" 2000 0.001 1000 1 200 500 > "$OUT/train-config-1.json"
train run-1 "$OUT/train-config-1.json"
# 4. Run 2, the dynamics stage alone on 100-frame windows with free bits (each KL term counts at
#    least 1 nat a frame; the latents had collapsed onto their priors): 6,000 steps, peak 1e-3.
config "\"stage_steps\": [0, 0, $S2], \"kl_free_nats\": 1.0" $S2 0.001 200 1 100 500 > "$OUT/train-config-2.json"
train run-2 "$OUT/train-config-2.json" run-1
# 5. Run 3, peak 5e-4: 2,500 steps (planned 4,500; it diverged after its best step, 2,500, which
#    went on; a run planned as 2,500 steps has the same schedule to there).
config "\"stage_steps\": [0, 0, $S3], \"kl_free_nats\": 1.0" $S3 0.0005 200 3 100 500 > "$OUT/train-config-3.json"
train run-3 "$OUT/train-config-3.json" run-2
# 6. Run 5, free bits 3 nats, peak 3e-4: 4,000 steps.
config "\"stage_steps\": [0, 0, $S5], \"kl_free_nats\": 3.0" $S5 0.0003 200 5 100 500 > "$OUT/train-config-5.json"
train run-5 "$OUT/train-config-5.json" run-3

# --- The last training stage: run 19 ----------------------------------------------------------
# 7. Content and style labels as conditions (their inputs start at zero, label dropout 0.1),
#    peak 2e-4 with 150 warm-up steps, 2,000 steps; its step 500 is the model (later checkpoints
#    swing between continuations that stop and standing that walks off).
config "\"stage_steps\": [0, 0, $S19], \"kl_free_nats\": 3.0, \"labels\": true, \"label_dropout\": 0.1" \
    $S19 0.0002 150 19 100 250 > "$OUT/train-config.json"
train run "$OUT/train-config.json" run-5 --keep-checkpoints

# --- Export -------------------------------------------------------------------------------------
"$MOSYN" export "$OUT/run" --out "$OUT" --checkpoint "$KEEP" --overwrite
