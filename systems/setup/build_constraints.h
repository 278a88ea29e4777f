// Creates an object's constraints from its simplicial complex and rest shape: which simplices a
// family acts on, with rest values measured by the family's own kernel.
#pragma once

#include <span>

#include "components/constraint_pools.h"
#include "components/simplicial_complex.h"
#include "nucleon/object_def.h"

namespace nucleon {

// Appends the constraints of one object whose particles start at `first`:
//  - stretch on every edge (not for colliders);
//  - cloth: shear at each triangle corner and bend on each interior edge's hinge, if enabled;
//  - rope: bend at each pair of segments sharing a vertex, twist on each run of three segments
//    whose rest shape is not straight, if enabled;
//  - solid: volume on each tetrahedron;
//  - cloth and rope with pins and inextensible stretch (compliance 0) or a strain limit
//    (Material::stretchLimit), if enabled: long-range attachments (Kim, Chentanez and Müller
//    2012), unilateral and hard. Pins joined by edges form a cluster; each free vertex is
//    tethered to the nearest pin of each of its four nearest clusters (Dijkstra along the edges),
//    leaving out a cluster whose pin is close to the nearest one as seen from the vertex, with the
//    geodesic distance in the rest shape as the limit (systems/setup/geodesic_distance.h), times 1
//    + the strain limit. Tethers to several clusters, not only to the nearest pin, keep a cloth
//    held at separate points from splitting where the nearest pin changes. A soft material without
//    a strain limit may stretch by any amount, so it gets no tethers.
void appendObjectConstraints(ConstraintPools& pools, ObjectKind kind,
                             const SimplicialComplex& complex, std::span<const Vec3> rest,
                             std::span<const Index> pins, Index first, const Material& material);

}  // namespace nucleon
