#!/usr/bin/env bash
# `nucleon sweep` on a 2 × 2 grid, three ways: run here in parallel processes, written out and
# run by GNU parallel, and gathered; every run must succeed with the settings it names, and the
# same settings must give the same state whichever way they ran.
set -euo pipefail
nucleon=$1
scene=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

fail() { echo "FAIL: $*" >&2; exit 1; }

# Local: 4 runs, 2 at a time.
"$nucleon" sweep "$scene" --set solver.iterations=2,4 --set solver.substeps=1,2 --frames 3 \
  --jobs 2 --out "$work/local" > "$work/local.out" 2> "$work/local.err" || fail "local sweep: $(cat "$work/local.err")"
csv=$work/local/results.csv
[[ $(wc -l < "$csv") -eq 5 ]] || fail "expected a header and 4 rows in $csv"
head -1 "$csv" | grep -q '^run,solver.iterations,solver.substeps,status,clean,ms_per_step' \
  || fail "header: $(head -1 "$csv")"
[[ $(grep -c ',ok,1,' "$csv") -eq 4 ]] || fail "not every run ok and clean: $(cat "$csv")"
# Four settings, four states; the row with 4 iterations and 2 substeps is a plain run's.
[[ $(cut -d, -f15 "$csv" | tail -n +2 | sort -u | wc -l) -eq 4 ]] || fail "state hashes not distinct"
row=$(grep '^run_0003,' "$csv")
[[ $row == run_0003,4,2,* ]] || fail "grid order: $row"
plain=$("$nucleon" run "$scene" --quiet --frames 3 --threads 1 --set solver.iterations=4 \
  --set solver.substeps=2 | grep -o 'state [0-9a-f]*' | cut -d' ' -f2)
[[ $row == *",$plain" ]] || fail "run_0003 ($row) is not the plain run's state $plain"

# Emitted, run by GNU parallel, gathered.
"$nucleon" sweep "$scene" --set solver.iterations=2,4 --set solver.substeps=1,2 --frames 3 \
  --emit --out "$work/emitted" > /dev/null
[[ $(wc -l < "$work/emitted/jobs.txt") -eq 4 ]] || fail "jobs.txt"
grep -q '^#SBATCH --array=0-3$' "$work/emitted/slurm.sh" || fail "slurm.sh array"
bash -n "$work/emitted/slurm.sh" || fail "slurm.sh is not valid bash"
command -v parallel > /dev/null || fail "GNU parallel is not installed (scripts/deps.sh installs it)"
parallel --will-cite --jobs 2 < "$work/emitted/jobs.txt" || fail "GNU parallel run"
"$nucleon" sweep --gather "$work/emitted" --csv "$work/gathered.csv" > /dev/null \
  || fail "gather: $(cat "$work/gathered.csv")"
# The same settings give the same states whichever way they ran (timings differ).
diff <(cut -d, -f1-5,15 "$csv") <(cut -d, -f1-5,15 "$work/gathered.csv") \
  || fail "the parallel runs' states differ from the local ones"

# A gathered run that failed is reported and makes the exit status 1.
rm "$work/emitted/run_0001.json"
echo "nucleon: an error" > "$work/emitted/run_0001.log"
if "$nucleon" sweep --gather "$work/emitted" --csv "$work/partial.csv" > /dev/null; then
  fail "a failed run did not fail the gather"
fi
grep -q '^run_0001,2,2,failed,' "$work/partial.csv" || fail "failed run row: $(cat "$work/partial.csv")"
echo "sweep: local, GNU parallel and gather agree"
