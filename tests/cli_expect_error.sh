#!/bin/sh
# Usage: cli_expect_error.sh WBM EXPECTED ARGS...
# Runs `WBM ARGS...`; passes if it exits non-zero, prints nothing on stdout and prints
# EXPECTED (a fixed string) on stderr.
wbm=$1
expected=$2
shift 2
out=$(mktemp) && err=$(mktemp) || exit 1
trap 'rm -f "$out" "$err"' EXIT
"$wbm" "$@" >"$out" 2>"$err"
status=$?
if [ "$status" -eq 0 ]; then
  echo "FAIL: '$wbm $*' exited 0" >&2
  exit 1
fi
if ! grep -qF -- "$expected" "$err"; then
  echo "FAIL: stderr does not contain: $expected" >&2
  echo "stderr was:" >&2
  cat "$err" >&2
  exit 1
fi
if [ -s "$out" ]; then
  echo "FAIL: stdout is not empty:" >&2
  cat "$out" >&2
  exit 1
fi
echo "ok: exit status $status, stderr: $(cat "$err")"
