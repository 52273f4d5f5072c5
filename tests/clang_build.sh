#!/usr/bin/env bash
# Builds wbm with Clang in a separate directory, warnings as errors, and runs its unit tests
# and the benchmarks' short mode there (not the valgrind analyses, below): the project stays warning-free and correct with the
# other compiler on Debian (GCC is the default build), and the benchmarks' sanity checks
# pass with its rounding too. Usage: clang_build.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$1
dir=$2
if ! command -v clang++ >/dev/null; then
  echo "clang_build: clang++ is not installed (Debian package clang; scripts/setup.sh installs it): skipped" >&2
  exit 77  # CTest: skipped
fi
CC=clang CXX=clang++ cmake -S "$src" -B "$dir" -DCMAKE_BUILD_TYPE=Release -DWBM_WARNINGS_AS_ERRORS=ON >/dev/null
cmake --build "$dir" -j"$(nproc)"
# Not the analyses under valgrind (instruction counts, memory traces: about a minute): they
# check scripts that read the GCC build's output the same way, and they run there.
ctest --test-dir "$dir" -L 'unit|bench' -LE valgrind --output-on-failure -j"$(nproc)"
