#!/usr/bin/env bash
# Convergence of the solver backends on the hanging cloths (assets/scenes/cloth_hang_128 and
# cloth_hang_256: 2 m, two pinned corners, inextensible, tethers on): the strain a run leaves
# against its wall time and against its sweep cost, over a ladder of sweep counts per substep at
# 1, 2 and 10 substeps. Writes into bench/results/<machine>/:
#   convergence.csv      one row per scene, backend, substeps, iterations and thread count
#   convergence_run.md   the command, the machine and the settings of the run
#   convergence.md       the tables (bench/convergence_report.sh; it also redraws the plots)
#   convergence_128.png, convergence_256.png   mean and p99 strain against ms/step and sweep cost
#
# Usage: bash scripts/bench_convergence.sh [--quick] [--scene 128|256] [--repeats R]
#   --quick        128² only (or the --scene one), a few rows of 30 frames: a smoke run
#   --scene N      measure that scene only; the other scene's rows already in convergence.csv
#                  are kept
#   --repeats R    runs per row, the median ms/step is reported (default 3 for 128², 1 for 256²)
# NUCLEON_BENCH_MACHINE and NUCLEON_BENCH_BUILD as in scripts/bench.sh (results folder name, and
# an existing Release build folder to use as it is; default: build-bench, configured here).
#
# Every row is one `nucleon bench` of a copy of the scene with its substep count set (the bench
# command has no --substeps flag), W warm-up steps then F − W timed ones from a fresh world: the
# final state, hence the strain, is that of `nucleon run SCENE --frames F` with the same flags
# (same state hash), and ms/step leaves out the first steps' set-up. `bench` rather than `run`
# because only `bench` reports the projection count (from the engine's profile, the multigrid
# cascade's coarse projections included) that the sweep cost is made of.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0 only="" repeats=""
usage="usage: bash scripts/bench_convergence.sh [--quick] [--scene 128|256] [--repeats R]"
command_line="bash scripts/bench_convergence.sh${*:+ $*}"
while (($#)); do
  case "$1" in
    --quick) quick=1 ;;
    --scene)
      [[ "${2:-}" == 128 || "${2:-}" == 256 ]] || { echo "$usage" >&2; exit 2; }
      only=$2; shift ;;
    --repeats)
      [[ "${2:-}" =~ ^[1-9][0-9]*$ ]] || { echo "$usage" >&2; exit 2; }
      repeats=$2; shift ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
  shift
done
started=$(date +%s)

bash scripts/deps.sh bench
jobs=$(nproc)
bin=${NUCLEON_BENCH_BUILD:-build-bench}
if [[ -z "${NUCLEON_BENCH_BUILD:-}" ]]; then
  cmake -S . -B "$bin" -G Ninja -DCMAKE_BUILD_TYPE=Release -DNUCLEON_BUILD_TESTS=OFF >/dev/null
fi
cmake --build "$bin" -j "$jobs" --target nucleon_app

cpu=$(grep -m1 "model name" /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
machine=${NUCLEON_BENCH_MACHINE:-${jobs}core-$(echo "$cpu" | tr -cs 'A-Za-z0-9' '-' |
  sed 's/-*$//' | cut -c1-40)}
out=bench/results/$machine
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# multigrid-jacobi is the multigrid backend with Jacobi fine sweeps (the scene's "smoother").
backends="gauss-seidel jacobi colored-gs multigrid multigrid-jacobi"
# Sweeps per substep for each substep count. The products S × K span about 3 to 40 fine sweeps
# per step and each ladder holds S × K = 10, the colored-gs reference of the equal-time table.
ladder_1="3 5 8 10 15 20 30 40"
ladder_2="2 3 5 8 10 15 20"
ladder_10="1 2 3 4"
substep_counts="1 2 10"
scenes="128 256"
# The same frame count for every row of a scene: the strain depends on it. The scenes' own 120
# frames (2 s) for both. 256² is about 4–5 times the work of 128² per row: one repeat there keeps
# the whole run near a quarter of an hour (its 110 timed steps still average out short noise).
frames_128=120 frames_256=120 warmup=10
repeats_128=3 repeats_256=1
# 1-thread rows for 128² only (cheap there), for the parallel backends: gauss-seidel is
# sequential, so its 1-thread row would repeat its 2-thread one.
threads_128="1,2" threads_256="2"
if ((quick)); then
  scenes="128" frames_128=30 warmup=5 repeats_128=1 threads_128="2"
  ladder_1="5 10" ladder_2="5" ladder_10="1"
fi
[[ -n "$only" ]] && scenes=$only
if ((quick)) && [[ "$only" == 256 ]]; then frames_256=30; fi
if [[ -n "$repeats" ]]; then repeats_128=$repeats repeats_256=$repeats; fi

csv=$out/convergence.csv
header="scene,backend,substeps,iterations,threads,ms_per_step,sweep_cost,mean_strain,p99_strain,\
max_strain,recoveries,frames,warmup,repeats,projections_per_step,fine_sweep_projections,\
stretch_constraints,tether_constraints,nan_count,state_hash"
echo "$header" >"$tmp/rows.csv"
# A partial run keeps the other scenes' rows of an earlier run.
if [[ -n "$only" && -f "$csv" ]] && [[ "$(head -1 "$csv")" == "$header" ]]; then
  awk -F, -v keep="cloth_hang_$only" 'NR > 1 && $1 != keep' "$csv" >>"$tmp/rows.csv"
fi

# A constraint count from a `nucleon run --stats` file: its keys are sorted, so the first
# "stretch" and "tether" figures are those of the "constraints" object.
count() { grep -m1 -o "\"$1\": [0-9]*" "$tmp/info.json" | grep -o '[0-9]*$'; }

for n in $scenes; do
  scene=assets/scenes/cloth_hang_$n.json
  name=cloth_hang_$n
  frames_var=frames_$n threads_var=threads_$n repeats_var=repeats_$n
  frames=${!frames_var} threads=${!threads_var} repeats=${!repeats_var}
  # The constraint counts of the scene: one fine sweep projects every stretch and every tether
  # constraint once, so the sweep cost is the step's projections over that sum (a colored-gs
  # row at S × K = 10 costs 10.0).
  "$bin/nucleon" run "$scene" --frames 1 --threads 1 --quiet --stats "$tmp/info.json" >/dev/null
  stretch=$(count stretch) tether=$(count tether)
  fine=$((stretch + tether))
  echo "== $name: $frames frames ($warmup untimed), $stretch stretch + $tether tether constraints"
  for s in $substep_counts; do
    ladder_var=ladder_$s
    grep -q '"substeps": *[0-9]' "$scene" || { echo "$scene: no \"substeps\" key" >&2; exit 1; }
    sed "s/\"substeps\": *[0-9]*/\"substeps\": $s/" "$scene" >"$tmp/scene.json"
    sed 's/"substeps":/"smoother": "jacobi", "substeps":/' "$tmp/scene.json" >"$tmp/scene_jacobi.json"
    for k in ${!ladder_var}; do
      for b in $backends; do
        t=$threads solver=$b file=$tmp/scene.json
        [[ "$b" == gauss-seidel ]] && t=2
        [[ "$b" == multigrid-jacobi ]] && solver=multigrid file=$tmp/scene_jacobi.json
        "$bin/nucleon" bench "$file" --solver "$solver" --iterations "$k" --threads "$t" \
          --steps $((frames - warmup)) --warmup "$warmup" --repeats "$repeats" \
          --csv "$tmp/bench.csv" >/dev/null
        # Columns by name, so that columns added to the bench CSV later do not shift them.
        awk -F, -v OFS=, -v scene="$name" -v backend="$b" -v s="$s" -v frames="$frames" \
          -v warmup="$warmup" \
          -v fine="$fine" -v stretch="$stretch" -v tether="$tether" '
          NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
          {
            ms = $(col["ms_per_step"])
            # mprojections_per_s = projections / (ms/step · steps) · 10⁻³, so per step:
            proj = $(col["mprojections_per_s"]) * ms * 1e3
            print scene, backend, s, $(col["iterations"]), $(col["threads"]), ms,
              sprintf("%.3f", proj / fine), $(col["mean_strain"]), $(col["strain_p99"]),
              $(col["max_strain"]), $(col["recoveries"]), frames, warmup, $(col["repeats"]),
              sprintf("%.0f", proj), fine, stretch, tether, $(col["nan_count"]),
              $(col["state_hash"])
          }' "$tmp/bench.csv" | tee -a "$tmp/rows.csv" |
          awk -F, '{ printf "  %-12s S=%-2d K=%-2d T=%d  %8.3f ms/step  cost %6.2f  mean %.4f  p99 %.4f  max %.4f\n",
            $2, $3, $4, $5, $6, $7, $8, $9, $10 }'
      done
    done
  done
done
cp "$tmp/rows.csv" "$csv"

{
  echo "- Command: \`$command_line\`$( [[ -n "${NUCLEON_BENCH_BUILD:-}" ]] &&
    echo " with NUCLEON_BENCH_BUILD=$NUCLEON_BENCH_BUILD")"
  echo "- Machine: $cpu, $jobs cores visible; $(awk '/MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo);"
  echo "  $(c++ --version | head -1); load average before the run $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "- nucleon commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown); date $(date -u +%Y-%m-%d)"
  echo "- Measured this run, $warmup warm-up steps per row, $(($(date +%s) - started)) s in all:"
  for n in $scenes; do
    f=frames_$n r=repeats_$n
    echo "  cloth_hang_$n, ${!f} frames, ${!r} repeat(s) per row"
  done
} >"$out/convergence_run.md"

bash bench/convergence_report.sh "$out"
echo "results: $out ($(($(date +%s) - started)) s)"
