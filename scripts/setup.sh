#!/usr/bin/env bash
# Installs what wbm needs on Debian 12 (idempotent), builds the report viewer and the
# C++ code. Root runs apt-get directly, others through sudo.
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

packages=(build-essential cmake pkg-config git
  libeigen3-dev liburdfdom-dev libtinyxml-dev libconsole-bridge-dev
  liborocos-kdl-dev libkdl-parser-dev libcli11-dev libyaml-cpp-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev python3 chromium valgrind clang libclang-rt-14-dev)
# Node.js: Debian's packages unless a node/npm is already installed (e.g. NodeSource's).
command -v node >/dev/null || packages+=(nodejs)
command -v npm >/dev/null || packages+=(npm)
missing=()
for p in "${packages[@]}"; do
  # The status compared whole, not through `| grep -q` (under pipefail a pipeline whose
  # reader exits early can fail).
  [[ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)" == "install ok installed" ]] || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

echo "setup: building the report viewer (web/)"
(cd web && npm ci --no-audit --no-fund --loglevel=error && node build.mjs)

echo "setup: building wbm (build/)"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
