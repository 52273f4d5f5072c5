#!/usr/bin/env bash
# CTest check_model_user_urdf: scripts/check_model.sh as a user runs it, on a URDF that is
# not at a shipped path (NAO copied under a directory with a space), on a massless robot with
# a fixed base, and its failure paths.
#   check_model_test.sh BUILD_DIR WORK_DIR
set -euo pipefail
build_dir="$1"
work="$2"
rm -rf "$work"
mkdir -p "$work/my robot"
cp models/third_party/nao/nao.urdf "$work/my robot/nao.urdf"
fail() { echo "check_model_test: $*" >&2; exit 1; }

# 1. The whole set on the copied robot passes, every group ran, the summary counts them.
rc=0
# (With an upper-body shift range of its own, as `wbm model export` names it for such a model.)
scripts/check_model.sh "$work/my robot/nao.urdf" --hands l_gripper,r_gripper --head gaze --legs LPelvis,RPelvis \
  --upper-body-x-range -0.04,0.1 --build-dir "$build_dir" >"$work/out.txt" 2>"$work/err.txt" || rc=$?
[[ $rc -eq 0 ]] || { cat "$work/out.txt" "$work/err.txt"; fail "exit $rc"; }
for name in Kinematics.JacobiansMatchFiniteDifferences/user Kinematics.JacobianTimesVelocityMatchesDirectionalDerivative/user \
  KdlComparison.PosesAndJacobiansMatchKdl/user KdlWholeTree.ExportWithVirtualDofsMatchesKdl/user \
  ExportRoundTrip.SameFramePosesAfterExportAndImport/user \
  EveryModel.PseudoInverseAndNullSpaceIdentitiesWithTheHandAndViewRows/user \
  EveryModel.RandomControllerRunsKeepLimits/user EveryModel.ConvergesToReachableHandTargetsWithoutAllocating/user; do
  grep -q "^  passed  $name " "$work/out.txt" || { cat "$work/out.txt"; fail "no passed line for $name"; }
done
grep -Eq '^(1[6-9]|[2-9][0-9]) passed, [0-9]+ skipped, 0 failed$' "$work/out.txt" || { cat "$work/out.txt"; fail "summary"; }
! grep -q '^note:' "$work/out.txt" || { cat "$work/out.txt"; fail "a note on NAO as it is"; }
# ... and turned by pitch pi/2 without saying so (the root height given, so the import's
# check of the legs' depth is skipped): the tests pass, the note says the legs point backward.
scripts/check_model.sh "$work/my robot/nao.urdf" --hands l_gripper,r_gripper --legs LPelvis,RPelvis \
  --root-rpy 0,1.5707963,0 --root-height 0.3 --build-dir "$build_dir" >"$work/out_turned.txt" 2>&1 || rc=$?
[[ $rc -eq 0 ]] || { cat "$work/out_turned.txt"; fail "turned NAO: exit $rc"; }
grep -q "^note: the legs point backward rather than down at zero joint values" "$work/out_turned.txt" ||
  { cat "$work/out_turned.txt"; fail "turned NAO: no note"; }

# 2. A robot on a fixed base whose URDF has no masses (no centre of mass to check), in a copy
# with xacro leftovers beside its links and joints (--ignore-xacro-elements; KDL's parser
# skips them too), its hands frames added to the tools (--add-frame, twice; the references
# read them as fixed links).
python3 - "$work/massless.urdf" "$work/massless_xacro.urdf" <<'PY'
import re, sys
text = re.sub(r"<inertial>.*?</inertial>", "", open("models/dual_arm/dual_arm.urdf").read(), flags=re.S)
open(sys.argv[1], "w").write(text)
leftovers = ('<robot name="dual_arm">\n  <xacro:include filename="$(find dual_arm)/materials.xacro"/>\n'
             '  <xacro:macro name="gz" params="link"><gazebo reference="${link}"/></xacro:macro>\n'
             '  <xacro:gz link="torso"/>')
open(sys.argv[2], "w").write(text.replace('<robot name="dual_arm">', leftovers))
PY
scripts/check_model.sh "$work/massless_xacro.urdf" --hands l_tip,r_tip --fixed-base --ignore-xacro-elements \
  --add-frame l_tip:left_tool:0.05,0,0 --add-frame r_tip:right_tool:0.05,0.01,0:0,0.5,0 \
  --build-dir "$build_dir" >"$work/out_massless.txt" 2>&1 || rc=$?
[[ $rc -eq 0 ]] || { cat "$work/out_massless.txt"; fail "massless fixed-base robot: exit $rc"; }
# (At least the sixteen tests of the first version; the count grows as tests are added.)
grep -Eq '^(1[6-9]|[2-9][0-9]) passed, [0-9]+ skipped, 0 failed$' "$work/out_massless.txt" || { cat "$work/out_massless.txt"; fail "massless summary"; }
grep -q '^  passed  KdlComparison.PosesAndJacobiansMatchKdl/user ' "$work/out_massless.txt" ||
  { cat "$work/out_massless.txt"; fail "massless: KDL comparison with the added frames"; }
grep -q "^note: the model has no mass" "$work/out_massless.txt" || { cat "$work/out_massless.txt"; fail "massless: no note"; }
set +e
scripts/check_model.sh "$work/massless_xacro.urdf" --hands left_tool,right_tool --fixed-base --build-dir "$build_dir" \
  >/dev/null 2>"$work/err7.txt"
rc=$?
set -e
[[ $rc -ne 0 ]] && grep -q "massless_xacro.urdf:7: <xacro:include> is a xacro element: expand the file first" "$work/err7.txt" ||
  { cat "$work/err7.txt"; fail "xacro leftovers without the flag: exit $rc"; }

# 3. A misspelt frame: exit 2, the flag and the closest name, nothing on stdout.
set +e
scripts/check_model.sh "$work/my robot/nao.urdf" --hands l_griper,r_gripper --build-dir "$build_dir" \
  >"$work/out2.txt" 2>"$work/err2.txt"
rc=$?
set -e
[[ $rc -eq 2 ]] || fail "misspelt hand: exit $rc, expected 2"
grep -q "^error: --hands (WBM_TEST_HANDS): .*no frame named 'l_griper' (did you mean 'l_gripper'?)" "$work/err2.txt" ||
  { cat "$work/err2.txt"; fail "misspelt hand: message"; }
[[ ! -s "$work/out2.txt" ]] || { cat "$work/out2.txt"; fail "misspelt hand: output on stdout"; }
# ... and a range of one number.
set +e
scripts/check_model.sh "$work/my robot/nao.urdf" --hands l_gripper,r_gripper --upper-body-x-range 0.1 \
  --build-dir "$build_dir" >/dev/null 2>"$work/err6.txt"
rc=$?
set -e
[[ $rc -eq 2 ]] && grep -q "^error: --upper-body-x-range (WBM_TEST_UPPER_BODY_X_RANGE): expected LOWER,UPPER in metres" \
  "$work/err6.txt" || { cat "$work/err6.txt"; fail "range of one number: exit $rc"; }
# ... and a hand that no joint moves (a frame on the base).
set +e
scripts/check_model.sh "$work/massless.urdf" --hands left_tool,world --build-dir "$build_dir" >/dev/null 2>"$work/err3.txt"
rc=$?
set -e
[[ $rc -eq 2 ]] && grep -q "^error: --hands (WBM_TEST_HANDS): no joint of the robot moves frame 'world'" "$work/err3.txt" ||
  { cat "$work/err3.txt"; fail "unmoved hand: exit $rc"; }
# ... and two hands on one arm (the elbow and the tool of the left arm).
set +e
scripts/check_model.sh "$work/massless.urdf" --hands left_tool,left_link4 --fixed-base --build-dir "$build_dir" \
  >/dev/null 2>"$work/err5.txt"
rc=$?
set -e
[[ $rc -eq 2 ]] && grep -q "^error: --hands (WBM_TEST_HANDS): 'left_tool' and 'left_link4' are on one arm" \
  "$work/err5.txt" || { cat "$work/err5.txt"; fail "hands on one arm: exit $rc"; }
# ... and a head that no joint turns on a fixed base (its 2-row view axis would be singular).
set +e
scripts/check_model.sh "$work/massless.urdf" --hands left_tool,right_tool --head world --fixed-base \
  --build-dir "$build_dir" >/dev/null 2>"$work/err4.txt"
rc=$?
set -e
[[ $rc -eq 2 ]] && grep -q "^error: --head (WBM_TEST_HEAD): no revolute joint of the robot turns frame 'world'" \
  "$work/err4.txt" || { cat "$work/err4.txt"; fail "unturned head: exit $rc"; }

# ... and a flag without its value (the shared flag parsing of scripts/lib/flags.sh).
tests/cli_expect_error.sh scripts/check_model.sh "check_model.sh: --hands needs a value" \
  "$work/my robot/nao.urdf" --hands --head gaze --build-dir "$build_dir" || fail "--hands without a value"

# 4. The summary fails a report with a failed test, and one in which no test ran.
cat >"$work/failed.json" <<'EOF'
{"testsuites": [{"name": "Models/Kinematics", "testsuite": [
  {"name": "JacobiansMatchFiniteDifferences/user", "result": "COMPLETED", "time": "0.1s",
   "failures": [{"failure": "column 3: analytic 1 vs finite difference 2"}]},
  {"name": "NamedFramesExist/user", "result": "COMPLETED", "time": "0s"}]}]}
EOF
echo '{"testsuites": []}' >"$work/empty.json"
for report in failed empty; do
  set +e
  python3 tests/check_model_summary.py robot.urdf "$work/$report.json" >"$work/$report.txt" 2>&1
  rc=$?
  set -e
  [[ $rc -eq 1 ]] || { cat "$work/$report.txt"; fail "summary of the $report report: exit $rc, expected 1"; }
done
grep -q "^  FAILED  Kinematics.JacobiansMatchFiniteDifferences/user " "$work/failed.txt" &&
  grep -q "^1 passed, 0 skipped, 1 failed$" "$work/failed.txt" || { cat "$work/failed.txt"; fail "failed report: lines"; }
grep -q "no test ran" "$work/empty.txt" || { cat "$work/empty.txt"; fail "empty report: message"; }
echo "check_model_test: passed"
