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
stamp="$("$crop4d" --version; "$crop4d" simulate --print-config --preset demo --depth;
         cat "$repo"/src/crop4d/sim/*.cc "$repo"/src/crop4d/sim/*.h "$repo"/src/crop4d/io/dataset_writer.cc | md5sum)"
if [ -f "$field/field.yaml" ] && [ "$(cat "$demo_dir/.simulated" 2>/dev/null)" = "$stamp" ]; then
  echo "demo: reusing the simulated field in $field (delete $demo_dir to simulate again)"
else
  rm -rf "$field" "$demo_dir/.simulated"
  mkdir -p "$demo_dir"
  # The imperfect field (the simulator's default realism). Its true depth maps are written
  # with the images, so the evaluation reads them instead of rendering each again.
  "$crop4d" simulate --preset demo --depth --out "$field"
  printf '%s' "$stamp" > "$demo_dir/.simulated"
fi

# The whole season in one command (docs/run.md): validate, row SLAM of every pass, cross matches
# between neighbouring passes, the joint 4D optimisation, dense clouds, the crop analysis, the
# errors against the simulator's ground truth and the report. Work already done is skipped, so a
# second `make demo` takes seconds; an interrupted one finishes where it stopped.
workspace="$demo_dir/workspace"
run_start=$(date +%s)
"$crop4d" run "$field" --workspace "$workspace" --config "$repo/scripts/demo.yaml"
run_s=$(( $(date +%s) - run_start ))
"$crop4d" section --workspace "$workspace" --field "$field" --row 1 --output "$demo_dir/cross_section.png"

echo "demo: done in $(( $(date +%s) - start )) s (crop4d run: $run_s s); field in $field,"
echo "      workspace in $workspace, report in $workspace/report.html,"
echo "      cross-section figure in $demo_dir/cross_section.png"
