# Sourced by scripts/bench.sh and scripts/check_model.sh before they parse their arguments:
# their help text, the flags that describe a user's robot model (both take them with the same
# names and meanings), paths given relative to where the script was called, and the build
# directory of a fresh checkout. Sourcing it changes into the repository's root.

script_name="${0##*/}"
script_file="$(realpath "$0")"
caller_dir="$(pwd -P)"  # physical, as the repository root after the cd below
cd "$(dirname "$script_file")/.."

# usage STATUS: the calling script's header comment, to stdout when asked for (STATUS 0), to
# stderr after a bad flag; then exits with STATUS.
usage() {
  local text
  text=$(awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$script_file")
  if [[ "${1:-0}" -eq 0 ]]; then echo "$text"; else echo "$text" >&2; fi
  exit "${1:-0}"
}

# need_value FLAG [NEXT]: exits 2 with a message naming FLAG when its value is missing (NEXT
# absent, empty or another flag).
need_value() {
  [[ $# -ge 2 && -n "$2" && "$2" != --* ]] || { echo "$script_name: $1 needs a value" >&2; exit 2; }
}

# model_flag FLAG [NEXT]: when FLAG is one of the model flags, sets model_key (hands, head,
# legs, root, root_height, root_rpy, upper_body_x_range, upper_body_y_range, upper_body_pivot, default_limits,
# ignore_xacro_elements, drop_legs, fixed_base, add_frame: repeatable), model_value (the flag's
# value; empty for a switch) and model_shift (the arguments it took: 1 or 2); otherwise
# model_shift=0. A missing value exits as need_value does.
model_flag() {
  model_key=""
  model_value=""
  model_shift=0
  case "$1" in
    --hands|--head|--legs|--root|--root-height|--root-rpy|--upper-body-x-range|--upper-body-y-range|--upper-body-pivot|--add-frame)
      need_value "$@"
      model_value="$2"
      model_shift=2 ;;
    --default-limits|--ignore-xacro-elements|--drop-legs|--fixed-base)
      model_shift=1 ;;
    *) return 0 ;;
  esac
  model_key="${1#--}"
  model_key="${model_key//-/_}"
}

# has_prefix PREFIX WORD...: true if one of the WORDs starts with PREFIX. (Not `printf ... |
# grep -q`: under pipefail that fails now and then, when grep has matched and exited before
# printf wrote its last line; 1 run in 20,000 here.)
has_prefix() {
  local prefix="$1" word
  shift
  for word in "$@"; do [[ "$word" == "$prefix"* ]] && return 0; done
  return 1
}

# set_urdf ARG: the robot file, the one argument that is not a flag; a second exits 2.
set_urdf() {
  [[ -z "$urdf" ]] || { echo "$script_name: one URDF only" >&2; exit 2; }
  urdf="$1"
}

# caller_path PATH: PATH as the caller meant it (relative to where the script was called);
# unchanged if absolute or if the script was called from the repository's root.
caller_path() {
  if [[ "$1" == /* || "$caller_dir" == "$PWD" ]]; then echo "$1"; else echo "$caller_dir/$1"; fi
}

# configure_build DIR CMAKE_FLAG...: nothing if DIR is configured. On a fresh checkout (DIR
# the default build directory) runs scripts/setup.sh, what scripts/test.sh does first
# (Debian packages, the report viewer, the build); another DIR is configured as a Release
# build with the given flags and without the command-line tool (it needs the report viewer
# built by npm).
configure_build() {
  local dir="$1"
  shift
  [[ ! -f "$dir/CMakeCache.txt" ]] || return 0
  if [[ "$(realpath -m "$dir")" == "$PWD/build" ]]; then
    echo "$script_name: no build yet; running scripts/setup.sh" >&2
    scripts/setup.sh >&2
  else
    cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DWBM_BUILD_APPS=OFF "$@" >/dev/null
  fi
}
