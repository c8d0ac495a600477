#!/usr/bin/env bash
# docs/realtime.md shows examples/realtime_walk.cpp verbatim; this keeps the two identical.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
diff <(sed -n '/^```cpp realtime_walk$/,/^```$/p' "$root/docs/realtime.md" | sed '1d;$d') "$root/examples/realtime_walk.cpp"
