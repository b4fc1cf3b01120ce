#!/usr/bin/env bash
# The main job on the embedded demo field (`make demo`): simulate the demo field, then run every
# pipeline stage that exists. Usage: scripts/demo.sh CROP4D_BINARY DEMO_DIR
set -euo pipefail
crop4d=${1:?usage: demo.sh CROP4D_BINARY DEMO_DIR}
demo_dir=${2:?usage: demo.sh CROP4D_BINARY DEMO_DIR}
field="$demo_dir/field"

start=$(date +%s)
# The simulation is deterministic: reuse the field when the simulator's source and the
# configuration are the ones that made it (a change elsewhere in crop4d does not re-simulate).
repo=$(cd "$(dirname "$0")/.." && pwd)
stamp="$("$crop4d" --version; "$crop4d" simulate --print-config --preset demo;
         cat "$repo"/src/crop4d/sim/*.cc "$repo"/src/crop4d/sim/*.h "$repo"/src/crop4d/io/dataset_writer.cc | md5sum)"
if [ -f "$field/field.yaml" ] && [ "$(cat "$demo_dir/.simulated" 2>/dev/null)" = "$stamp" ]; then
  echo "demo: reusing the simulated field in $field (delete $demo_dir to simulate again)"
else
  rm -rf "$field" "$demo_dir/.simulated"
  mkdir -p "$demo_dir"
  "$crop4d" simulate --preset demo --out "$field"
  printf '%s' "$stamp" > "$demo_dir/.simulated"
fi

"$crop4d" validate "$field"

# Row SLAM of every pass of every session, cross matches between neighbouring passes (the robust
# method and the naive baseline), the joint 4D optimisation, then every error against the
# simulator's ground truth (trajectories, association precision, cross-session misalignment).
# Work already done is skipped.
workspace="$demo_dir/workspace"
timed() { local s; s=$(date +%s); "$@"; echo "demo: $2 took $(( $(date +%s) - s )) s"; }
timed "$crop4d" slam "$field" --workspace "$workspace"
timed "$crop4d" associate "$field" --workspace "$workspace" --method both
timed "$crop4d" fuse "$field" --workspace "$workspace"
# Dense clouds of every session, then the crop analysis: canopy height per site and date (the
# table is printed), growth, terrain and canopy height rasters, plots in WS/analysis/.
timed "$crop4d" densify "$field" --workspace "$workspace"
timed "$crop4d" analyze "$field" --workspace "$workspace"
timed "$crop4d" eval --workspace "$workspace" --truth "$field"
"$crop4d" section --workspace "$workspace" --field "$field" --row 1 --output "$demo_dir/cross_section.png"

echo "demo: done in $(( $(date +%s) - start )) s; field in $field, workspace in $workspace,"
echo "      cross-section figure in $demo_dir/cross_section.png,"
echo "      canopy height plots in $workspace/analysis/plots/heights.png"
