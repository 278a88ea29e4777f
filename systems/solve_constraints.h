// The solve stage of a substep: the sweeps of the plan, in order, with the chosen backend.
#pragma once

#include "components/constraint_pools.h"
#include "components/particles.h"
#include "components/sweep_plan.h"

namespace nucleon {

// Resets every multiplier (XPBD's λ lives for one substep) and runs plan.ops on particles.p,
// projecting ground contacts after each round (and once when the plan has no sweeps).
void solveConstraints(ConstraintPools& pools, ParticlePool& particles, const SweepPlan& plan,
                      const GroundPlane& ground, SolverKind kind, Real h, Real relaxation);

}  // namespace nucleon
