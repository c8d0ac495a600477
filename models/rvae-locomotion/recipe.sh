#!/usr/bin/env bash
# Rebuilds models/rvae-locomotion from the motion archives, every stage written out.
#   bash models/rvae-locomotion/recipe.sh OUT_DIR        (from the repository root)
# Environment: MOSYN (the binary, default build/mosyn), MOSYN_DATA (the folder of the archives,
# default ../shared/data), SMOKE=1 (every stage with a handful of steps, as `make test` runs it).
# OUT_DIR ends as a model directory (config.json, stats.json, checkpoint.pt, log.jsonl).
# Wall time (1 training thread): about 4.6 hours after the datasets (16 runs, 142,960 steps).
set -euo pipefail
OUT=${1:?usage: bash models/rvae-locomotion/recipe.sh OUT_DIR}
MOSYN=${MOSYN:-build/mosyn}
MOSYN_DATA=${MOSYN_DATA:-../shared/data}
SMOKE=${SMOKE:-0}
mkdir -p "$OUT/data"

# 1. The Bandai-Namco archive (CC BY-NC 4.0): dataset 2, unpacked once (SMOKE: its walks only,
#    a minute of them in training).
LOCO="walk,walk-turn-left,walk-turn-right,run"
source "$(dirname "$0")/../../scripts/recipe_archive.sh"
STAND="wave-both-hands"

# 2. Datasets at 30 fps, joint positions, mirrored, windows of 120 frames (hop 30), 10% of the
#    files held out (split seed 0: the held-out files of every locomotion model of mosyn). They
#    differ in the root path's Gaussian filter (none, the default 0.35 s, 0.7 s) and, from
#    `loco30-fast` on, in added copies; those keep the split and standardisation of `loco30-s07`.
P=(--form positions --fps 30 --window 120 --hop 30 --mirror $LIMIT --overwrite)
RETIME=(--retime 1.25 --retime-min-speed 1.3 --retime-max-speed 1.7)
KEEP=(--stats-from "$OUT/data/loco30-s07" --split-from "$OUT/data/loco30-s07")
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco30-raw" --contents "$LOCO" --root-smoothing 0 "${P[@]}"
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco30" --contents "$LOCO" "${P[@]}"
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco30-s07" --contents "$LOCO" --root-smoothing 0.7 "${P[@]}"
#    the takes walked at 1.3-1.7 m/s also played 1.25 times as fast (walks up to about 2 m/s)
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco30-fast" --contents "$LOCO" --root-smoothing 0.7 "${RETIME[@]}" \
    "${KEEP[@]}" "${P[@]}"
#    plus the standing takes of `wave-both-hands` (no locomotion take starts or stops)
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco30-stand" --contents "$LOCO,$STAND" --root-smoothing 0.7 \
    "${RETIME[@]}" "${KEEP[@]}" "${P[@]}"
#    plus, beside every moving clip, a copy that starts from rest and one that comes to rest at its
#    double-support frame (speed ramped over 1 s, the still pose held 2 s)
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco30-rest" --contents "$LOCO,$STAND" --root-smoothing 0.7 \
    "${RETIME[@]}" --rest-ends 2 "${KEEP[@]}" "${P[@]}"

# Sixteen runs, each from the weights of the one before (--init-from). The paper's network
# with its time constants in seconds (kernel 13 at 30 fps; channels 64/256, 64/128, 128; latent
# 128), input dropout 0.1, batch 32, Adam at a constant rate. A run whose weights went on from
# step N of a longer run trains N steps here (the rate is constant, so the weights are the same).
BATCH=32; VAL_WINDOWS=256
N=(16000 8460 26500 9000 8000 12000 4000 20000 11000 4000 4000 8000 3000 3000 3000 3000)
if [ "$SMOKE" = 1 ]; then BATCH=4; VAL_WINDOWS=8; N=(2 2 2 2 2 2 2 2 2 2 2 2 2 2 2 2); fi
NET='"encoder_channels": [64, 256], "control_channels": [64, 128], "decoder_channels": [128], "latent": 128, "kernel": 13, "input_dropout": 0.1, "kl_weight": 1.0, "kl_anneal": 0.0, "l1": 0.0, "test_latents": "every_step"'
stage() {  # stage INDEX DATA MODEL_KEYS LR WINDOW SEED EVERY [INIT_FROM]: trains $OUT/run-INDEX
  cat > "$OUT/train-config-$1.json" <<JSON
{"model": {$NET, $3},
 "train": {"batch": $BATCH, "window": $5, "lr": $4, "warmup": 0, "steps": ${N[$1-1]}, "seed": $6,
           "checkpoint_every": $7, "validate_every": $7, "val_windows": $VAL_WINDOWS, "threads": 1}}
JSON
  "$MOSYN" train rvae --data "$OUT/data/$2" --out "$OUT/run-$1" --config "$OUT/train-config-$1.json" \
      ${8:+--init-from "$OUT/run-$8"} --overwrite
}
L='"labels": true'; C='"latent_prior": "conditional"'

# 3. The raw hip path, the paper's standard prior, no labels: 16,000 steps at 5e-4.
stage 1 loco30-raw '"labels": false' 0.0005 120 1 500
# 4. The 0.35-s filtered path, content and style labels (their inputs start at zero): 8,460 steps.
stage 2 loco30 "$L" 0.0005 120 1 500 1
# 5. The conditional latent prior (its output layer starts at zero, the standard prior): 26,500
#    steps (the original ran 28,660; its best validation, step 26,500, went on).
stage 3 loco30 "$L, $C" 0.0005 120 1 500 2
# 6. The 0.7-s filtered path (0.35 s leaves the gait's rhythm in the control, and the model read
#    its cadence from it): 9,000 steps (of 12,000; the best validation went on).
stage 4 loco30-s07 "$L, $C" 0.0005 120 1 500 3
# 7. A constant 1.5e-4: 8,000 steps.
stage 5 loco30-s07 "$L, $C" 0.00015 120 8 500 4
# 8. The foot-contact term at weight 2 (planted heels held still): 12,000 steps.
stage 6 loco30-s07 "$L, $C, \"foot_contact_weight\": 2.0" 0.00015 120 10 500 5
# 9. The term halved to 1: 4,000 steps.
F='"foot_contact_weight": 1.0'
stage 7 loco30-s07 "$L, $C, $F" 0.00015 120 11 500 6
# 10. Windows of 60 frames (most run takes are shorter than 120): 20,000 steps.
stage 8 loco30-s07 "$L, $C, $F" 0.00015 60 12 1000 7
# 11. `loco30-fast`: 11,000 steps (of 15,000; the best validation went on).
stage 9 loco30-fast "$L, $C, $F" 0.00015 60 13 1000 8
# 12. The heel-speed term at 0.3 (shorter contacts in the runs): 4,000 steps.
H='"heel_speed_weight": 0.3'
stage 10 loco30-fast "$L, $C, $F, $H" 0.00015 60 25 1000 9
# 13. `loco30-stand` (the standing takes): 4,000 steps, then 8,000 more.
stage 11 loco30-stand "$L, $C, $F, $H" 0.00015 60 30 1000 10
stage 12 loco30-stand "$L, $C, $F, $H" 0.00015 60 31 1000 11
# 14. `loco30-rest` (takes that start from and come to rest): 3,000 steps.
stage 13 loco30-rest "$L, $C, $F, $H" 0.00015 60 44 1000 12

# 15. The toe-slide term at 3 (toes kept from sliding when a style is asked for): 3,000 steps.
stage 14 loco30-rest "$L, $C, $F, $H, \"toe_slide_weight\": 3" 0.00015 60 60 1000 13

# --- The last training stage: standing (the weights shipped now) ------------------------------
# 16. `loco30-rest6`: as `loco30-rest` with the still pose of the rest copies held 6 s instead of
#     2 (told to stand 10 s, the hips had wandered up to 0.41 m off the root: the windows never
#     showed a still body lasting): two runs of 3,000 steps.
"$MOSYN" data prepare "$BN" --out "$OUT/data/loco30-rest6" --contents "$LOCO,$STAND" --root-smoothing 0.7 \
    "${RETIME[@]}" --rest-ends 6 "${KEEP[@]}" "${P[@]}"
T='"toe_slide_weight": 3'
stage 15 loco30-rest6 "$L, $C, $F, $H, $T" 0.00015 60 73 1000 14
stage 16 loco30-rest6 "$L, $C, $F, $H, $T" 0.00015 60 74 1000 15

# --- Export: the last stage's last step is the model ------------------------------------------
"$MOSYN" export "$OUT/run-16" --out "$OUT" --checkpoint checkpoint.pt --overwrite
