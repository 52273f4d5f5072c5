# Sourced by the CTests that run a user's tool on seeded random robot variants
# (check_model_random_robots.sh, bench_random_robots.sh): with the caller's BUILD_DIR and
# WORK_DIR in build_dir and work and its name in test_name, it empties WORK_DIR and defines
#   run NAME BASE.urdf SEED FLAGS...
# which writes the variant (tests/random_robot.py) to WORK_DIR/NAME.urdf and calls the
# caller's `check_variant URDF OUTPUT FLAGS...`: that runs the tool with its output to
# OUTPUT, returns non-zero if it failed (with a reason on stdout) and otherwise prints a
# one-line summary. A failure prints the tool's output and ends the test with exit 1.
rm -rf "$work"
mkdir -p "$work"
fail() { echo "$test_name: $*" >&2; exit 1; }
run() {  # name base seed flags...
  local name="$1" base="$2" seed="$3"
  shift 3
  python3 tests/random_robot.py "$base" "$seed" "$work/$name.urdf"
  local summary
  summary=$(check_variant "$work/$name.urdf" "$work/$name.txt" "$@") ||
    { cat "$work/$name.txt"; fail "$name (seed $seed): $summary"; }
  echo "$name (seed $seed): $summary"
}
