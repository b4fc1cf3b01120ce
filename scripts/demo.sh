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

# Row SLAM of every pass of every session (passes already done are skipped), then the
# trajectory errors against the simulator's ground truth.
workspace="$demo_dir/workspace"
"$crop4d" slam "$field" --workspace "$workspace"
"$crop4d" eval --workspace "$workspace" --truth "$field"

echo "demo: done in $(( $(date +%s) - start )) s; field in $field, workspace in $workspace"
