#!/bin/bash
# Makes the tiny models the tests use (tests/models/), from the project's own synthetic motion
# (never from ../shared/data), so that test fixtures copy them instead of training in every test
# process. Rerun after a change to the run-directory or dataset format:
#   scripts/make_test_models.sh [build/mosyn]
# Deterministic: one thread, fixed seeds; paths in the files are relative to the repository.
set -euo pipefail
cd "$(dirname "$0")/.."
MOSYN=${1:-build/mosyn}
OUT=tests/models
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
rm -rf "$OUT"
mkdir -p "$OUT"
"$MOSYN" data synth "$TMP/source" --takes 2 --frames 90 --seed 3
# Joint rotations with mirrored copies (moglow, classifier); joint positions (rvae).
"$MOSYN" data prepare "$TMP/source" --out "$OUT/dataset-rotations" --window 40 --hop 10 --val 0.25 --threads 1 --mirror
"$MOSYN" data prepare "$TMP/source" --out "$OUT/dataset-positions" --form positions --window 40 --hop 10 --val 0.25 \
  --threads 1
cat > "$TMP/moglow.json" <<'JSON'
{"model": {"num_steps": 2, "hidden": 16, "tau": 4},
 "train": {"steps": 6, "batch": 4, "window": 20, "warmup": 0, "validate_every": 3, "checkpoint_every": 3}}
JSON
cat > "$TMP/rvae.json" <<'JSON'
{"model": {"encoder_channels": [8, 8], "control_channels": [4, 4], "decoder_channels": [8], "latent": 4, "kernel": 5},
 "train": {"steps": 4, "batch": 4, "window": 40, "warmup": 0, "validate_every": 2, "checkpoint_every": 2}}
JSON
cat > "$TMP/classifier.json" <<'JSON'
{"model": {"channels": 8, "features": 8},
 "train": {"steps": 10, "batch": 8, "window": 30, "warmup": 0, "validate_every": 5, "checkpoint_every": 5}}
JSON
"$MOSYN" train moglow --data "$OUT/dataset-rotations" --out "$OUT/moglow" --config "$TMP/moglow.json" --threads 1
"$MOSYN" train rvae --data "$OUT/dataset-positions" --out "$OUT/rvae" --config "$TMP/rvae.json" --threads 1
"$MOSYN" train classifier --data "$OUT/dataset-rotations" --out "$OUT/classifier" --config "$TMP/classifier.json" \
  --threads 1
# Temporary source paths mean nothing once committed.
for f in "$OUT"/*/dataset.json "$OUT"/*/config.json; do
  sed -i "s|$TMP/source|tests/models/source|g" "$f"
done
rm -f "$OUT"/*/.lock "$OUT"/*/best.pt  # tests use checkpoint.pt; half the size
du -sh "$OUT"
