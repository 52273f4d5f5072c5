#!/bin/sh
# Usage: cli_expect_error.sh [--any-stdout] PROGRAM EXPECTED ARGS...
# Runs `PROGRAM ARGS...`; passes if it exits non-zero and prints EXPECTED (a fixed string) on
# stderr, and prints nothing on stdout unless --any-stdout is given (for programs such as
# the benchmark that write their own output there).
any_stdout=0
if [ "$1" = "--any-stdout" ]; then
  any_stdout=1
  shift
fi
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
if [ "$any_stdout" -eq 0 ] && [ -s "$out" ]; then
  echo "FAIL: stdout is not empty:" >&2
  cat "$out" >&2
  exit 1
fi
echo "ok: exit status $status, stderr: $(cat "$err")"
