#!/usr/bin/env bash
# The README's picture, docs/walk.gif: three walks along one drawn path from the shipped
# look-ahead MoGlow model (models/moglow-lookahead), in the normal, elderly and exhausted styles,
# side by side, the camera following each body. Deterministic (fixed seed, one thread).
#   scripts/make_readme_picture.sh [OUT.gif]        (from anywhere; MOSYN: the binary, default build/mosyn)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$root/docs/walk.gif}
mosyn=${MOSYN:-$root/build/mosyn}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
path="0,0 0,3 2,5 5,5"
for style in normal elderly exhausted; do
  "$mosyn" sample "$root/models/moglow-lookahead" --out "$tmp" --prefix "$style" --n 1 --seed 1 --threads 1 \
    --path "$path" --content walk --style "$style" > /dev/null
done
"$mosyn" render "$tmp"/normal_000.bvh "$tmp"/elderly_000.bvh "$tmp"/exhausted_000.bvh --out "$out" \
  --camera iso --width 600 --height 260 --follow --fps 10 > /dev/null
echo "wrote $out ($(( $(stat -c %s "$out") / 1024 )) KiB)"
