#!/usr/bin/env bash
# Installs what is missing, builds in Release with warnings as errors and runs the test suite,
# then again with double-precision solver state, then builds the tests again with
# AddressSanitizer + UndefinedBehaviorSanitizer and runs them. The viewer and the Python module
# are built and tested in the first build only (the solver state they show is tested in all three).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
jobs=$(nproc)

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DNUCLEON_WERROR=ON >/dev/null
cmake --build build -j "$jobs"
ctest --test-dir build --output-on-failure -j "$jobs"

cmake -S . -B build-double -G Ninja -DCMAKE_BUILD_TYPE=Release -DNUCLEON_WERROR=ON \
  -DNUCLEON_DOUBLE=ON -DNUCLEON_BUILD_BENCH=OFF -DNUCLEON_BUILD_VIEWER=OFF \
  -DNUCLEON_BUILD_PYTHON=OFF >/dev/null
cmake --build build-double -j "$jobs"
ctest --test-dir build-double --output-on-failure -j "$jobs"

# -O1 -g1 (line tables for the reports' stack traces, no variable information): half the
# compile time of -O2 -g, the largest part of this command.
cmake -S . -B build-sanitize -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DNUCLEON_WERROR=ON \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
  -DNUCLEON_SANITIZE=ON -DNUCLEON_BUILD_BENCH=OFF -DNUCLEON_BUILD_VIEWER=OFF >/dev/null
cmake --build build-sanitize -j "$jobs"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-sanitize --output-on-failure -j "$jobs"
