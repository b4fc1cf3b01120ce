#!/usr/bin/env bash
# Builds the unit tests (ctest label `unit`: in-memory data and small files, no rendered field,
# no whole stage) under AddressSanitizer + UndefinedBehaviorSanitizer and runs them. Any
# sanitizer report fails its test and so this script. Used by .ci/run; `make asan` runs the whole
# suite the same way. Usage: scripts/sanitize-unit-tests.sh [JOBS]
set -euo pipefail
cd "$(dirname "$0")/.."
JOBS="${1:-$(nproc)}"
start=$(date +%s)
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$JOBS" --target crop4d_unit_tests
built=$(date +%s)
ctest --preset asan -L unit -j "$JOBS"
echo "sanitize-unit-tests: build $((built - start)) s, tests $(($(date +%s) - built)) s"
