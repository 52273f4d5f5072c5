#!/usr/bin/env bash
# Writes reports for a paper experiment, a walking scenario, G1 balancing (every URDF link,
# the feet and the centre of mass drawn) and one that never switches a task element on,
# and checks each in headless Chromium (web/test/check_report.mjs): no
# console errors, no requests, the 3D view drawn and changing with the time slider, every
# plot drawn (the idle one has no task-error plot rather than an empty one).
set -euo pipefail
wbm=$1
out=$2
rm -rf "$out"
mkdir -p "$out"
# No element active; the arm starts near its limits, so the null-space criterion moves it.
printf 'name: idle\nduration: 0.5\ninitial: {l_shoulder_pitch: -2.2, l_elbow: -2.2}\n%s\n' \
  'tasks: [{name: l_hand, type: position, frame: l_hand_ref, active: false}]' >"$out/idle.yaml"
"$wbm" run scenarios/fig7_middle_gaze_sweep.yaml scenarios/walk_object_ahead.yaml scenarios/g1_reach_with_balance.yaml \
  "$out/idle.yaml" --out "$out"
for name in fig7_middle_gaze_sweep walk_object_ahead g1_reach_with_balance idle; do
  node web/test/check_report.mjs "$out/$name/report.html" --screenshot "$out/$name/screenshot.png"
done
if grep -q 'Task errors to the commanded targets' "$out/idle/report.html"; then
  echo "report_check: the idle scenario's report has a task-error plot without data" >&2
  exit 1
fi
