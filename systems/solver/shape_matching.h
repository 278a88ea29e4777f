// Shape matching (Müller, Heidelberger, Teschner and Gross 2005): every particle of a cluster is
// pulled towards its place in the rest shape moved rigidly to fit the current positions best,
//   c = Σ m p / M,   A = Σ m (p − c) rᵀ = Σ m p rᵀ (Σ m r = 0),   R = the rotation of A's polar
//   decomposition,   g = c + R r,   p ← p + s (g − p).
// The fit keeps linear momentum (Σ m (g − p) = 0) and angular momentum (the polar rotation is the
// one whose goal positions exert no torque about c). At rigidity 1 the cluster is moved exactly
// to its fitted rigid pose every projection; below 1 it resists deformation (Nucleus's rigidity
// and deform resistance), with s per projection set so that the rounds of a substep together
// close the same share, 1 − (1 − rigidity)^(1/rounds), of the gap for any sweep count.
#pragma once

#include "components/objects.h"
#include "components/particles.h"
#include "components/shape_match_pool.h"

namespace nucleon {

// Appends the cluster of `record` (object number `objectIndex`; its particles already in the
// pool at record.firstParticle, every one of them free).
void appendShapeMatchCluster(ShapeMatchPool& pool, const ObjectRecord& record,
                             std::uint32_t objectIndex, const ParticlePool& particles);

// One projection of every cluster on the predicted positions p (with `objectRuns`, only the
// clusters of the objects it marks); `rounds` is the number of projections in the substep. A
// particle of inverse mass 0 (held by the fail-safe for a moment) is not moved.
void projectShapeMatching(ShapeMatchPool& pool, ParticlePool& particles, int rounds,
                          const std::uint8_t* objectRuns = nullptr);

// The rotation of the polar decomposition of A (the rotation nearest to A), by SVD, with the
// reflection taken out when det A < 0.
Mat3d polarRotation(const Mat3d& a);

}  // namespace nucleon
