#!/usr/bin/env bash
# Runs wbm's per-model correctness tests on your robot: the tests every shipped model passes.
#
#   scripts/check_model.sh ROBOT.urdf --hands LEFT,RIGHT [--head FRAME] [--legs A,B] [--root LINK]
#                          [--root-height H] [--upper-body-pivot H] [--root-rpy R,P,Y] [--default-limits] [--drop-legs] [--fixed-base]
#                          [--upper-body-x-range LO,HI] [--upper-body-y-range LO,HI] [--ignore-xacro-elements]
#                          [--add-frame NAME:PARENT:X,Y,Z[:R,P,Y] ...] [--build-dir DIR]
#
#   kinematics  every Jacobian (frames, points, axes, centre of mass) against central
#               differences of forward kinematics on random configurations; J q_dot against
#               the derivative of FK along a path; the chains; named frames; the upright
#               base; no allocation in FK and Jacobians; a reused Data equals a fresh one;
#               export to URDF and import again gives the same frame poses
#   KDL         poses and Jacobians of every frame against Orocos KDL on your URDF (mimic
#               joints included), and on the whole tree exported with the virtual dofs;
#               every frame hangs from the link next to it in the URDF (as drawn in reports)
#   solver      the hands' position and grasp-axis rows and the head's view-axis row: their
#               Jacobians against finite differences, J J# = I at full rank, J N = 0,
#               N N = N, frozen dofs exactly still (eqs. 6, 7); random controller runs
#               (targets out of reach, rows and dofs switched, NaN targets) stay finite and
#               within every position and speed limit
#   controller  both hands converge to 0.1 mm and 0.1 deg on reachable targets, allocating
#               nothing in the cycles
#
# After the tests' summary line: `wbm model info`'s notes on the file, if any (legs that do not
# point down, placeholder speed limits; docs/model.md), when the command-line tool is built.
#
# The flags are those of scripts/bench.sh (the hands: a frame per arm, e.g. a palm or the
# last wrist link; without --head no view axis; --fixed-base: the controller tests start
# with the base upright and keep the nine virtual dofs frozen, as for a robot on a pedestal). Exit status 0 when every test passed, 1
# when one failed, 2 for a bad flag, file or frame name. The test binaries are built in
# $BUILD_DIR (default: build) if they are not up to date. The property tests run 10^4 cases
# (shared among the models for the solver's); WBM_PROPERTY_CASES=N in the environment
# changes that.
set -euo pipefail
source "$(dirname "$0")/lib/flags.sh"  # now in the repository's root

build_dir="${BUILD_DIR:-build}"
urdf=""
env_vars=()
info_flags=()  # the model flags `wbm model info` takes, for its notes
added_frames=""  # --add-frame SPEC, repeatable: WBM_TEST_ADD_FRAME=SPEC;SPEC

while [[ $# -gt 0 ]]; do
  model_flag "$@"
  if [[ $model_shift -gt 0 ]]; then  # WBM_TEST_HANDS=..., WBM_TEST_DROP_LEGS=1, ...
    if [[ "$model_key" == add_frame ]]; then  # repeatable: joined by ';' below
      added_frames+="${added_frames:+;}$model_value"
    else
      env_vars+=("WBM_TEST_${model_key^^}=${model_value:-1}")
    fi
    case "$model_key" in hands|head|fixed_base) ;; *) info_flags+=("${@:1:$model_shift}") ;; esac
    shift "$model_shift"
    continue
  fi
  case "$1" in
    -h|--help) usage 0 ;;
    --build-dir) need_value "$@"; build_dir="$2"; shift ;;
    -*) echo "check_model.sh: unknown option $1" >&2; usage 2 ;;
    *) set_urdf "$1" ;;
  esac
  shift
done

[[ -z "$added_frames" ]] || env_vars+=("WBM_TEST_ADD_FRAME=$added_frames")
[[ -n "$urdf" ]] || { echo "check_model.sh: a URDF file is required (see --help)" >&2; exit 2; }
urdf=$(caller_path "$urdf")
[[ -f "$urdf" ]] || { echo "check_model.sh: no such file: $urdf" >&2; exit 2; }
has_prefix WBM_TEST_HANDS= "${env_vars[@]}" ||
  { echo "check_model.sh: --hands LEFT,RIGHT is required (two frames, one per arm; scripts/bench.sh ROBOT.urdf lists the ends of the robot's arms)" >&2; exit 2; }
[[ "$build_dir" == /* ]] || build_dir="$PWD/$build_dir"

binaries=(test_kinematics test_kdl test_solver test_controller)
configure_build "$build_dir" -DWBM_BUILD_BENCHMARKS=OFF
targets=("${binaries[@]}")
[[ ! -x "$build_dir/wbm" ]] || targets+=(wbm_cli)  # for the notes at the end (not in a tests-only build)
echo "check_model: building ${targets[*]} in $build_dir" >&2
cmake --build "$build_dir" --target "${targets[@]}" -j"$(nproc)" >/dev/null

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
status=0
for b in "${binaries[@]}"; do
  echo "check_model: ${b#test_} ..." >&2
  # Only the tests on the user's robot: their names end in /user. MimicModelsShareDofs checks
  # a shipped model against what it is known to hold, which a user's is not: it would only say
  # "skipped" (KdlComparison checks the user's mimic joints).
  set +e
  env "WBM_TEST_URDF=$urdf" "${env_vars[@]}" "$build_dir/tests/$b" \
    --gtest_filter='*/user:-*/Kinematics.MimicModelsShareDofs/user' --gtest_brief=1 \
    --gtest_output="json:$out/$b" | grep -v '^Running main()'
  rc=${PIPESTATUS[0]}
  set -e
  if [[ $rc -eq 2 && ! -f "$out/$b" ]]; then exit 2; fi  # the model or a flag: said on stderr, no report
  [[ $rc -eq 0 ]] || status=1
done
python3 tests/check_model_summary.py "$urdf" "${binaries[@]/#/$out/}" || status=1
# What imports and computes right but may not be what the file means (a root link turned
# without --root-rpy, placeholder speed limits): `wbm model info`'s notes, docs/model.md.
if [[ -x "$build_dir/wbm" ]]; then
  "$build_dir/wbm" model info "$urdf" "${info_flags[@]}" --json 2>/dev/null |
    python3 -c 'import json, sys; [print("note: " + n) for n in json.load(sys.stdin)["notes"]]' || true
fi
exit $status
