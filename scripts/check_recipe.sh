#!/usr/bin/env bash
# Runs a shipped model's recipe in smoke mode (SMOKE=1: every stage, a handful of steps) into a
# fresh folder and checks that it rebuilt the shipped architecture: OUT/config.json has the same
# family and model section as models/NAME/config.json, but for the keys that only count training
# steps (DFN's stage_steps), which SMOKE shortens as it does --steps. `make test` runs it for every
# recipe.
#   scripts/check_recipe.sh NAME OUT_DIR        (MOSYN, MOSYN_DATA as the recipes take them)
set -euo pipefail
name=${1:?usage: check_recipe.sh NAME OUT_DIR}
out=${2:?usage: check_recipe.sh NAME OUT_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
rm -rf "$out/run" "$out/config.json"
mkdir -p "$out"
SMOKE=1 bash "models/$name/recipe.sh" "$out"
python3 - "models/$name/config.json" "$out/config.json" <<'PY'
import json, sys
shipped, rebuilt = (json.load(open(p)) for p in sys.argv[1:3])
for config in (shipped, rebuilt):
    config.get("model", {}).pop("stage_steps", None)  # a length of training, as --steps
for key in ("family", "model"):
    if shipped.get(key) != rebuilt.get(key):
        sys.exit(f"{sys.argv[2]}: '{key}' differs from {sys.argv[1]}:\n  shipped {shipped.get(key)}\n  rebuilt {rebuilt.get(key)}")
print(f"{sys.argv[2]}: family and model section as shipped")
PY
