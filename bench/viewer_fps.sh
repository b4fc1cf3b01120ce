#!/usr/bin/env bash
# The 4D viewer's speed on a workspace (bench/RESULTS.md, "4D viewer"): builds the viewer tiles
# into a scratch copy of the workspace (symbolic links to its files; the workspace itself is
# only read), serves it with `crop4d view`, and measures time to first frame and frames per
# second in headless Chromium with SwiftShader (bench/viewer_fps.cjs).
#   bench/viewer_fps.sh WORKSPACE DATE [CONFIGS] [SECONDS] [SCREENSHOT.png]   (viewer_fps.cjs)
# e.g. bench/viewer_fps.sh demo/workspace 2016-06-01
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${CROP4D_BUILD:-$here/build/release}"
ws="$1"; date="$2"; shift 2
scratch="$(mktemp -d)"
trap 'kill "$server" 2>/dev/null || true; rm -rf "$scratch"' EXIT
cp -rs "$(cd "$ws" && pwd)" "$scratch/ws"
start=$(date +%s.%N)
"$build/crop4d" view "$scratch/ws" --port 0 --no-browser > "$scratch/view.log" &
server=$!
until grep -q 'http://' "$scratch/view.log" 2>/dev/null; do
  kill -0 "$server" || { cat "$scratch/view.log"; exit 1; }
  sleep 0.2
done
echo "tiles of every session built and server up in $(echo "$(date +%s.%N) - $start" | bc) s:"
sed 's/^/  /' "$scratch/view.log"
url="$(grep -o 'http://[0-9.:]*/' "$scratch/view.log")"
NODE_PATH="$build/src/crop4d/viewer/npm/node_modules" node "$here/bench/viewer_fps.cjs" "$url" "$date" "$@"
