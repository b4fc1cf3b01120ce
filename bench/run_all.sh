#!/usr/bin/env bash
# Runs every benchmark of bench/ against a build folder and prints the tables that
# bench/RESULTS.md records. Usage: bench/run_all.sh BUILD_DIR
set -euo pipefail
build=${1:-build/release}
here="$(cd "$(dirname "$0")" && pwd)"
for b in "$build"/bench/*_bench; do
  [ -x "$b" ] || continue
  echo "== $(basename "$b")"
  "$b"
done
