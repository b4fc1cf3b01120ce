#!/usr/bin/env bash
# Checks a crop4d report (docs/report.md) in a real headless browser (Debian's chromium):
#   scripts/check-report.sh REPORT.html [SCREENSHOT.png]
# Loads the page from disk with no network, dumps its DOM after the load event and checks the
# markers set by the page's own inline script: data-report-loaded="yes" on <html> (the load event
# ran) and data-js-errors="0" (no JavaScript error and no resource that failed to load). Writes a
# screenshot when asked (size from REPORT_SCREENSHOT_SIZE, default 1200,3000).
# Exit codes: 0 the page loaded without errors; 1 it did not (the reason is printed); 2 usage,
# missing file or no chromium.
set -euo pipefail

usage() { echo "usage: $0 REPORT.html [SCREENSHOT.png]" >&2; exit 2; }
[ $# -ge 1 ] && [ $# -le 2 ] || usage
report=$1
screenshot=${2:-}
if [ ! -f "$report" ]; then echo "check-report: $report: no such file" >&2; exit 2; fi

browser=""
for b in chromium chromium-browser; do
  if command -v "$b" >/dev/null 2>&1; then browser=$(command -v "$b"); break; fi
done
if [ -z "$browser" ]; then
  echo "check-report: chromium not found (Debian: apt-get install chromium; scripts/install-deps.sh)" >&2
  exit 2
fi

report_abs=$(cd "$(dirname "$report")" && pwd)/$(basename "$report")
tmp=$(mktemp -d "${TMPDIR:-/tmp}/check-report.XXXXXX")
trap 'rm -rf "$tmp"' EXIT

flags=(--headless --no-sandbox --disable-gpu --no-first-run --no-default-browser-check
       --disable-extensions --disable-sync --disable-background-networking
       --user-data-dir="$tmp/profile" --virtual-time-budget=10000)
url="file://$report_abs"

if ! timeout 120 "$browser" "${flags[@]}" --dump-dom "$url" >"$tmp/dom.html" 2>"$tmp/chromium.log"; then
  echo "check-report: FAIL: chromium could not load $report; its log:" >&2
  tail -n 20 "$tmp/chromium.log" >&2
  exit 1
fi
# The <html ...> start tag as the browser serialised it.
html_tag=$(grep -o -m1 '<html[^>]*>' "$tmp/dom.html" || true)
if [ -z "$html_tag" ]; then
  echo "check-report: FAIL: chromium returned no document for $report" >&2
  exit 1
fi
if ! grep -q 'data-report-loaded="yes"' <<<"$html_tag"; then
  echo "check-report: FAIL: $report did not finish loading (no data-report-loaded marker: not a" \
       "crop4d report, or its inline script did not run)" >&2
  exit 1
fi
errors=$(sed -n 's/.*data-js-errors="\([0-9]*\)".*/\1/p' <<<"$html_tag")
if [ "${errors:-missing}" != "0" ]; then
  last=$(sed -n 's/.*data-js-last-error="\([^"]*\)".*/\1/p' <<<"$html_tag")
  echo "check-report: FAIL: ${errors:-unknown number of} error(s) while loading $report: $last" >&2
  exit 1
fi
echo "check-report: OK: $report loaded in $("$browser" --version 2>/dev/null | head -n1) without errors"

if [ -n "$screenshot" ]; then
  size=${REPORT_SCREENSHOT_SIZE:-1200,3000}
  shot_abs=$(cd "$(dirname "$screenshot")" && pwd)/$(basename "$screenshot")
  rm -f "$shot_abs"
  if ! timeout 120 "$browser" "${flags[@]}" --hide-scrollbars --window-size="$size" \
      --screenshot="$shot_abs" "$url" >"$tmp/shot.log" 2>&1 || [ ! -s "$shot_abs" ]; then
    echo "check-report: FAIL: no screenshot written to $screenshot; chromium's log:" >&2
    tail -n 20 "$tmp/shot.log" >&2
    exit 1
  fi
  echo "check-report: screenshot ($size) in $screenshot"
fi
