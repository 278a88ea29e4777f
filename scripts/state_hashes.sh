#!/usr/bin/env bash
# Prints the state hash of every bundled scene under every backend after a few frames: a table
# to compare before and after a change that must not alter behaviour (a refactoring).
#   scripts/state_hashes.sh [NUCLEON_BINARY] [FRAMES]     (defaults: build/nucleon, 20)
set -euo pipefail
cd "$(dirname "$0")/.."
nucleon=${1:-build/nucleon}
frames=${2:-20}
stats=$(mktemp)
trap 'rm -f "$stats"' EXIT
for scene in assets/scenes/*.json; do
  for solver in gauss-seidel jacobi colored-gs multigrid; do
    "$nucleon" run "$scene" --frames "$frames" --threads 2 --solver "$solver" --quiet \
      --stats "$stats" >/dev/null
    hash=$(sed -n 's/.*"state_hash": *"\([0-9a-f]*\)".*/\1/p' "$stats")
    printf '%-24s %-13s %s\n' "$(basename "$scene" .json)" "$solver" "$hash"
  done
done
