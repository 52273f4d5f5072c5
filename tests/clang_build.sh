#!/usr/bin/env bash
# Builds wbm a second time, with Clang, AddressSanitizer and UndefinedBehaviorSanitizer and
# assertions on (Eigen's index checks), warnings as errors, in a separate directory, and runs
# its unit tests there. So the library, the tools and the tests stay warning-free with the
# other compiler on Debian (GCC is the default build), and a read or write out of bounds, a
# use after free, a leak or undefined behaviour (a misaligned load, a signed overflow, ...)
# anywhere the unit tests reach ends the test with the sanitizer's report: the solver's
# hand-written kernels index raw buffers, where such a bug need not show in results (the
# first run found a scale written one past its buffer). -O1, as the sanitizers advise. The
# tests' own code is compiled without the sanitizers (WBM_TEST_COMPILE_OPTIONS): they check the
# library and the tools, which keep them, and ASan's allocator puts its red zones around every
# heap block, also those a test allocates and the library writes (the scale above is still
# caught). Sanitized, the tests' Eigen-heavy files took most of this build's time
# (test_solver.cpp 52 s against 25; the whole build and run 6.3 -> 4.7 min on two cores). Not
# the benchmarks (GCC's build runs their short mode; built and run here as well they took
# about 1.5 of the 7.4 minutes this took on two cores) nor the valgrind analyses, which read
# GCC's build.
# Usage: clang_build.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$1
dir=$2
if ! command -v clang++ >/dev/null; then
  echo "clang_build: clang++ is not installed (Debian package clang; scripts/setup.sh installs it): skipped" >&2
  exit 77  # CTest: skipped
fi
sanitizers=address,undefined
probe=$(mktemp -d)
trap 'rm -rf "$probe"' EXIT
if ! echo 'int main() { return 0; }' | clang++ -x c++ -fsanitize=$sanitizers - -o "$probe/a.out" 2>"$probe/log"; then
  echo "clang_build: clang++ cannot link with -fsanitize=$sanitizers (its runtimes are in the Debian package" \
    "libclang-rt-14-dev; scripts/setup.sh installs it): skipped" >&2
  sed 's/^/  /' "$probe/log" >&2
  exit 77
fi
CC=clang CXX=clang++ cmake -S "$src" -B "$dir" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-O1 \
  -DWBM_SANITIZE=$sanitizers -DWBM_TEST_COMPILE_OPTIONS=-fno-sanitize=$sanitizers -DWBM_WARNINGS_AS_ERRORS=ON \
  -DWBM_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$dir" -j"$(nproc)"
ctest --test-dir "$dir" -L unit --output-on-failure -j"$(nproc)"
