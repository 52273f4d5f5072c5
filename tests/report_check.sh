#!/usr/bin/env bash
# Writes reports for a paper experiment, a walking scenario, G1 balancing (every URDF link,
# the feet and the centre of mass drawn), one that never switches a task element on and
# NAO (a small robot, drawn smaller; and walking 1 m, framed whole), and checks each in headless Chromium (web/test/check_report.mjs): no
# console errors, no requests, the 3D view drawn and changing with the time slider, every
# plot drawn (the idle one has no task-error plot rather than an empty one), every value axis
# holding its plot's values (a flat one not spread from 0 to 100).
set -euo pipefail
wbm=$1
out=$2
rm -rf "$out"
mkdir -p "$out"
# No element active; the arm starts near its limits, so the null-space criterion moves it.
printf 'name: idle\nduration: 0.5\ninitial: {l_shoulder_pitch: -2.2, l_elbow: -2.2}\n%s\n' \
  'tasks: [{name: l_hand, type: position, frame: l_hand_ref, active: false}]' >"$out/idle.yaml"
# NAO, 0.58 m tall: its links, spheres and arrows are drawn at about half the size.
printf 'name: nao\nrobot: {urdf: %s, legs: [LPelvis, RPelvis]}\nduration: 0.5\n%s\n%s\n' \
  "$PWD/models/third_party/nao/nao.urdf" 'tasks: [{name: hand, type: position, frame: l_gripper}]' \
  'timeline: [{t: 0, activate: [hand], relative_targets: {hand: [0.05, 0, 0.05]}}]' >"$out/nao.yaml"
# NAO walking 1 m: the camera frames the whole walk (framed on the first sample, NAO walked
# out of the view).
printf 'name: nao_walk\nrobot: {urdf: %s, legs: [LPelvis, RPelvis]}\nduration: 8\n%s\n%s\n%s\n%s\n' \
  "$PWD/models/third_party/nao/nao.urdf" 'frozen: [heel_x, heel_y, heel_yaw]' 'walking: {enabled: true}' \
  'tasks: [{name: hand, type: position, frame: l_gripper, filter: {bandwidth: 3, max_speed: 0.4}}]' \
  'timeline: [{t: 0.2, activate: [hand], relative_targets: {hand: [1.0, 0.3, 0]}}]' >"$out/nao_walk.yaml"
"$wbm" run scenarios/fig7_middle_gaze_sweep.yaml scenarios/walk_object_ahead.yaml scenarios/g1_reach_with_balance.yaml \
  "$out/idle.yaml" "$out/nao.yaml" "$out/nao_walk.yaml" --out "$out"
if ! grep -Eq '"footsteps": *[1-9]' "$out/nao_walk/summary.json"; then
  echo "report_check: NAO did not walk, so the framing check of a walk checks nothing" >&2
  exit 1
fi
for name in fig7_middle_gaze_sweep walk_object_ahead g1_reach_with_balance idle; do
  node web/test/check_report.mjs "$out/$name/report.html" --screenshot "$out/$name/screenshot.png" --expect-scale 0.8,1.2
done
node web/test/check_report.mjs "$out/nao_walk/report.html" --screenshot "$out/nao_walk/screenshot.png" --expect-scale 0.3,0.6
node web/test/check_report.mjs "$out/nao/report.html" --screenshot "$out/nao/screenshot.png" --expect-scale 0.3,0.6 |
  tee "$out/nao/check.txt"
# NAO's null-space cost stays 0 (no joint near a limit): the flat plot whose value axis the
# check judges (uPlot would draw it from 0 to 100).
if ! grep -Eq 'PASS value axes fit the data: .* [1-9][0-9]* flat' "$out/nao/check.txt"; then
  echo "report_check: NAO's report has no flat plot any more, so its value-axis check checks nothing" >&2
  exit 1
fi
if grep -q 'Task errors to the commanded targets' "$out/idle/report.html"; then
  echo "report_check: the idle scenario's report has a task-error plot without data" >&2
  exit 1
fi
