#!/usr/bin/env bash
# The collision benchmark: every bundled collision scene through the scene runner
# (`nucleon run SCENE --stats`), all of its frames, at 1 and 2 threads, one CSV row per run:
# ms/step split by stage, candidate pairs and contacts per substep, broad-phase runs (full and
# incremental), fail-safe work, intersections, recoveries, strain and the state hash.
#
#   bash scripts/bench_collisions.sh [BINARY] [OUT.csv] [LABEL]
#
# BINARY defaults to build/nucleon, OUT to bench/results/<machine>/collision_scenes.csv; LABEL
# (default "current") names the code the rows are of, so that runs of two builds can share one
# file (rows are appended).
set -euo pipefail
cd "$(dirname "$0")/.."
binary=${1:-build/nucleon}
out=${2:-bench/results/2core-AMD-EPYC/collision_scenes.csv}
label=${3:-current}
scenes=(cloth_self cloth_drop_sphere bullet_cloth rope_pile cloth_twist kinematic_spin cloth_free_fall)
stats=$(mktemp)
trap 'rm -f "$stats"' EXIT

if [[ ! -s "$out" ]]; then
  echo "code,scene,threads,steps,substeps,ms_per_step,broad_phase_ms,narrow_phase_ms,contacts_and_failsafe_ms,solve_ms,collision_share,candidate_pairs_per_substep,contacts_per_substep,broad_phases,incremental_broad_phases,refreshes,solve_redetections,stopped_particles,unresolved_pairs,max_intersections,recoveries,strain_mean,strain_p99,strain_max,frame_strain_max,state_hash" >"$out"
fi
for scene in "${scenes[@]}"; do
  for threads in 1 2; do
    "$binary" run "assets/scenes/$scene.json" --threads "$threads" --stats "$stats" --quiet >/dev/null
    python3 - "$stats" "$label" "$scene" "$threads" >>"$out" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
label, scene, threads = sys.argv[2:5]
c, p = d["collisions"], d["profile_ms_per_step"]
substeps = max(1, d["steps"] * d["substeps"])
collide = p["broad_phase"] + p["narrow_phase"] + p["collisions"]
frames = d["per_frame"]
print(",".join(str(v) for v in [
    label, scene, threads, d["steps"], d["substeps"], round(d["ms_per_step"], 2),
    round(p["broad_phase"], 2), round(p["narrow_phase"], 2), round(p["collisions"], 2),
    round(p["solve"], 2), round(collide / d["ms_per_step"], 3),
    c["candidate_pairs"] // substeps, c["contacts"] // substeps, c["broad_phases"],
    c.get("incremental_broad_phases", 0), c["broad_phase_refreshes"], c["solve_redetections"],
    c["stopped_particles"], c["unresolved_pairs"], max(f["intersections"] for f in frames),
    d["recoveries"], round(d["mean_strain"], 4), round(d["strain_p99"], 4),
    round(d["max_strain"], 4), round(max(f["max_strain"] for f in frames), 4),
    d["state_hash"]]))
EOF
    echo "$label $scene $threads threads: $(tail -1 "$out" | cut -d, -f6) ms/step" >&2
  done
done
