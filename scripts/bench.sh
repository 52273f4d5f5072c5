#!/usr/bin/env bash
# Runs the wbm benchmarks (bench/README.md).
#
#   scripts/bench.sh                      all fixtures (paper model, G1, Romeo) against KDL
#   scripts/bench.sh --short              the same, short (a few seconds)
#   scripts/bench.sh --scaling            scaling study (9 short repetitions, about 5 min); rewrites
#                                         bench/results/scaling.{csv,svg,md}
#   scripts/bench.sh --instructions       instructions per control cycle by function (valgrind's
#                                         callgrind; the same on every run of a build); with a
#                                         URDF (below): on your robot
#   scripts/bench.sh ROBOT.urdf --hands LEFT,RIGHT [--head FRAME] [--root LINK] [--legs A,B]
#                    [--com] [--posture DOF,DOF,...] [--start DOF=VALUE,...]
#                    [--default-limits] [--drop-legs] [--root-height H] [--upper-body-pivot H] [--root-rpy R,P,Y] [--fixed-base] [--short]
#                    [--upper-body-x-range LO,HI] [--upper-body-y-range LO,HI] [--ignore-xacro-elements]
#                    [--add-frame NAME:PARENT:X,Y,Z[:R,P,Y] ...]
#                                         your robot: both hands position + grasp axis and the
#                                         head's view axis (12 rows; 10 without --head), the
#                                         centre of mass (3 rows) and joint rows if asked, with
#                                         KDL's wdls and arm-chain solvers on the same URDF;
#                                         --fixed-base freezes all nine virtual dofs, not only
#                                         the heel (a robot whose base never moves, e.g. a
#                                         dual-arm robot on a pedestal); --start replaces dofs'
#                                         values of the home pose (the centre of every range)
#                                         where the motions start, e.g. elbows bent: arms
#                                         stretched there keep the hands from moving
#   scripts/bench.sh --loop SECONDS [--rate HZ] [--priority P | --spin] [--plot DIR] [ROBOT.urdf --hands ...]
#                                         the controller in a periodic real-time loop (default
#                                         1000 Hz, SCHED_FIFO 80 with memory locked if allowed;
#                                         --priority 0: as started; --spin: busy-wait instead of
#                                         sleeping), then KDL's wdls cycle in the same loop: cycle
#                                         and wake-up latency median/p99/p99.9/max, overruns; on
#                                         the paper model, G1 and Romeo, or on your robot;
#                                         --plot DIR writes DIR/loop.csv (every period) and
#                                         DIR/loop.svg (histograms)
#   ... -- ARGS                           extra Google Benchmark flags, e.g.
#                                         -- --benchmark_repetitions=5 --benchmark_filter=paper_r12
#
# The binary is taken from $BUILD_DIR (default: build) and built there if it is missing.
set -euo pipefail
source "$(dirname "$0")/lib/flags.sh"  # now in the repository's root

build_dir="${BUILD_DIR:-build}"
urdf=""
mode="fixtures"
short=0
own=()
loop=()
plot_dir=""
extra=()

while [[ $# -gt 0 ]]; do
  model_flag "$@"
  if [[ $model_shift -gt 0 ]]; then  # bench_wbm's --wbm_hands=..., --wbm_drop_legs, ...
    own+=("--wbm_${model_key}${model_value:+=$model_value}")
    shift "$model_shift"
    continue
  fi
  case "$1" in
    -h|--help) usage 0 ;;
    --short) short=1 ;;
    --scaling) mode="scaling" ;;
    --instructions) mode="instructions" ;;
    --build-dir) need_value "$@"; build_dir="$2"; shift ;;
    --com) own+=("--wbm_com") ;;
    --posture) need_value "$@"; own+=("--wbm_posture=$2"); shift ;;
    --start) need_value "$@"; own+=("--wbm_start=$2"); shift ;;
    --loop) need_value "$@"; loop+=("--wbm_loop=$2"); shift ;;
    --rate) need_value "$@"; loop+=("--wbm_rate=$2"); shift ;;
    --priority) need_value "$@"; loop+=("--wbm_priority=$2"); shift ;;
    --spin) loop+=("--wbm_spin") ;;
    --plot) need_value "$@"; plot_dir="$2"; shift ;;
    --) shift; extra+=("$@"); break ;;
    -*) echo "bench.sh: unknown option $1" >&2; usage 2 ;;
    *) set_urdf "$1" ;;
  esac
  shift
done

if [[ ${#loop[@]} -gt 0 && "$mode" != "fixtures" ]]; then echo "bench.sh: --loop runs on its own (not with --$mode)" >&2; exit 2; fi
if [[ -n "$plot_dir" && ${#loop[@]} -eq 0 ]]; then echo "bench.sh: --plot DIR goes with --loop SECONDS" >&2; exit 2; fi
[[ -z "$plot_dir" ]] || plot_dir=$(caller_path "$plot_dir")

# The periodic loop (bench_wbm's arguments), and with --plot its samples and histograms.
run_loop() {
  if [[ -n "$plot_dir" ]]; then
    mkdir -p "$plot_dir"
    "$bin" "$@" "${loop[@]}" "--wbm_loop_csv=$plot_dir/loop.csv" "${extra[@]}"
    python3 bench/plot_loop.py "$plot_dir/loop.csv" "$plot_dir/loop.svg"
  else
    "$bin" "$@" "${loop[@]}" "${extra[@]}"
  fi
  exit 0
}

bin="$build_dir/bench/bench_wbm"
if [[ ! -x "$bin" ]]; then
  configure_build "$build_dir" -DWBM_BUILD_TESTS=OFF
  cmake --build "$build_dir" --target bench_wbm
fi

args=()
[[ $short -eq 1 ]] && args+=(--benchmark_min_time=0.01)

if [[ -n "$urdf" ]]; then
  urdf=$(caller_path "$urdf")
  [[ -f "$urdf" ]] || { echo "bench.sh: no such file: $urdf" >&2; exit 2; }
  # Without --hands, bench_wbm says so and lists the ends of the robot's arms.
  has_prefix --wbm_hands= "${own[@]}" || exec "$bin" "--wbm_urdf=$urdf" "${own[@]}"
  [[ ${#loop[@]} -eq 0 ]] || run_loop "--wbm_urdf=$urdf" "${own[@]}" --wbm_id=custom
  if [[ "$mode" == "instructions" ]]; then
    exec python3 bench/count_instructions.py "$bin" custom -- "--wbm_urdf=$urdf" "${own[@]}" --wbm_id=custom "${extra[@]}"
  fi
  exec "$bin" "--wbm_urdf=$urdf" "${own[@]}" --wbm_id=custom --benchmark_filter='^custom/' "${args[@]}" "${extra[@]}"
fi
if [[ ${#own[@]} -gt 0 ]]; then echo "bench.sh: --root/--legs/--hands/--head/--com/--posture/--start/--fixed-base/... need a URDF file" >&2; exit 2; fi

if [[ ${#loop[@]} -gt 0 ]]; then
  run_loop
elif [[ "$mode" == "instructions" ]]; then
  exec python3 bench/count_instructions.py "$bin" paper_r12 g1_r20 romeo_r12 -- "${extra[@]}"
elif [[ "$mode" == "scaling" ]]; then
  json="$(mktemp --suffix=.json)"
  trap 'rm -f "$json"' EXIT
  # Nine short repetitions in random order, of which plot_scaling.py takes the least: the
  # host's slow spells (seconds) slow whole repetitions (bench/README.md, "Scaling").
  reps=(--benchmark_repetitions=9 --benchmark_min_time=0.1 --benchmark_enable_random_interleaving=true)
  [[ $short -eq 1 ]] && reps=()
  "$bin" --benchmark_filter='^scaling/' --benchmark_out="$json" --benchmark_out_format=json "${reps[@]}" "${args[@]}" \
    "${extra[@]}"
  python3 bench/plot_scaling.py "$json" bench/results
else
  "$bin" --benchmark_filter='^(paper|g1|romeo)_' "${args[@]}" "${extra[@]}"
fi
