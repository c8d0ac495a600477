# Sourced by every models/NAME/recipe.sh: unpacks Bandai-Namco dataset 2 (CC BY-NC 4.0) from
# $MOSYN_DATA into $OUT/data once and sets BN (its folder) and LIMIT (extra `data prepare` flags).
# SMOKE=1: only its cfg and walk files, and a minute of training motion (LIMIT), so every stage of
# a recipe runs in seconds. Needs OUT, MOSYN_DATA and SMOKE set.
LIMIT=""
if [ "$SMOKE" = 1 ]; then
  LIMIT="--max-train-seconds 60"
  BN="$OUT/data/smoke/bandai-namco/Bandai-Namco-Research-Motiondataset-2"
  [ -d "$BN" ] || { mkdir -p "$OUT/data/smoke"; tar -xzf "$MOSYN_DATA/bandai-namco-motion.tar.gz" -C "$OUT/data/smoke" \
      --wildcards '*/Bandai-Namco-Research-Motiondataset-2/cfg/*' '*/dataset-2_walk_*'; }
else
  BN="$OUT/data/bandai-namco/Bandai-Namco-Research-Motiondataset-2"
  [ -d "$BN" ] || tar -xzf "$MOSYN_DATA/bandai-namco-motion.tar.gz" -C "$OUT/data" bandai-namco/Bandai-Namco-Research-Motiondataset-2
fi
