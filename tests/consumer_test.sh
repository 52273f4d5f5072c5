#!/bin/bash
# Usage: consumer_test.sh CMAKE BUILD_DIR PREFIX CONSUMER_SOURCE CONSUMER_BUILD [CONFIG]
# Installs the wbm build tree BUILD_DIR into PREFIX, then configures, builds and runs the
# consumer project (examples/consumer) against it with find_package(wbm). Any failing
# step fails the test.
set -euo pipefail
cmake=$1
build=$2
prefix=$3
source=$4
consumer_build=$5
config=${6:-Release}
[ -n "$config" ] || config=Release

rm -rf "$prefix" "$consumer_build"
"$cmake" --install "$build" --prefix "$prefix" --config "$config"
test -f "$prefix/include/wbm/model.hpp"
ls "$prefix"/lib*/cmake/wbm/wbmConfig.cmake >/dev/null

# Only the install prefix may provide wbm: no package registry, no build tree.
"$cmake" -S "$source" -B "$consumer_build" -DCMAKE_BUILD_TYPE="$config" \
  -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
"$cmake" --build "$consumer_build" --config "$config"
output=$("$consumer_build/wbm_consumer")
echo "$output"
grep -q "l_hand_ref" <<<"$output"
grep -q "$prefix" "$consumer_build/CMakeCache.txt"   # wbm_DIR points into the prefix
echo "consumer test ok"
