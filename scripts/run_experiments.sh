#!/usr/bin/env bash
# The main job: install, build, and run the paper's experiments on the built-in model.
# Reports land in out/<scenario>/report.html (open them in a browser, works offline).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build/wbm model info
build/wbm run scenarios/*.yaml --out out
echo "Open the reports: $(ls out/*/report.html | tr '\n' ' ')"
