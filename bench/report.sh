#!/usr/bin/env bash
# Turns the CSV files scripts/bench.sh wrote into summary.md and the gnuplot PNGs, in the same
# folder. Needs awk and gnuplot only, so a results folder can be re-plotted anywhere.
#   bash bench/report.sh bench/results/<machine>
set -euo pipefail
dir=${1:?usage: report.sh RESULTS_DIR}
peer=$dir/peer.csv scaling=$dir/scaling.csv
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# peer.csv columns: 1 scene 2 bending 3 n 4 iterations 5 engine 6 solver 7 threads 8 repeats
# 9 ms_per_step 10 ms_min 11 forces 12 predict 13 solve 14 collisions 15 update 16 proj/s
# 17 max_strain 18 mean_strain 19 peak_max 20 average_mean 21 penetration 22 lowest_y 23 finite
peer_table() {  # $1 scene, $2 bending, $3 nucleon solver
  awk -F, -v scene="$1" -v bend="$2" -v solver="$3" '
    NR > 1 && $1 == scene && $2 == bend {
      key = $3 "," $4
      if ($5 == "bullet") { bms[key] = $9; bmax[key] = $17; bmean[key] = $18; bpeak[key] = $19 }
      else if ($6 == solver) {
        ratio = bms[key] > 0 ? bms[key] / $9 : 0
        met = (ratio >= 5 && $17 <= bmax[key]) ? "yes" : "no"
        printf "| %d | %d | %.2f | %.2f | **%.2f×** | %.3g / %.3f | %.3g / %.3f | %.3g / %.3g | %s |\n",
          $3, $4, bms[key], $9, ratio, bmax[key], bmean[key], $17, $18, bpeak[key], $19, met
      }
    }' "$peer"
}
peer_header='| N | K | Bullet ms/step | nucleon ms/step | Bullet / nucleon | Bullet max / mean strain | nucleon max / mean strain | peak max strain (Bullet / nucleon) | ≥ 5× at ≤ max strain |
|---|---|---|---|---|---|---|---|---|'

{
  echo "# nucleon benchmark results"
  echo
  cat "$dir/machine.md" | sed 's/^# Machine/## Machine/'
  echo
  echo "Cloth N×N vertices, 2 m, 1 kg, dt = 1/60 s, one substep, K iterations; nucleon on"
  echo "$(awk -F, '$5 == "nucleon" { print $7; exit }' "$peer") threads, Bullet single-threaded (its soft-body"
  echo "solver has no threads). Strain |L/L0 − 1| over the mesh edges after the last step"
  echo "(max / mean), and the largest max strain seen after any step (peak). ms/step: median of"
  echo "the repeats. See bench/README.md for how the two configurations correspond."
  echo
  echo "## Hanging cloth, structural links: nucleon colored-gs against Bullet"
  echo
  echo "$peer_header"
  peer_table hanging 0 colored-gs
  echo
  echo "## Hanging cloth, structural links: nucleon jacobi against Bullet"
  echo
  echo "$peer_header"
  peer_table hanging 0 jacobi
  echo
  echo "## Where nucleon's time goes (hanging, colored-gs; ms per step from the engine's profile)"
  echo
  echo "| N | K | step | forces | predict | solve | collisions | update | M projections/s |"
  echo "|---|---|---|---|---|---|---|---|---|"
  awk -F, 'NR > 1 && $1 == "hanging" && $2 == 0 && $6 == "colored-gs" {
    printf "| %d | %d | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.0f |\n",
      $3, $4, $9, $11, $12, $13, $14, $15, $16 / 1e6 }' "$peer"
  echo
  echo "## Hanging cloth with bending (Bullet: bending links at distance 2; nucleon: dihedral bending)"
  echo
  echo "$peer_header"
  peer_table hanging 1 colored-gs
  echo
  echo "## Cloth dropped on a sphere (r = 0.5 m at the origin)"
  echo
  echo "| N | K | engine | ms/step | Bullet / this | max / mean strain | peak max strain | deepest penetration (m) | lowest y (m) |"
  echo "|---|---|---|---|---|---|---|---|---|"
  awk -F, 'NR > 1 && $1 == "sphere" {
    key = $3 "," $4
    if ($5 == "bullet") bms[key] = $9
    ratio = bms[key] > 0 ? sprintf("%.2f×", bms[key] / $9) : "–"
    name = $5 == "bullet" ? "Bullet" : "nucleon " $6
    printf "| %d | %d | %s | %.2f | %s | %.3g / %.3f | %.3g | %.4f | %.2f |\n",
      $3, $4, name, $9, ratio, $17, $18, $19, $21, $22 }' "$peer"
  echo
  echo "Penetration below 0 means no vertex is inside the sphere's contact surface."
  echo
  echo "## Thread scaling (nucleon bench)"
  echo
  echo "| scene | solver | K | threads | ms/step | speedup | efficiency | M projections/s | state hash equal to 1 thread |"
  echo "|---|---|---|---|---|---|---|---|---|"
  awk -F, 'NR > 1 { printf "| %s | %s | %d | %d | %.3f | %.2f× | %.2f | %.0f | %s |\n",
    $1, $2, $3, $4, $8, $16, $17, $15, $21 == 1 ? "yes" : "NO" }' "$scaling"
  echo
  echo "## Scaling model"
  echo
  echo "Fitted per scene and backend by least squares to the measured points: T(p) = s + q/p"
  echo "(Amdahl: s is the time that does not shrink with threads — serial stages, the per-color"
  echo "barriers of the sweeps and memory bandwidth — q the part that divides). With only the"
  echo "thread counts this machine has, the fit has as many points as unknowns where p ≤ 2; the"
  echo "predictions beyond are extrapolations of this model, not measurements."
  echo
  echo "| scene | solver | s (ms) | q (ms) | serial fraction | predicted speedup 4 / 8 / 16 threads | limit |"
  echo "|---|---|---|---|---|---|---|"
  awk -F, 'NR > 1 {
      key = $1 "," $2; n[key]++; x = 1 / $4; y = $8
      sx[key] += x; sy[key] += y; sxx[key] += x * x; sxy[key] += x * y
      if (!(key in order)) { order[key] = ++count; keys[count] = key }
    }
    END {
      for (i = 1; i <= count; i++) {
        k = keys[i]; split(k, part, ",")
        d = n[k] * sxx[k] - sx[k] * sx[k]
        if (n[k] < 2 || d == 0) continue
        q = (n[k] * sxy[k] - sx[k] * sy[k]) / d; s = (sy[k] - q * sx[k]) / n[k]
        if (s < 0) s = 0
        if (q < 0) q = 0
        t1 = s + q; f = s / t1
        printf "| %s | %s | %.3f | %.3f | %.2f | %.2f / %.2f / %.2f | %s |\n", part[1], part[2],
          s, q, f, t1 / (s + q / 4), t1 / (s + q / 8), t1 / (s + q / 16),
          (f > 0 ? sprintf("%.1f×", 1 / f) : "∞")
        print part[1], part[2], s, q > "'"$tmp"'/model.dat"
      }
    }' "$scaling"
  echo
  echo "## Per-system Google Benchmarks (median of repeats)"
  echo
  echo "| benchmark | time | unit | what | throughput |"
  echo "|---|---|---|---|---|"
  awk -F, '
    $1 == "name" { split("", col); for (i = 1; i <= NF; i++) { h = $i; gsub(/"/, "", h); col[h] = i } next }
    $1 ~ /^"?BM_/ && $1 !~ /_(mean|stddev|cv)"?$/ {
      name = $1; gsub(/"/, "", name); sub(/_median$/, "", name)
      label = $(col["label"]); gsub(/"/, "", label)
      rate = ""
      if (col["projections/s"] && $(col["projections/s"]) != "")
        rate = sprintf("%.0f M projections/s", $(col["projections/s"]) / 1e6)
      else if (col["particles/s"] && $(col["particles/s"]) != "")
        rate = sprintf("%.0f M particles/s", $(col["particles/s"]) / 1e6)
      printf "| %s | %.1f | %s | %s | %s |\n", name, $(col["real_time"]), $(col["time_unit"]), label, rate
    }' "$dir"/systems_*.csv
} >"$dir/summary.md"

# Series for the plots.
awk -F, 'NR > 1 && $1 == "hanging" && $2 == 0 && $4 == 10 {
  name = $5 == "bullet" ? "bullet" : $6; print $3, $9 > "'"$tmp"'/n_" name ".dat" }' "$peer"
awk -F, 'NR > 1 && $1 == "hanging" && $2 == 0 {
  name = $5 == "bullet" ? "bullet" : $6
  print $4, $17 > "'"$tmp"'/k_" name "_" $3 ".dat" }' "$peer"
big=$(awk -F, 'NR > 1 && $1 ~ /^cloth_hang/ { if ($5 > m) { m = $5; s = $1 } } END { print s }' "$scaling")
awk -F, -v scene="$big" 'NR > 1 && $1 == scene { print $4, $16 > "'"$tmp"'/t_" $2 ".dat" }' "$scaling"
maxthreads=$(awk -F, 'NR > 1 && $4 > m { m = $4 } END { print (m > 16 ? m : 16) }' "$scaling")

plot_series() {  # $1 prefix, $2 suffix: "file" title "name" pairs for every file present
  local first=1 f name
  for f in "$tmp"/"$1"*"$2"; do
    [[ -e "$f" ]] || continue
    name=$(basename "$f" .dat)
    name=${name#"$1"}
    ((first)) || printf ', '
    printf "'%s' using 1:2 with linespoints lw 2 pt 7 title '%s'" "$f" "${name//_/ N=}"
    first=0
  done
}

gnuplot <<EOF
set terminal pngcairo size 900,600 font ",11" noenhanced
set grid
set key left top

set output "$dir/ms_vs_n.png"
set title "Hanging cloth, K = 10 iterations: ms per step (nucleon $(awk -F, '$5 == "nucleon" { print $7; exit }' "$peer") threads, Bullet 1)"
set xlabel "N (cloth of N×N vertices)"
set ylabel "ms / step"
set logscale xy
set xrange [50:330]
set xtics (64, 128, 256)
plot $(plot_series n_ .dat)

set output "$dir/strain_vs_iterations.png"
set title "Hanging cloth: max strain after 2 s against iterations"
set xlabel "K (iterations per step)"
set ylabel "max strain |L/L0 - 1|"
set logscale x
set xtics (4, 10, 20)
set xrange [3.5:23]
set key outside right
plot $(plot_series k_ .dat)

set output "$dir/speedup.png"
set title "$big: speedup against threads (points: measured; lines: fitted T(p) = s + q/p)"
set xlabel "threads"
set ylabel "speedup over 1 thread"
unset logscale
set xtics auto
set key left top inside
set xrange [1:$maxthreads]
$(while read -r scene solver s q; do
  [[ "$scene" == "$big" ]] && echo "s_${solver//-/_} = $s; q_${solver//-/_} = $q"
done <"$tmp/model.dat")
plot x with lines dt 2 lc rgb "gray" title "ideal" \
$(for f in "$tmp"/t_*.dat; do
  [[ -e "$f" ]] || continue
  s=$(basename "$f" .dat); s=${s#t_}; v=${s//-/_}
  printf ", '%s' using 1:2 with points pt 7 ps 1.5 title '%s'" "$f" "$s"
  printf ", (s_%s + q_%s) / (s_%s + q_%s / x) with lines lw 2 title '%s model'" "$v" "$v" "$v" "$v" "$s"
done)
EOF
echo "wrote $dir/summary.md and plots"
