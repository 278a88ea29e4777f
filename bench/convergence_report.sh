#!/usr/bin/env bash
# Turns the convergence.csv that scripts/bench_convergence.sh wrote into convergence.md and the
# gnuplot PNGs convergence_<N>.png, in the same folder. Needs awk, sort and gnuplot only, so a
# results folder can be redrawn anywhere.
#   bash bench/convergence_report.sh bench/results/<machine>
set -euo pipefail
dir=${1:?usage: convergence_report.sh RESULTS_DIR}
csv=$dir/convergence.csv
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# convergence.csv columns: 1 scene 2 backend 3 substeps 4 iterations 5 threads 6 ms_per_step
# 7 sweep_cost 8 mean_strain 9 p99_strain 10 max_strain 11 recoveries 12 frames 13 warmup
# 14 repeats 15 projections_per_step 16 fine_sweep_projections 17 stretch_constraints
# 18 tether_constraints 19 nan_count 20 state_hash
# Rows with a sort key in front (scene, backend in the order below, substeps, then $1 and $2 of
# the caller), the key cut off again: mawk has no sort of its own.
rank='BEGIN { r["gauss-seidel"] = 1; r["jacobi"] = 2; r["colored-gs"] = 3; r["multigrid"] = 4
  r["multigrid-jacobi"] = 5 }'
sorted() {  # $1: awk condition on the rows; $2: the last two keys as awk expressions
  awk -F, "$rank NR > 1 && ($1) { k = r[\$2]; if (k == \"\") k = 9
    printf \"%s,%d,%04d,%s,%s,%s\\n\", \$1, k, \$3, $2, \$0 }" "$csv" |
    sort -t, -k1,1 -k2,2n -k3,3n -k4,4g -k5,5g | cut -d, -f6-
}
# The thread count the derived tables and plots use: 2 (the target), or the largest measured.
threads=$(awk -F, 'NR > 1 { if ($5 == 2) two = 1; if ($5 > m) m = $5 }
  END { print two ? 2 : m }' "$csv")
sorted "\$5 == $threads" '$6, $4' >"$tmp/by_ms.csv"
sorted "\$5 == $threads" '$4, $5' >"$tmp/by_k.csv"
# The equal-time reference of each scene and substep count: colored-gs at S × K = 10.
awk -F, -v OFS=, '$2 == "colored-gs" && $3 * $4 == 10 { print $1, $3, $6 }' "$tmp/by_ms.csv" \
  >"$tmp/ref.csv"

{
  echo "# Convergence of the solver backends: hanging cloth"
  echo
  [[ -f "$dir/convergence_run.md" ]] && cat "$dir/convergence_run.md" && echo
  echo "Scenes cloth_hang_128 and cloth_hang_256: a 2 m cloth of N×N vertices hanging from two"
  echo "corners, inextensible (stretch and compression compliance 0), tethers on, 60 steps a second."
  echo "Every row is one \`nucleon bench\` of the scene with \`solver.substeps\` set to S, \`--solver B"
  echo "--iterations K\` (K sweeps of each family per substep; multigrid: K colored Gauss–Seidel fine"
  echo "sweeps after its coarse-to-fine cascade, the scene's sweeps per coarse level; multigrid-jacobi:"
  echo "the same with K Jacobi fine sweeps, the scene's \`smoother\` set to jacobi), the frame count"
  echo "run from a fresh world with the first steps untimed; ms/step is the median of the repeats."
  echo "Strain |L/L0 − 1| of the stretch constraints after the last frame (mean, 99th percentile,"
  echo "max). Sweep cost: constraint projections per step (the engine's count, the multigrid"
  echo "cascade's coarse projections included) over the projections of one fine sweep (every"
  echo "stretch and every tether constraint once), so colored-gs at S × K = 10 costs 10.0."
  echo "gauss-seidel is sequential: its rows are at one thread whatever the thread count."
  echo
  awk -F, 'NR > 1 && !seen[$1]++ {
    printf "- %s: %d frames (%d untimed), %d repeat(s) per row, %d stretch + %d tether constraints\n",
      $1, $12, $13, $14, $17, $18 }' "$csv"
  for scene in $(awk -F, 'NR > 1 { print $1 }' "$csv" | sort -u); do
    echo
    echo "## $scene"
    echo
    echo "| backend | S × K | threads | ms/step | sweep cost | mean strain | p99 strain | max strain | recoveries |"
    echo "|---|---|---|---|---|---|---|---|---|"
    sorted "\$1 == \"$scene\"" '$4, $5' | awk -F, '{
      printf "| %s | %d × %d | %d | %.3f | %.2f | %.4f | %.4f | %.4f | %d |\n",
        $2, $3, $4, $5, $6, $7, $8, $9, $10, $11 }'
  done
  echo
  echo "## Time to a mean strain below 1% ($threads threads)"
  echo
  echo "The smallest measured ms/step among the rows of the ladder that leave a mean strain below"
  echo "0.01 (no interpolation)."
  echo
  echo "| scene | backend | substeps | ms/step | row (S × K) | sweep cost | mean strain |"
  echo "|---|---|---|---|---|---|---|"
  awk -F, '
    function flush() {
      if (key == "") return
      if (hit != "") print hit
      else printf "| %s | %s | %d | not reached in the ladder | lowest mean: %d × %d | %.2f | %.4f |\n",
        scene, backend, s, s, bestk, bestcost, best
    }
    {
      k = $1 "," $2 "," $3
      if (k != key) { flush(); key = k; scene = $1; backend = $2; s = $3; hit = ""; best = "" }
      if (hit == "" && $8 < 0.01)  # rows come by ms/step: the first below 1% is the fastest
        hit = sprintf("| %s | %s | %d | %.3f | %d × %d | %.2f | %.4f |", $1, $2, $3, $6, $3, $4,
          $7, $8)
      if (best == "" || $8 < best) { best = $8; bestk = $4; bestcost = $7 }
    }
    END { flush() }' "$tmp/by_ms.csv" | sort -t'|' -s -k2,2 -k4,4n
  echo
  echo "## Strain at the wall time of 10 colored-gs sweeps ($threads threads)"
  echo
  echo "The reference time t is the ms/step of colored-gs at S × K = 10 with the same substep"
  echo "count. Each backend's mean and p99 strain at t are interpolated linearly in log(strain)"
  echo "against log(ms/step) between the two rows of its ladder (ordered by ms/step) whose times"
  echo "bracket t; where no two rows bracket t, the nearest row is named instead. Last column:"
  echo "colored-gs's mean at t over the backend's (above 1: the backend does better in that time)."
  echo
  echo "| scene | substeps | t (ms/step) | backend | mean strain at t | p99 strain at t | how | colored-gs mean / this |"
  echo "|---|---|---|---|---|---|---|---|"
  awk -F, '
    FNR == NR { ref[$1 "," $2] = $3; next }
    function flush(   t, i, f, m, p, how, lo, hi) {
      if (key == "" || !((scene "," s) in ref)) return
      t = ref[scene "," s]
      m = ""
      if (t < ms[1])
        how = sprintf("not reached: the fastest row, %d × %d, takes %.3f ms (mean %.4f)", s, kk[1],
          ms[1], mean[1])
      else if (t > ms[n])
        how = sprintf("beyond the ladder: the slowest row, %d × %d, takes %.3f ms (mean %.4f)", s,
          kk[n], ms[n], mean[n])
      else
        for (i = 1; i <= n; i++) {
          if (ms[i] == t) { m = mean[i]; p = p99[i]; how = sprintf("row %d × %d", s, kk[i]); break }
          if (i < n && ms[i] < t && t < ms[i + 1]) {
            f = (log(t) - log(ms[i])) / (log(ms[i + 1]) - log(ms[i]))
            m = exp(log(mean[i]) + f * (log(mean[i + 1]) - log(mean[i])))
            p = exp(log(p99[i]) + f * (log(p99[i + 1]) - log(p99[i])))
            how = sprintf("between %d × %d and %d × %d", s, kk[i], s, kk[i + 1])
            break
          }
        }
      if (backend == "colored-gs" && m != "") cgs[scene "," s] = m
      line[++lines] = scene SUBSEP s SUBSEP t SUBSEP backend SUBSEP m SUBSEP p SUBSEP how
    }
    {
      k = $1 "," $2 "," $3
      if (k != key) { flush(); key = k; scene = $1; backend = $2; s = $3; n = 0 }
      n++; ms[n] = $6; mean[n] = $8; p99[n] = $9; kk[n] = $4
    }
    END {
      flush()
      for (i = 1; i <= lines; i++) {
        split(line[i], v, SUBSEP)
        if (v[5] == "") {
          printf "| %s | %d | %.3f | %s | – | – | %s | – |\n", v[1], v[2], v[3], v[4], v[7]
          continue
        }
        ratio = "–"
        c = cgs[v[1] "," v[2]]
        if (c != "" && v[5] > 0) ratio = sprintf("%.2f", c / v[5])
        printf "| %s | %d | %.3f | %s | %.4f | %.4f | %s | %s |\n", v[1], v[2], v[3], v[4], v[5],
          v[6], v[7], ratio
      }
    }' "$tmp/ref.csv" "$tmp/by_ms.csv" | sort -t'|' -s -k2,2 -k3,3n
  echo
  echo "Plots: convergence_<N>.png, one row of panels per substep count: mean strain against"
  echo "ms/step (the dotted line: t above) and against sweep cost, p99 strain against ms/step."
} >"$dir/convergence.md"

# Series for the plots: one file per scene, substep count and backend, in ladder order.
awk -F, -v tmp="$tmp" '{ print $6, $7, $8, $9 > (tmp "/s_" $1 "_" $3 "_" $2 ".dat") }' "$tmp/by_k.csv"
color() {
  case "$1" in
    gauss-seidel) echo "#1f77b4" ;; jacobi) echo "#d62728" ;;
    colored-gs) echo "#2ca02c" ;; multigrid) echo "#9467bd" ;;
    multigrid-jacobi) echo "#ff7f0e" ;; *) echo "#555555" ;;
  esac
}
series() {  # $1 scene, $2 substeps, $3 x column, $4 y column: one curve per backend; $5 "1%"
  # draws the 1% line of the time-to-1% table
  local first=1 b f
  for b in gauss-seidel jacobi colored-gs multigrid multigrid-jacobi; do
    f=$tmp/s_$1_$2_$b.dat
    [[ -e "$f" ]] || continue
    ((first)) || printf ', '
    printf "'%s' using %d:%d with linespoints lw 2 pt 7 lc rgb '%s' title '%s'" "$f" "$3" "$4" \
      "$(color "$b")" "$b"
    first=0
  done
  [[ "${5:-}" == "1%" ]] && printf ", 0.01 with lines dt 2 lw 1.5 lc rgb '#606060' title 'mean 1%%'"
  return 0
}
for scene in $(awk -F, 'NR > 1 { print $1 }' "$csv" | sort -u); do
  counts=$(awk -F, -v scene="$scene" '$1 == scene { print $3 }' "$tmp/by_k.csv" | sort -n -u)
  [[ -n "$counts" ]] || continue
  rows=$(echo "$counts" | wc -l)
  frames=$(awk -F, -v scene="$scene" '$1 == scene { print $12; exit }' "$tmp/by_k.csv")
  {
    echo "set terminal pngcairo size 1650,$((430 * rows + 60)) font ',10' noenhanced"
    echo "set output '$dir/convergence_${scene#cloth_hang_}.png'"
    echo "set multiplot layout $rows,3 title '$scene, $frames frames, $threads threads: strain after the last frame'"
    echo "set grid; set logscale xy; set key right top; set format y '%g'"
    for s in $counts; do
      t=$(awk -F, -v scene="$scene" -v s="$s" '$1 == scene && $2 == s { print $3 }' "$tmp/ref.csv")
      echo "unset arrow"
      [[ -n "$t" ]] && echo "set arrow from $t, graph 0 to $t, graph 1 nohead dt 3 lc rgb 'black'"
      echo "set title 'S = $s: mean strain against time'; set xlabel 'ms / step'; set ylabel 'mean strain'"
      echo "plot $(series "$scene" "$s" 1 3 1%)"
      echo "unset arrow"
      echo "set title 'S = $s: mean strain against sweep cost'; set xlabel 'sweep cost (fine sweeps per step)'"
      echo "plot $(series "$scene" "$s" 2 3 1%)"
      [[ -n "$t" ]] && echo "set arrow from $t, graph 0 to $t, graph 1 nohead dt 3 lc rgb 'black'"
      echo "set title 'S = $s: p99 strain against time'; set xlabel 'ms / step'; set ylabel 'p99 strain'"
      echo "plot $(series "$scene" "$s" 1 4)"
    done
    echo "unset multiplot"
  } >"$tmp/plot.gp"
  gnuplot "$tmp/plot.gp"
done
echo "wrote $dir/convergence.md and plots"
