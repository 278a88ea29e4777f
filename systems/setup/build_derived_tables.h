// Builds the derived tables of the static constraint pools when the topology or the solver
// settings change, never inside a step: per pool the coloring (and, for colored Gauss–Seidel,
// the pool permuted into color order), the Jacobi incidence table, split inverse masses and
// correction scratch; then the sweep plan of the schedule.
#pragma once

#include <span>

#include "components/constraint_pools.h"
#include "components/objects.h"
#include "components/particles.h"
#include "components/sweep_plan.h"
#include "nucleon/solver_settings.h"

namespace nucleon {

void buildDerivedTables(ConstraintPools& pools, const ParticlePool& particles, SolverKind kind);

// The sweeps of one substep under `solver`, with their projection count.
SweepPlan buildSweepPlan(const SolverSettings& solver, std::span<const ObjectRecord> objects,
                         const ConstraintPools& pools, const ParticlePool& particles);

}  // namespace nucleon
