#!/usr/bin/env bash
# Several real browsers on the live page at once: starts `mosyn serve MODEL`, opens N headless
# Chromium pages on it (SwiftShader WebGL, as the browser test does), lets them stream for SECONDS,
# closes them and prints each connection's statistics as the server logs them (frames, fps, CPU,
# late frames) and the server's resident memory before and with the pages.
#   scripts/live_browsers.sh [MODEL] [N] [SECONDS]     (defaults: models/moglow-realtime 4 30)
# Environment: MOSYN (default build/mosyn), PORT (default 8391), CLIENT_NICE (run the pages at
# this nice level, as clients on other machines would not take the server's cores). Needs Debian's chromium. Timing
# figures mean something only on an otherwise idle machine (the pages render in software).
set -euo pipefail
MODEL=${1:-models/moglow-realtime}
N=${2:-4}
SECONDS_LIVE=${3:-30}
MOSYN=${MOSYN:-build/mosyn}
PORT=${PORT:-8391}
command -v chromium >/dev/null || { echo "live_browsers.sh: chromium is not installed" >&2; exit 1; }
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$work"' EXIT

${SERVER_CPUS:+taskset -c $SERVER_CPUS} "$MOSYN" serve "$MODEL" --port "$PORT" --max-connections "$N" > "$work/serve.log" 2>&1 &
serve_pid=$!
for _ in $(seq 100); do
  grep -q "http://" "$work/serve.log" 2>/dev/null && break
  sleep 0.2
done
# mosyn serve execs mosyn-torch: the pid stays the server's.
rss_kb() { awk '/VmRSS/ {print $2}' "/proc/$serve_pid/status"; }
before=$(rss_kb)
for i in $(seq "$N"); do
  ${CLIENT_CPUS:+taskset -c $CLIENT_CPUS} ${CLIENT_NICE:+nice -n $CLIENT_NICE} chromium --headless --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader --disable-gpu-sandbox \
    --user-data-dir="$work/profile$i" --remote-debugging-port=$((PORT + i)) \
    "http://127.0.0.1:$PORT/" > "$work/chromium$i.log" 2>&1 &
done
sleep "$SECONDS_LIVE"
with=$(rss_kb)
pkill -f -- "--user-data-dir=$work/profile" || true
sleep 2
echo "server resident memory: ${before} kB before, ${with} kB with $N pages (+$(( (with - before) / 1024 )) MB)"
grep -E "frames in .* late" "$work/serve.log" || { echo "no connection statistics in the server log:" >&2; cat "$work/serve.log" >&2; exit 1; }
