#!/usr/bin/env bash
# Runs the whole benchmark set on this machine and writes bench/results/<machine>/:
#   machine.md      the machine, compiler, Bullet version and commit the figures belong to
#   peer.csv        nucleon against Bullet's btSoftBody on the same cloth (bench/README.md):
#                   hanging (N = 64, 128, 256; K = 4, 10, 20; nucleon with its tethers on and
#                   off, as Bullet has none), hanging with bending, on a sphere
#   scaling.csv     `nucleon bench` thread sweeps, 1 .. nproc threads, every backend
#   systems_Sweep.csv, systems_Contacts.csv   Google Benchmark: one sweep of each constraint
#                   family and backend; contact projection
#   summary.md      the tables: headline comparison, bending, sphere, thread scaling and the
#                   fitted scaling model
#   ms_vs_n.png, speedup.png, strain_vs_iterations.png   (gnuplot)
#   convergence.csv, convergence.md, convergence_128.png, convergence_256.png   strain against
#                   wall time and sweep cost for every backend (scripts/bench_convergence.sh)
#
# Usage: bash scripts/bench.sh [--quick] [--peer-only | --convergence-only]
#   --quick       one repeat, N = 64 and 128 only, fewer steps: a smoke run of the pipeline
#   --peer-only   only the comparison with Bullet (peer.csv), then the report; the thread scaling
#                 and per-system CSV files already in the folder are kept as they are (machine.md
#                 says which parts this run measured)
#   --convergence-only   only scripts/bench_convergence.sh (machine.md and the other files are
#                 left as they are)
# Set NUCLEON_BENCH_MACHINE to name the results folder (default: <cores>core-<cpu model>), and
# NUCLEON_BENCH_BUILD to use an existing Release build folder as it is configured (default: a
# build-bench folder configured here, without the tests).
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0 peer_only=0 convergence_only=0
for arg in "$@"; do
  case "$arg" in
    --quick) quick=1 ;;
    --peer-only) peer_only=1 ;;
    --convergence-only) convergence_only=1 ;;
    *) echo "usage: bash scripts/bench.sh [--quick] [--peer-only | --convergence-only]" >&2; exit 2 ;;
  esac
done
if ((convergence_only)); then
  # It sets up its own build and results folder the same way (same variables, same defaults).
  quick_flag=()
  ((quick)) && quick_flag=(--quick)
  exec bash scripts/bench_convergence.sh "${quick_flag[@]}"
fi
started=$(date +%s)

bash scripts/deps.sh bench
jobs=$(nproc)
bin=${NUCLEON_BENCH_BUILD:-build-bench}
if [[ -z "${NUCLEON_BENCH_BUILD:-}" ]]; then
  cmake -S . -B "$bin" -G Ninja -DCMAKE_BUILD_TYPE=Release -DNUCLEON_BUILD_TESTS=OFF >/dev/null
fi
cmake --build "$bin" -j "$jobs" --target nucleon_app nucleon_bench_cloth nucleon_bench_systems

cpu=$(grep -m1 "model name" /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
machine=${NUCLEON_BENCH_MACHINE:-${jobs}core-$(echo "$cpu" | tr -cs 'A-Za-z0-9' '-' |
  sed 's/-*$//' | cut -c1-40)}
out=bench/results/$machine
mkdir -p "$out"

repeats=3 sizes=64,128,256 steps=120 scaling_steps=100
if ((quick)); then repeats=1 sizes=64,128 steps=40 scaling_steps=20; fi
threads=$(seq -s, 1 "$jobs")

{
  echo "# Machine"
  echo
  echo "- CPU: $cpu, $jobs cores visible ($(grep -c ^processor /proc/cpuinfo) logical)"
  echo "- Memory: $(awk '/MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo)"
  echo "- Compiler: $(c++ --version | head -1)"
  echo "- Bullet: $(dpkg-query -W -f='${Version}' libbullet-dev 2>/dev/null || echo none)"
  echo "- nucleon commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "- Date: $(date -u +%Y-%m-%d)"
  echo "- Repeats per configuration: $repeats (median reported); $steps steps per cloth run, the"
  echo "  first 10 untimed"
  if ((peer_only)); then
    echo "- This run measured the comparison with Bullet only; the thread scaling and per-system"
    echo "  tables are from an earlier run in this folder"
  fi
} >"$out/machine.md"

echo "== cloth against Bullet (hanging, structural links; nucleon tethers on and off)"
"$bin/bench/nucleon_bench_cloth" --n "$sizes" --iterations 4,10,20 --scenes hanging \
  --bending off --solvers colored-gs,jacobi,multigrid --tethers both --threads "$jobs" \
  --repeats "$repeats" --steps "$steps" --csv "$out/peer_hanging.csv"
echo "== cloth against Bullet (hanging, with bending; nucleon tethers on and off)"
"$bin/bench/nucleon_bench_cloth" --n "$sizes" --iterations 10 --scenes hanging --bending on \
  --solvers colored-gs --tethers both --threads "$jobs" --repeats "$repeats" --steps "$steps" \
  --csv "$out/peer_bending.csv"
echo "== cloth against Bullet (dropped on a sphere: a free cloth, no tethers)"
"$bin/bench/nucleon_bench_cloth" --n "$sizes" --iterations 10 --scenes sphere \
  --solvers colored-gs,gauss-seidel --tethers on --threads "$jobs" --repeats "$repeats" \
  --steps "$steps" --csv "$out/peer_sphere.csv"
{
  head -1 "$out/peer_hanging.csv"
  for f in hanging bending sphere; do tail -n +2 "$out/peer_$f.csv"; done
} >"$out/peer.csv"
rm "$out"/peer_hanging.csv "$out"/peer_bending.csv "$out"/peer_sphere.csv

if ((peer_only)); then
  bash bench/report.sh "$out"
  echo "results: $out ($(($(date +%s) - started)) s)"
  exit 0
fi

echo "== thread scaling"
scaling_scenes="cloth_hang_128 cloth_hang_256 cloth_sphere solid_jelly"
((quick)) && scaling_scenes="cloth_hang_128 cloth_sphere"
# shellcheck disable=SC2086
"$bin/nucleon" bench $scaling_scenes --solver gauss-seidel,jacobi,colored-gs \
  --threads "$threads" --steps "$scaling_steps" --repeats "$repeats" --csv "$out/scaling.csv"

echo "== per-system Google Benchmarks"
# One output file per benchmark family: Google Benchmark's CSV needs the same counters in every row.
size=256
((quick)) && size=64
for family in Sweep Contacts; do
  "$bin/bench/nucleon_bench_systems" --benchmark_filter="BM_$family/.*n:$size/" \
    --benchmark_repetitions="$repeats" --benchmark_report_aggregates_only=true \
    --benchmark_out="$out/systems_$family.csv" --benchmark_out_format=csv >/dev/null
done

bash bench/report.sh "$out"

echo "== convergence of the backends"
# Same build and results folder; it writes its own tables and plots (convergence.md).
quick_flag=()
((quick)) && quick_flag=(--quick)
NUCLEON_BENCH_BUILD=$bin NUCLEON_BENCH_MACHINE=$machine \
  bash scripts/bench_convergence.sh "${quick_flag[@]}"
echo "results: $out ($(($(date +%s) - started)) s)"
