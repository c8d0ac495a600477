#!/usr/bin/env bash
# Unpacks the shared motion-capture archives into a cache folder once (never into the source
# tree). Usage: unpack_data.sh SHARED_DATA_DIR DEST_DIR. Missing archives are skipped.
set -euo pipefail
src=$1 dest=$2
mkdir -p "$dest"
for archive in bandai-namco-motion cmu-mocap-subset; do
  tarball="$src/$archive.tar.gz"
  stamp="$dest/.$archive.unpacked"
  [ -f "$tarball" ] || { echo "skip: $tarball not found"; continue; }
  [ -f "$stamp" ] && [ "$stamp" -nt "$tarball" ] && continue
  tmp=$(mktemp -d "$dest/.unpack.XXXXXX")
  tar -xzf "$tarball" -C "$tmp"
  for d in "$tmp"/*; do rm -rf "$dest/$(basename "$d")"; mv "$d" "$dest/"; done
  rmdir "$tmp"
  touch "$stamp"
done
