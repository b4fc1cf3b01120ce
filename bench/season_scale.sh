#!/usr/bin/env bash
# How crop4d's cost grows with the season (issue 28): `crop4d run` on simulated fields of growing
# size — rows, row length and sessions, one axis at a time from a base field, 640×480 — and per
# stage its wall time, CPU time and peak memory (WS/run.json: core/resource_usage.h), per image,
# pass and pass pair. Prints a markdown table (bench/RESULTS.md "Season scale").
#
#   bench/season_scale.sh [--grid issue|quick] [--points LIST] [--crop4d BIN] [--dir DIR]
#
#   --grid issue   base 4 rows × 20 m × 4 sessions (the demo's layout); rows 8, 16; length 40,
#                  80 m; sessions 8, 16 (about 19 demo-sized runs: hours on 2 cores)
#   --grid quick   base 2 rows × 10 m × 2 sessions; ×2 and ×4 on each axis
#   --points LIST  only these points of the grid (comma-separated names: base,rows2,rows4,
#                  length2,length4,sessions2,sessions4)
#   --dir DIR      fields and workspaces (default /tmp/crop4d-season-scale); a field already
#                  simulated there is reused, a workspace is always run from scratch
#
# The fields are the demo preset's (imperfect world, seed 1) with the sizes changed; sessions
# twice a week from 2016-06-01 (alternately 3 and 4 days apart), no rain.
set -euo pipefail

grid=issue
points=""
repo=$(cd "$(dirname "$0")/.." && pwd)
crop4d="$repo/build/release/crop4d"
dir=/tmp/crop4d-season-scale
while [ $# -gt 0 ]; do
  case "$1" in
    --grid) grid=$2; shift 2 ;;
    --points) points=$2; shift 2 ;;
    --crop4d) crop4d=$2; shift 2 ;;
    --dir) dir=$2; shift 2 ;;
    *) echo "usage: $0 [--grid issue|quick] [--points LIST] [--crop4d BIN] [--dir DIR]" >&2; exit 2 ;;
  esac
done
[ -x "$crop4d" ] || { echo "season_scale: no crop4d at $crop4d (build first, or --crop4d)" >&2; exit 1; }

case "$grid" in
  issue) rows=4; length=20; sessions=4 ;;
  quick) rows=2; length=10; sessions=2 ;;
  *) echo "season_scale: --grid issue or quick" >&2; exit 2 ;;
esac

# name rows length sessions
all_points=(
  "base $rows $length $sessions"
  "rows2 $((rows * 2)) $length $sessions"
  "rows4 $((rows * 4)) $length $sessions"
  "length2 $rows $((length * 2)) $sessions"
  "length4 $rows $((length * 4)) $sessions"
  "sessions2 $rows $length $((sessions * 2))"
  "sessions4 $rows $length $((sessions * 4))"
)

session_list() {  # N dates twice a week from 2016-06-01
  local n=$1 day=0
  for ((i = 0; i < n; i++)); do
    echo "  - {date: $(date -u -d "2016-06-01 + $day days" +%F), rain_before: false}"
    day=$((day + (i % 2 == 0 ? 3 : 4)))
  done
}

mkdir -p "$dir"
results="$dir/results.tsv"
: > "$results"
for point in "${all_points[@]}"; do
  read -r name r l s <<< "$point"
  if [ -n "$points" ] && [[ ",$points," != *",$name,"* ]]; then continue; fi
  tag="${grid}_${r}x${l}m_${s}s"
  field="$dir/field_$tag"
  ws="$dir/ws_$tag"
  config="$dir/sim_$tag.yaml"
  { echo "rows: {count: $r, length_m: $l}"; echo "sessions:"; session_list "$s"; } > "$config"
  if [ ! -f "$field/field.yaml" ]; then
    echo "season_scale: simulating $tag" >&2
    rm -rf "$field"
    "$crop4d" simulate --preset demo --config "$config" --out "$field" -q >&2
  fi
  rm -rf "$ws"
  echo "season_scale: running $tag" >&2
  start=$(date +%s.%N)
  "$crop4d" run "$field" --workspace "$ws" --eval never --no-report -q > "$dir/run_$tag.log" 2>&1 || {
    echo "season_scale: crop4d run failed on $tag (see $dir/run_$tag.log)" >&2; exit 1; }
  end=$(date +%s.%N)
  python3 - "$name" "$r" "$l" "$s" "$field" "$ws" "$start" "$end" >> "$results" <<'EOF'
import glob, json, os, sys
name, rows, length, sessions, field, ws, start, end = sys.argv[1:]
wall = f"{float(end) - float(start):.1f}"
images = 0
for csv in glob.glob(os.path.join(field, "sessions", "*", "cam0", "data.csv")):
    with open(csv) as f:
        images += sum(1 for line in f if line.strip() and not line.startswith("#"))
passes = len(glob.glob(os.path.join(ws, "sessions", "*", "rows", "*", "summary.json")))
pairs = len(glob.glob(os.path.join(ws, "associations", "robust", "*.bin")))
record = json.load(open(os.path.join(ws, "run.json")))
stages = {s["name"]: s for s in record["stages"]}
out = [name, rows, length, sessions, str(images), str(passes), str(pairs), wall]
for stage in ["slam", "associate", "fuse", "densify", "analyze"]:
    s = stages.get(stage, {})
    out += [str(s.get("seconds") or 0), str(s.get("cpu_seconds") or 0), str(s.get("peak_rss_mb") or 0)]
# What adding the last session cost fuse: the step that added it (incremental fuse), else the
# whole stage (one problem over the season, solved again when a session is added).
fused = json.load(open(os.path.join(ws, "fused", "summary.json")))
steps = fused.get("steps") or []
out.append(str(steps[-1]["seconds"] if steps else stages.get("fuse", {}).get("seconds") or 0))
# The images densify matched (over the rows; not those of the turns at the row ends).
dense_images = 0
for summary in glob.glob(os.path.join(ws, "dense", "*.json")):
    dense_images += json.load(open(summary)).get("images", {}).get("used", 0)
out.append(str(dense_images))
print("\t".join(out))
EOF
done

python3 - "$results" "$grid" <<'EOF'
import sys
rows = [line.rstrip("\n").split("\t") for line in open(sys.argv[1]) if line.strip()]
print(f"grid `{sys.argv[2]}`; per stage: wall s / CPU s / peak MB; per unit: wall s")
print()
print("| point | rows × length, sessions | images | passes | pairs | run s | slam | associate | fuse | densify | analyze | slam s/image | associate s/pair | fuse s/pass | densify s/image | densify s/matched image | fuse: add the last session, s |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    name, nr, nl, ns, images, passes, pairs, wall = r[:8]
    v = list(map(float, r[8:23]))
    add_last = float(r[23]) if len(r) > 23 else float("nan")
    dense_images = int(r[24]) if len(r) > 24 else 0
    stage = lambda i: f"{v[3*i]:.0f} / {v[3*i+1]:.0f} / {v[3*i+2]:.0f}"
    images, passes, pairs = int(images), int(passes), int(pairs)
    per = lambda x, n: f"{x / n:.3f}" if n else "-"
    print(f"| {name} | {nr} × {nl} m, {ns} | {images} | {passes} | {pairs} | {float(wall):.0f} | "
          f"{stage(0)} | {stage(1)} | {stage(2)} | {stage(3)} | {stage(4)} | "
          f"{per(v[0], images)} | {per(v[3], pairs)} | {per(v[6], passes)} | {per(v[9], images)} | "
          f"{per(v[9], dense_images)} | {add_last:.1f} |")

# Growth: each stage's wall time against its work, fitted as t = a * n^b over the points
# (b = 1: linear), and the paper's season extrapolated from it (Dong et al. 2017: 21 rows x
# 150 m, 23 sessions, about 16 000 images per session; about 3 pass pairs per pass).
import math
paper = {"images": 23 * 16000, "passes": 23 * 21, "pairs": 23 * 21 * 3}
fits = {}
for i, (stage, unit) in enumerate([("slam", "images"), ("associate", "pairs"),
                                   ("fuse", "passes"), ("densify", "images")]):
    # densify against the images it matched where the bench recorded them (those of the turns
    # at the row ends, a larger share of a short field's images, are not matched).
    count = lambda r: (r[24] if stage == "densify" and len(r) > 24 and int(r[24]) > 0
                       else {"images": r[4], "passes": r[5], "pairs": r[6]}[unit])
    pts = [(float(count(r)), float(r[8 + 3 * i])) for r in rows]
    pts = [(n, t) for n, t in pts if n > 0 and t > 0]
    if len(set(n for n, _ in pts)) < 2:
        continue
    xs, ys = [math.log(n) for n, _ in pts], [math.log(t) for _, t in pts]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    a = math.exp(my - b * mx)
    fits[stage] = (unit, a, b, a * paper[unit] ** b)
if fits:
    print()
    print("extrapolated with the fitted growth; per-image costs as measured at 640x480 (the paper's "
          "images are 1280x960: densify's matching grows with the pixels)")
    print()
    print("| stage | work unit | exponent b (t = a n^b) | paper season, one 2-core machine | on 10 machines |")
    print("|---|---|---|---|---|")
    for stage, (unit, a, b, t) in fits.items():
        # Units of a stage run side by side on a cluster; fuse's steps follow one another.
        t10 = t if stage == "fuse" else t / 10
        print(f"| {stage} | {unit} | {b:.2f} | {t / 3600:.1f} h | {t10 / 3600:.1f} h |")
EOF
