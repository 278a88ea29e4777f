#!/usr/bin/env bash
# The torture scenes (assets/scenes/torture/, its large meshes in large/ and the cases not clean
# yet in unsolved/):
# cloth on sharp, moving colliders at the scenes' default substeps, each run through
# `nucleon run` for all of its frames; one line per scene with what keeps it from being clean
# (the stats' `failures`), the fail-safe's work and ms/step.
#
#   bash scripts/torture.sh [BINARY] [THREADS]
set -euo pipefail
cd "$(dirname "$0")/.."
binary=${1:-build/nucleon}
threads=${2:-2}
stats=$(mktemp)
trap 'rm -f "$stats"' EXIT
for scene in assets/scenes/torture/*.json assets/scenes/torture/large/*.json \
  assets/scenes/torture/unsolved/*.json; do
  "$binary" run "$scene" --threads "$threads" --stats "$stats" --quiet >/dev/null
  python3 - "$stats" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
f, c = d["failures"], d["collisions"]
print(f'{d["scene"]}: {"clean" if f["clean"] else "NOT CLEAN"}, {d["ms_per_step"]:.1f} ms/step, '
      f'frames with intersections {f["frames_with_intersections"]} (most {f["max_intersections"]}), '
      f'overstretched frames {f["overstretched_frames"]}, frames with particles inside colliders '
      f'{f["frames_inside_colliders"]}, worst frame max strain '
      f'{f["worst_frame_max_strain"]:.3f}, end max strain {d["max_strain"]:.3f}, unresolved '
      f'{f["unresolved_crossing_pairs"]}, crossings {c["crossings_stopped"]}, carried '
      f'{c["carried_particles"]} of {c["stopped_particles"]} held particles, impact zones '
      f'{c["impact_zones"]} ({c["stopped_impact_zones"]} stopped), state {d["state_hash"]}')
PY
done
