# Sourced by scripts/bench.sh and scripts/check_model.sh: their help text, and the flags that
# describe a user's robot model, which both take with the same names and meanings.

script_name="${0##*/}"
script_file="$(realpath "$0")"  # before the script changes directory

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
# legs, root, root_height, default_limits, drop_legs, fixed_base), model_value (the flag's
# value; empty for a switch) and model_shift (the arguments it took: 1 or 2); otherwise
# model_shift=0. A missing value exits as need_value does.
model_flag() {
  model_key=""
  model_value=""
  model_shift=0
  case "$1" in
    --hands|--head|--legs|--root|--root-height)
      need_value "$@"
      model_value="$2"
      model_shift=2 ;;
    --default-limits|--drop-legs|--fixed-base)
      model_shift=1 ;;
    *) return 0 ;;
  esac
  model_key="${1#--}"
  model_key="${model_key//-/_}"
}
