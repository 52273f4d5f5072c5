#!/bin/sh
# Usage: expect_error.sh EXPECTED COMMAND ARGS...
# Runs COMMAND ARGS...; passes if it exits non-zero and prints EXPECTED (a fixed string) on
# stderr (stdout, the benchmark's own output, is not checked).
expected=$1
shift
err=$(mktemp) || exit 1
trap 'rm -f "$err"' EXIT
"$@" >/dev/null 2>"$err"
status=$?
if [ "$status" -eq 0 ]; then
  echo "FAIL: '$*' exited 0" >&2
  exit 1
fi
if ! grep -qF -- "$expected" "$err"; then
  echo "FAIL: stderr does not contain: $expected" >&2
  echo "stderr was:" >&2
  cat "$err" >&2
  exit 1
fi
echo "ok: exit status $status, stderr: $(cat "$err")"
