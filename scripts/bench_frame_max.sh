#!/usr/bin/env bash
# The per-frame max strain of a hanging cloth under several solver configurations, frame by
# frame, against a reference configuration. The max strain after one frame is one sample of a
# quantity that swings from frame to frame while the cloth whips round; this script compares the
# whole second half of the run instead: for each frame the reference's max over the
# configuration's, and the median, spread and share of frames at a given ratio.
#
# Usage: bash scripts/bench_frame_max.sh [--scene 128|256] [--threads T]
# Writes into bench/results/<machine>/ (NUCLEON_BENCH_MACHINE and NUCLEON_BENCH_BUILD as in
# scripts/bench.sh):
#   frame_max_<N>.csv   scene, config, solver settings, frame, ms, max_strain
#   frame_max_<N>.md    the table
#
# Configurations (K fine sweeps, one substep, the scene's cascade): colored-gs × 10 (the
# reference), jacobi × 10, multigrid + 7 colored-gs sweeps, multigrid + 8 and + 10 Jacobi
# sweeps: the rows of the equal-wall-time table in multigrid.md, and a multigrid-jacobi row that
# is faster than the reference; and multigrid + 8 Jacobi sweeps with the cascade over-relaxed by
# 1.5 (solver.cascade_relaxation).
set -euo pipefail
cd "$(dirname "$0")/.."
n=256 threads=2
usage="usage: bash scripts/bench_frame_max.sh [--scene 128|256] [--threads T]"
while (($#)); do
  case "$1" in
    --scene)
      [[ "${2:-}" == 128 || "${2:-}" == 256 ]] || { echo "$usage" >&2; exit 2; }
      n=$2; shift ;;
    --threads)
      [[ "${2:-}" =~ ^[1-9][0-9]*$ ]] || { echo "$usage" >&2; exit 2; }
      threads=$2; shift ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
  shift
done

bin=${NUCLEON_BENCH_BUILD:-build-bench}
if [[ -z "${NUCLEON_BENCH_BUILD:-}" ]]; then
  bash scripts/deps.sh
  cmake -S . -B "$bin" -G Ninja -DCMAKE_BUILD_TYPE=Release -DNUCLEON_BUILD_TESTS=OFF >/dev/null
fi
cmake --build "$bin" -j "$(nproc)" --target nucleon_app
cpu=$(grep -m1 "model name" /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
machine=${NUCLEON_BENCH_MACHINE:-$(nproc)core-$(echo "$cpu" | tr -cs 'A-Za-z0-9' '-' |
  sed 's/-*$//' | cut -c1-40)}
out=bench/results/$machine
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

scene=assets/scenes/cloth_hang_$n.json
grep -q '"type": "multigrid"' "$scene" || { echo "$scene: no multigrid solver line" >&2; exit 1; }
# label | solver type | extra solver keys | fine sweeps
configs=(
  "colored-gs x10|colored-gs||10"
  "jacobi x10|jacobi||10"
  "multigrid + 7|multigrid||7"
  "multigrid-jacobi + 8|multigrid|\"smoother\": \"jacobi\", |8"
  "multigrid-jacobi + 10|multigrid|\"smoother\": \"jacobi\", |10"
  "multigrid-jacobi + 8 cascade x1.5|multigrid|\"smoother\": \"jacobi\", \"cascade_relaxation\": 1.5, |8"
)
csv=$out/frame_max_$n.csv
echo "scene,config,solver,smoother,iterations,threads,frame,ms,max_strain" >"$csv"
for c in "${configs[@]}"; do
  IFS='|' read -r label type extra iterations <<<"$c"
  sed "s/\"type\": \"multigrid\", /\"type\": \"$type\", $extra/" "$scene" >"$tmp/scene.json"
  "$bin/nucleon" run "$tmp/scene.json" --iterations "$iterations" --threads "$threads" --quiet \
    --stats "$tmp/stats.json" >/dev/null
  smoother=$({ grep -o '"smoother": "[a-z-]*"' "$tmp/stats.json" || true; } | head -1 | cut -d'"' -f4)
  # The per_frame objects list their keys in order: frame, intersections, max_strain, ms.
  awk -v OFS=, -v scene="cloth_hang_$n" -v label="$label" -v type="$type" \
    -v smoother="${smoother:-none}" -v k="$iterations" -v t="$threads" '
    /"per_frame"/ { on = 1 }
    on && /^  \]/ { on = 0 }
    on && /"frame":/ { gsub(/[^0-9]/, "", $2); frame = $2 }
    on && /"max_strain":/ { gsub(/,/, "", $2); strain = $2 }
    on && /"ms":/ { gsub(/,/, "", $2); print scene, label, type, smoother, k, t, frame, $2, strain }
  ' "$tmp/stats.json" >>"$csv"
  echo "  $label: $(grep -c ",$label," "$csv") frames"
done

frames=$(awk -F, 'NR > 1 && $7 > m { m = $7 } END { print m }' "$csv")
first=$((frames / 2 + 1))
{
  echo "# Per-frame max strain, cloth_hang_$n, $threads threads"
  echo
  echo "- Command: \`bash scripts/bench_frame_max.sh --scene $n --threads $threads\`; nucleon commit"
  echo "  $(git rev-parse --short HEAD 2>/dev/null || echo unknown), $(date -u +%Y-%m-%d); $cpu."
  echo "- One \`nucleon run\` per configuration, $frames frames; the figures are over frames"
  echo "  $first–$frames. ms/step is the median of those frames' step times (one run: a guide, the"
  echo "  benchmark's equal-time figures are in multigrid.md)."
  echo "- Ratio: colored-gs × 10's max strain of a frame over the configuration's max of the same"
  echo "  frame (above 1: the configuration's worst edge is less stretched)."
  echo
  echo "| config | ms/step | max after the last frame | per-frame max: median | min | max | ratio: median | min | frames with ratio ≥ 10 |"
  echo "|---|---|---|---|---|---|---|---|---|"
  awk -F, -v first="$first" -v last="$frames" '
    function median(a, n,   i, j, x) {  # insertion sort, then the middle (mean of two)
      for (i = 2; i <= n; i++) { x = a[i]; for (j = i - 1; j >= 1 && a[j] > x; j--) a[j + 1] = a[j]; a[j + 1] = x }
      return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
    }
    NR == 1 { next }
    !($2 in seen) { seen[$2] = 1; order[++configs] = $2 }
    $7 >= first { strain[$2, $7] = $9; ms[$2, $7] = $8 }
    END {
      ref = order[1]
      for (c = 1; c <= configs; c++) {
        name = order[c]; n = 0; lo = 1e30; hi = 0; rlo = 1e30; tens = 0
        delete s; delete r; delete t
        for (f = first; f <= last; f++) {
          n++; s[n] = strain[name, f]; t[n] = ms[name, f]; r[n] = strain[ref, f] / strain[name, f]
          if (s[n] < lo) lo = s[n]; if (s[n] > hi) hi = s[n]
          if (r[n] < rlo) rlo = r[n]; if (r[n] >= 10) tens++
        }
        final = strain[name, last]
        printf "| %s | %.2f | %.1f%% | %.1f%% | %.1f%% | %.1f%% | %.1f | %.1f | %d of %d |\n",
          name, median(t, n), 100 * final, 100 * median(s, n), 100 * lo, 100 * hi, median(r, n),
          rlo, tens, n
      }
    }' "$csv"
} >"$out/frame_max_$n.md"
cat "$out/frame_max_$n.md"
