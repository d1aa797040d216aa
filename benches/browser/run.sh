#!/usr/bin/env bash
# The interactive panels' browser speeds (docs/report.md, docs/performance.md): builds the
# release CLI, makes the demo's five-model report, and times the panels in headless
# Chromium (panels_speed.cjs). Needs chromium, node and npm's playwright-core in
# target/browser-test (.ci/run installs them). Run on an idle machine.
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -p fit-brdf --quiet
out="${1:-target/panels-bench}"
[ -f "$out/report/index.html" ] || target/release/fit-brdf demo --out "$out" >/dev/null
NODE_PATH=target/browser-test/node_modules node benches/browser/panels_speed.cjs \
  "$out/report/index.html" "${CHROMIUM:-/usr/bin/chromium}" "${REPEATS:-15}"
