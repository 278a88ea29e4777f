// The solve stage of a substep: the sweeps of the plan, in order, with the chosen backend.
#pragma once

#include <cstdint>
#include <span>

#include "components/constraint_pools.h"
#include "components/particles.h"
#include "components/sweep_plan.h"

namespace nucleon {

// The static surfaces particles are projected out of between sweep rounds.
struct ContactSurfaces {
  const GroundPlane& ground;
  std::span<const SphereCollider> spheres;
  bool any() const { return ground.enabled || !spheres.empty(); }
};

// Resets every multiplier (XPBD's λ lives for one substep) and runs plan.ops on particles.p,
// projecting contacts after each round (and once when the plan has no sweeps). Returns the
// seconds spent in contact projection, which the profile books as collisions.
double solveConstraints(ConstraintPools& pools, ParticlePool& particles, const SweepPlan& plan,
                        const ContactSurfaces& contacts, SolverKind kind, Real h, Real relaxation);

// Constraint projections one substep of `plan` performs (for throughput figures).
std::uint64_t countProjections(const ConstraintPools& pools, const ParticlePool& particles,
                               const SweepPlan& plan);

}  // namespace nucleon
