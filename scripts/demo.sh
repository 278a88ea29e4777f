#!/usr/bin/env bash
# Installs what is missing, builds in Release and runs the default demo scene: prints a summary
# and writes build/cloth_hang.png (and build/cloth_hang_stats.json).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target nucleon_app -j "$(nproc)"
./build/nucleon run assets/scenes/cloth_hang.json \
  --stats build/cloth_hang_stats.json --render build/cloth_hang.png "$@"
