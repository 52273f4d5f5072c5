#!/usr/bin/env bash
# CTest bench_random_robots: the benchmark's user path (scripts/bench.sh ROBOT.urdf, short)
# on seeded random variants of shipped robots (tests/random_robot.py: other link offsets
# and rotations, random joint axes, joint types and masses), robots nobody tuned the
# benchmark for. Each must pass the benchmark's checks (wbm converges, tracks or warns why
# not, KDL agrees on the same tree) and print its summary. The dual-arm variants of seeds 3
# and 9 reach joint limits in 8-18 % of the moving cycles and trail their targets by 8 and
# 20 mm: they failed the tracking check (no benchmark at all) before it allowed for that.
# The dual-arm variant of seed 63 starts 1.8 rad from its goal's grasp axis, which the
# filters' speed limits turn in 5 s: it failed the 4 s convergence check before that check
# gave a user's robot more time while the errors still fall.
#   bench_random_robots.sh BUILD_DIR WORK_DIR
set -euo pipefail
build_dir="$1"
work="$2"
test_name=bench_random_robots
check_variant() {  # urdf output flags...
  local urdf="$1" output="$2" rc=0
  shift 2
  BUILD_DIR="$build_dir" scripts/bench.sh "$urdf" "$@" -- --benchmark_min_time=0.002 >"$output" 2>&1 || rc=$?
  [[ $rc -eq 0 ]] || { echo "exit $rc"; return 1; }
  grep -q "^Your robot ($urdf, [0-9]* rows): the wbm cycle takes" "$output" || { echo "no summary"; return 1; }
  echo "$(grep -c '^  WARNING' "$output" || true) warnings"
}
source tests/random_robot_runs.sh
for seed in 3 9 63; do
  run "dual_arm_$seed" models/dual_arm/dual_arm.urdf "$seed" --hands left_tool,right_tool --fixed-base
done
run g1_5 models/third_party/unitree_g1/g1_29dof.urdf 5 --hands left_rubber_hand,right_rubber_hand --head d435_link \
  --legs left_hip_pitch_link,right_hip_pitch_link --com --posture waist_yaw_joint,left_wrist_roll_joint
run atlas_5 models/third_party/atlas/atlas_v4_with_multisense.urdf 5 --hands l_hand,r_hand --head head \
  --legs l_uglut,r_uglut --com
run h1_5 models/third_party/unitree_h1/h1.urdf 5 --hands left_elbow_link,right_elbow_link \
  --legs left_hip_yaw_link,right_hip_yaw_link
