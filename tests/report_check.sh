#!/usr/bin/env bash
# Writes reports for a paper experiment and a walking scenario and checks each in
# headless Chromium (web/test/check_report.mjs): no console errors, no requests, the 3D
# view drawn and changing with the time slider, every plot drawn.
set -euo pipefail
wbm=$1
out=$2
rm -rf "$out"
"$wbm" run scenarios/fig7_middle_gaze_sweep.yaml scenarios/walk_object_ahead.yaml --out "$out"
for name in fig7_middle_gaze_sweep walk_object_ahead; do
  node web/test/check_report.mjs "$out/$name/report.html" --screenshot "$out/$name/screenshot.png"
done
