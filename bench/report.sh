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
# 24 state_hash 25 tethers (on, off, none) 26 p99_strain (files from before the tethers and p99
# columns: tethers were on, p99 is shown as –)
peer_rows() {  # $1 scene, $2 bending, $3 nucleon solver: Bullet's row, then that solver's rows
  awk -F, -v scene="$1" -v bend="$2" -v solver="$3" '
    NR > 1 && $1 == scene && $2 == bend && ($5 == "bullet" || $6 == solver) {
      key = $3 "," $4
      if ($5 == "bullet") bms[key] = $9
      ratio = "–"
      if (bms[key] > 0) ratio = sprintf("%.2f×", bms[key] / $9)
      name = "nucleon " $6
      if ($5 == "bullet") name = "Bullet"
      tethers = $25
      if (tethers == "") tethers = $5 == "bullet" ? "none" : "on"
      p99 = $26 == "" ? "–" : sprintf("%.3g", $26)
      printf "| %d | %d | %s | %s | %.2f | %s | %.3g / %.3f / %s | %.3g |\n",
        $3, $4, name, tethers, $9, ratio, $17, $18, p99, $19
    }' "$peer"
}
peer_header='| N | K | engine | tethers | ms/step | Bullet / this | max / mean / p99 strain | peak max strain |
|---|---|---|---|---|---|---|---|'

{
  echo "# nucleon benchmark results"
  echo
  cat "$dir/machine.md" | sed 's/^# Machine/## Machine/'
  echo
  echo "Cloth N×N vertices, 2 m, 1 kg, dt = 1/60 s, one substep, K iterations; nucleon on"
  echo "$(awk -F, '$5 == "nucleon" { print $7; exit }' "$peer") threads, Bullet single-threaded (its soft-body"
  echo "solver has no threads). Strain |L/L0 − 1| over the mesh edges after the last step"
  echo "(max / mean), and the largest max strain seen after any step (peak). ms/step: median of"
  echo "the repeats; p99: the 99th percentile of the strain after the last step (nearest rank)."
  echo "See bench/README.md for how the two configurations correspond."
  echo
  echo "Bullet's cloth has no long-range attachments. nucleon's pinned cloth has tethers by default"
  echo "(one per free vertex and pin, a unilateral limit on the distance to the pin), so every"
  echo "hanging case shows nucleon twice: tethers on (nucleon as it ships; the tethers' projections"
  echo "are in its time) and tethers off (exactly Bullet's constraint set: one distance constraint"
  echo "per mesh edge). 'none': the engine or the cloth has no tethers."
  echo
  echo "## Headline: hanging cloth, structural links, nucleon colored-gs (the README's table)"
  echo
  echo "| N | K | Bullet ms/step | nucleon ms/step, tethers on / off | Bullet / nucleon, tethers on / off | Bullet max / mean / p99 strain | nucleon tethers on | nucleon tethers off |"
  echo "|---|---|---|---|---|---|---|---|"
  awk -F, 'NR > 1 && $1 == "hanging" && $2 == 0 && $3 >= 128 && ($5 == "bullet" || $6 == "colored-gs") {
      key = $3 "," $4
      if (!(key in seen)) { seen[key] = 1; keys[++count] = key }
      figures = sprintf("%.3g / %.3g / %.3g", $17, $18, $26)
      if ($5 == "bullet") { bms[key] = $9; bstrain[key] = figures }
      else if ($25 == "off") { offms[key] = $9; offstrain[key] = figures }
      else { onms[key] = $9; onstrain[key] = figures }
    }
    END {
      for (i = 1; i <= count; i++) {
        k = keys[i]; split(k, part, ",")
        if (!(k in bms) || !(k in onms) || !(k in offms)) continue
        printf "| %d | %d | %.2f | %.2f / %.2f | %.1f× / %.1f× | %s | %s | %s |\n", part[1], part[2],
          bms[k], onms[k], offms[k], bms[k] / onms[k], bms[k] / offms[k], bstrain[k], onstrain[k],
          offstrain[k]
        printed++
      }
      if (!printed) print "\n(No N ≥ 128 case in this file has nucleon runs with the tethers both on and off.)"
    }' "$peer"
  echo
  echo "## Hanging cloth, structural links: nucleon colored-gs against Bullet"
  echo
  echo "$peer_header"
  peer_rows hanging 0 colored-gs
  echo
  echo "## Hanging cloth, structural links: nucleon jacobi against Bullet"
  echo
  echo "$peer_header"
  peer_rows hanging 0 jacobi
  echo
  echo "## Hanging cloth, structural links: nucleon multigrid against Bullet"
  echo
  echo "$peer_header"
  peer_rows hanging 0 multigrid
  echo
  echo "## Where nucleon's time goes (hanging, colored-gs; ms per step from the engine's profile)"
  echo
  echo "| N | K | tethers | step | forces | predict | solve | collisions | update | M projections/s |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  awk -F, 'NR > 1 && $1 == "hanging" && $2 == 0 && $6 == "colored-gs" {
    printf "| %d | %d | %s | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.0f |\n",
      $3, $4, ($25 == "" ? "on" : $25), $9, $11, $12, $13, $14, $15, $16 / 1e6 }' "$peer"
  echo
  echo "## Hanging cloth with bending (Bullet: bending links at distance 2; nucleon: dihedral bending)"
  echo
  echo "$peer_header"
  peer_rows hanging 1 colored-gs
  echo
  echo "## Cloth dropped on a sphere (r = 0.5 m at the origin)"
  echo
  echo "| N | K | engine | ms/step | Bullet / this | max / mean / p99 strain | peak max strain | deepest penetration (m) | lowest y (m) |"
  echo "|---|---|---|---|---|---|---|---|---|"
  awk -F, 'NR > 1 && $1 == "sphere" {
    key = $3 "," $4
    if ($5 == "bullet") bms[key] = $9
    ratio = "–"
    if (bms[key] > 0) ratio = sprintf("%.2f×", bms[key] / $9)
    name = "nucleon " $6
    if ($5 == "bullet") name = "Bullet"
    p99 = $26 == "" ? "–" : sprintf("%.3g", $26)
    printf "| %d | %d | %s | %.2f | %s | %.3g / %.3f / %s | %.3g | %.4f | %.2f |\n",
      $3, $4, name, $9, ratio, $17, $18, p99, $19, $21, $22 }' "$peer"
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
  echo "barriers of the sweeps and memory bandwidth — q the part that divides). The speedups at"
  echo "4, 8 and 16 threads are not measurements: they extrapolate the fit beyond the thread"
  echo "counts in the 'fitted on' column. Fitted on 1 and 2 threads only, the model has two"
  echo "unknowns for two points, so it fits exactly whatever the cost of a barrier does as threads"
  echo "are added; that cost and the memory bandwidth only grow with p, so such an extrapolation"
  echo "is an upper bound, to be checked with \`nucleon bench --threads 1,2,4,8,16\` on a larger"
  echo "machine."
  echo
  echo "| scene | solver | fitted on (threads) | s (ms) | q (ms) | serial fraction | extrapolated speedup 4 / 8 / 16 threads | Amdahl limit (extrapolated) |"
  echo "|---|---|---|---|---|---|---|---|"
  awk -F, 'NR > 1 {
      key = $1 "," $2; n[key]++; x = 1 / $4; y = $8
      sx[key] += x; sy[key] += y; sxx[key] += x * x; sxy[key] += x * y
      if (!(key in lo) || $4 < lo[key]) lo[key] = $4
      if (!(key in hi) || $4 > hi[key]) hi[key] = $4
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
        t1 = s + q
        if (t1 <= 0) continue
        f = s / t1
        # Decided before the printf: a comparison inside a print list would be a redirection.
        limit = "none (no serial part)"
        if (f > 0) limit = sprintf("%.1f×", 1 / f)
        fitted = n[k] == 2 ? sprintf("%d and %d only: upper bound", lo[k], hi[k]) : sprintf("%d to %d", lo[k], hi[k])
        printf "| %s | %s | %s | %.3f | %.3f | %.2f | %.2f / %.2f / %.2f | %s |\n", part[1], part[2],
          fitted, s, q, f, t1 / (s + q / 4), t1 / (s + q / 8), t1 / (s + q / 16), limit
        print part[1], part[2], s, q > "'"$tmp"'/model.dat"
      }
    }' "$scaling"
  echo
  echo "## Per-system Google Benchmarks (median of repeats, wall-clock time)"
  echo
  echo "BM_Sweep: one sweep of one family, every timed sweep from the same predicted state with"
  echo "the multipliers at zero (restored outside the timing); 'projected': the constraints that"
  echo "sweep had to correct (a satisfied tether is only tested). BM_Contacts: contact detection"
  echo "and one projection of the contact pool; 'inside' counts particles inside a contact surface"
  echo "before the projection and after it."
  echo
  echo "| benchmark | time | unit | what | throughput | counts |"
  echo "|---|---|---|---|---|---|"
  awk -F, '
    $1 == "name" { split("", col); for (i = 1; i <= NF; i++) { h = $i; gsub(/"/, "", h); col[h] = i } next }
    $1 ~ /^"?BM_/ && $1 !~ /_(mean|stddev|cv)"?$/ {
      name = $1; gsub(/"/, "", name); sub(/_median$/, "", name); sub(/\/real_time$/, "", name)
      label = $(col["label"]); gsub(/"/, "", label)
      rate = ""
      if (col["projections/s"] && $(col["projections/s"]) != "")
        rate = sprintf("%.0f M projections/s", $(col["projections/s"]) / 1e6)
      else if (col["particles/s"] && $(col["particles/s"]) != "")
        rate = sprintf("%.0f M particles/s", $(col["particles/s"]) / 1e6)
      counts = ""
      if (col["active"] && $(col["active"]) != "")
        counts = sprintf("%d of %d projected", $(col["active"]), $(col["constraints"]))
      else if (col["contacts"] && $(col["contacts"]) != "")
        counts = sprintf("%d contacts; inside %d, after %d", $(col["contacts"]), $(col["inside"]),
          $(col["inside_after"]))
      printf "| %s | %.1f | %s | %s | %s | %s |\n", name, $(col["real_time"]), $(col["time_unit"]),
        label, rate, counts
    }' "$dir"/systems_*.csv
} >"$dir/summary.md"

# Series for the plots: one file per engine configuration, named bullet or SOLVER+tethers-on|off
# (and @N for the strain series); plot_series turns the name into the title.
awk -F, 'NR > 1 && $1 == "hanging" && $2 == 0 && $4 == 10 {
  name = "bullet"
  if ($5 != "bullet") name = $6 "+tethers-" ($25 == "" ? "on" : $25)
  print $3, $9 > "'"$tmp"'/n_" name ".dat" }' "$peer"
awk -F, 'NR > 1 && $1 == "hanging" && $2 == 0 {
  name = "bullet"
  if ($5 != "bullet") name = $6 "+tethers-" ($25 == "" ? "on" : $25)
  print $4, $17 > "'"$tmp"'/k_" name "@" $3 ".dat" }' "$peer"
big=$(awk -F, 'NR > 1 && $1 ~ /^cloth_hang/ { if ($5 > m) { m = $5; s = $1 } } END { print s }' "$scaling")
awk -F, -v scene="$big" 'NR > 1 && $1 == scene { print $4, $16 > "'"$tmp"'/t_" $2 ".dat" }' "$scaling"
maxthreads=$(awk -F, 'NR > 1 && $4 > m { m = $4 } END { print (m > 16 ? m : 16) }' "$scaling")

plot_series() {  # $1 prefix, $2 suffix: "file" title "name" pairs for every file present
  local first=1 f name
  for f in "$tmp"/"$1"*"$2"; do
    [[ -e "$f" ]] || continue
    name=$(basename "$f" .dat)
    name=${name#"$1"}
    name=${name//+/ }
    ((first)) || printf ', '
    printf "'%s' using 1:2 with linespoints lw 2 pt 7 title '%s'" "$f" "${name//@/ N=}"
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
set title "$big: speedup against threads\npoints: measured; lines: T(p) = s + q/p fitted on them, extrapolated beyond them (an upper bound)"
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
  printf ", (s_%s + q_%s) / (s_%s + q_%s / x) with lines lw 2 title '%s model, extrapolated'" "$v" "$v" "$v" "$v" "$s"
done)
EOF
echo "wrote $dir/summary.md and plots"
