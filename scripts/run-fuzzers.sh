#!/usr/bin/env bash
# Runs every crop4d libFuzzer target for a while.
#
#   bash scripts/run-fuzzers.sh BUILD_DIR SECONDS
#
# BUILD_DIR is a build of the `fuzz` CMake preset (clang, CROP4D_BUILD_FUZZERS=ON), whose
# fuzzers are in BUILD_DIR/fuzz/. Each target starts from the seed files in
# tests/data/fuzz/<kind>/ plus what earlier runs found (BUILD_DIR/fuzz/corpus/<target>/), and
# runs for SECONDS. Crashes, timeouts and leaks are written to BUILD_DIR/fuzz/artifacts/<target>/
# and make the script exit with 1.
set -euo pipefail

if [[ $# -ne 2 ]]; then
  echo "usage: $0 BUILD_DIR SECONDS" >&2
  exit 64
fi
build_dir=$1
seconds=$2
source_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
fuzz_dir="$build_dir/fuzz"

# target name -> seed folder under tests/data/fuzz/
declare -A seeds=([crop4d_csv_fuzzer]=csv [crop4d_yaml_fuzzer]=yaml)

status=0
for target in crop4d_csv_fuzzer crop4d_yaml_fuzzer; do
  binary="$fuzz_dir/$target"
  if [[ ! -x "$binary" ]]; then
    echo "run-fuzzers: $binary not found; build the fuzz preset first" \
         "(cmake --preset fuzz && cmake --build --preset fuzz)" >&2
    exit 1
  fi
  corpus="$fuzz_dir/corpus/$target"
  artifacts="$fuzz_dir/artifacts/$target"
  mkdir -p "$corpus" "$artifacts"
  echo "run-fuzzers: $target for $seconds s"
  log="$fuzz_dir/$target.log"
  if "$binary" "$corpus" "$source_dir/tests/data/fuzz/${seeds[$target]}" \
      -max_total_time="$seconds" -max_len=4096 -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$artifacts/" >"$log" 2>&1; then
    grep -E "^stat::number_of_executed_units|^stat::new_units_added" "$log" | sed 's/^/  /'
    echo "run-fuzzers: $target: no crash"
  else
    echo "run-fuzzers: $target FAILED; last lines of $log:" >&2
    tail -n 40 "$log" >&2
    ls -1 "$artifacts" >&2
    status=1
  fi
done
exit $status
