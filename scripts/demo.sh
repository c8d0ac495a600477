#!/usr/bin/env bash
# The main job, run by `make demo`: real motion capture in, training data and files out.
# Usage: demo.sh BUILD_DIR SHARED_DATA_DIR CACHE_DIR
set -euo pipefail
build=$1 shared=$2 cache=$3
mosyn="$build/mosyn"
out=demo-out
mkdir -p "$out"
# Each stage says how long the one before it took.
stage_start=$SECONDS stage_name=""
stage() {
  [ -n "$stage_name" ] && echo "   ($stage_name: $((SECONDS - stage_start)) s)"
  stage_name=$1 stage_start=$SECONDS
  echo "== $1"
}

if [ ! -f "$shared/bandai-namco-motion.tar.gz" ]; then
  echo "demo: $shared/bandai-namco-motion.tar.gz not found; set DATA_DIR=... to the folder holding the archives" >&2
  exit 1
fi
stage "unpacking motion capture into $cache/data (once)"
bash "$(dirname "$0")/unpack_data.sh" "$shared" "$cache/data"
bandai="$cache/data/bandai-namco/Bandai-Namco-Research-Motiondataset-2"
clip="$bandai/data/dataset-2_walk-turn-left_normal_001.bvh"

stage "mosyn info"
"$mosyn" info "$clip"

stage "mosyn convert: BVH (resampled to 15 fps), glTF for Blender and game engines, world positions as NPY and CSV"
"$mosyn" convert "$clip" "$out/walk-turn-left_15fps.bvh" --fps 15
"$mosyn" convert "$out/walk-turn-left_15fps.bvh" "$out/walk-turn-left_15fps.glb"
"$mosyn" convert "$clip" "$out/walk-turn-left_positions.npy" --positions
"$mosyn" convert "$clip" "$out/walk-turn-left_positions.csv" --positions

stage "mosyn data prepare: Bandai-Namco locomotion (walk, turns, run; all styles)"
dataset="$cache/datasets/bandai-locomotion"
if [ ! -f "$dataset/dataset.json" ]; then
  "$mosyn" data prepare "$bandai" --out "$dataset" --contents walk,walk-turn-left,walk-turn-right,run \
    --fps 30 --window 120 --hop 30 --mirror
fi
"$mosyn" data info "$dataset"

# Offline sampling knows the whole path: the look-ahead MoGlow (crispest footsteps, styles recognised).
# Frame by frame (games, the live server) the real-time MoGlow reads the path its controller predicts.
model=models/moglow-lookahead
if [ -f "$model/checkpoint.pt" ]; then
  stage "mosyn sample: walks along one curved path from the shipped look-ahead MoGlow model, in two styles"
  for style in normal elderly; do
    "$mosyn" sample "$model" --out "$out/curve" --prefix "curve-$style" --n 2 --seed 1 \
      --path "0,0 0,3 2,5 5,5 7,3" --content walk --style "$style" --positions --format bvh,glb
  done
  stage "mosyn sample: stop and go (stand 2 s at two corners)"
  "$mosyn" sample "$model" --out "$out/stop-and-go" --prefix stop-and-go --n 2 --seed 3 \
    --path "0,0 0,3,2 3,5,2 3,8" --content walk
  views=("$out"/curve/*.bvh "$out"/stop-and-go/*.bvh)
  realtime=models/moglow-realtime
  if [ -f "$realtime/checkpoint.pt" ]; then
    stage "mosyn sample --realtime: the real-time MoGlow (what games and the live page run) stands 3 s, then walks"
    "$mosyn" sample "$realtime" --realtime --out "$out/stand-walk" --prefix stand-walk --n 2 --seed 2 \
      --path "0,0,3 0,5" --content walk
    views+=("$out"/stand-walk/*.bvh)
  fi
  rvae=models/rvae-locomotion
  held_out="$bandai/data/dataset-2_walk-turn-left_normal_031.bvh"  # a validation file of both models
  if [ -f "$rvae/checkpoint.pt" ]; then
    stage "mosyn sample: the shipped recurrent VAE along the root path of a held-out clip, from its prior"
    "$mosyn" sample "$rvae" --out "$out/rvae" --prefix rvae-prior --n 3 --seed 1 --control "$held_out"
    stage "mosyn sample --continue: the recurrent VAE continues the clip's first 4 frames (its posterior)"
    "$mosyn" sample "$rvae" --out "$out/rvae" --prefix rvae-continued --n 2 --seed 2 --continue "$held_out" \
      --observed-frames 4
    views+=("$out"/rvae/*.bvh)
  fi
  stage "pictures: a viewer page and a filmstrip"
  "$mosyn" view "${views[@]}" --out "$out/viewer.html"
  "$mosyn" render "$out"/curve/*.bvh --out "$out/curve.png" --camera top --width 900 --height 600 --overlay
  if [ -f "$out/stand-walk/stand-walk_000.bvh" ]; then
    "$mosyn" render "$out"/stand-walk/stand-walk_000.bvh --out "$out/stand-walk.png" --camera side --filmstrip 6 \
      --width 240 --height 320 --follow
  fi
  for style in normal elderly; do
    "$mosyn" render "$out/curve/curve-${style}_000.bvh" --out "$out/curve-$style.png" --camera side --filmstrip 8 \
      --width 200 --height 300 --follow
  done
  "$mosyn" render "$out"/stop-and-go/*.bvh --out "$out/stop-and-go.png" --camera top --width 900 --height 600 --overlay
  if [ -f "$out/rvae/rvae-prior_000.bvh" ]; then
    "$mosyn" render "$out/rvae/rvae-prior_000.bvh" --out "$out/rvae.png" --camera side --filmstrip 8 \
      --width 200 --height 300 --follow
  fi
else
  echo "demo: $model/checkpoint.pt not found, so no motion is drawn: the shipped models are committed" \
    "under models/ (models/README.md); restore them with git checkout -- models" >&2
fi

stage "done"
echo
echo "demo: wrote $(find "$out" -type f | wc -l) files to $out/ and the dataset to $dataset"
[ -f "$out/viewer.html" ] && echo "demo: open file://$(cd "$out" && pwd)/viewer.html in a browser to watch the samples"
for glb in "$out"/walk-turn-left_15fps.glb "$out"/curve/curve-normal.glb; do
  [ -f "$glb" ] && echo "demo: $glb: glTF beside its BVH (skinned body, one animation per motion, metres, Y up) for Blender, game engines, three.js"
done
echo "demo: steer a character live: $build/mosyn serve models/moglow-realtime, then open http://127.0.0.1:8080"
echo "      (arrow keys / WASD or a gamepad; style menu, speed, add characters; Ctrl-C stops the server)"
exit 0
