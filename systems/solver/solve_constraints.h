// The solve stage of a substep: the sweeps of the plan, in order, with the chosen backend.
#pragma once

#include <cstdint>

#include "components/collider_pool.h"
#include "components/constraint_pools.h"
#include "components/contact_pool.h"
#include "components/particles.h"
#include "components/primitive_contact_pool.h"
#include "components/sweep_plan.h"
#include "nucleon/solver_settings.h"
#include "systems/solver/jacobi_chebyshev.h"

namespace nucleon {

// Resets every multiplier (XPBD's λ lives for one substep) and runs plan.ops on particles.p,
// projecting the collider contact pool and the primitive contact pool after each round (and once
// when the plan has no sweeps), so that resting contact is solved with the constraints and not
// after them. Returns the seconds spent in contact projection, which the profile books as
// collisions. After each round but the last (its contacts projected), `betweenRounds(context,
// r)` is called with the number r ≥ 1 of rounds done, if given: the multigrid backend repeats
// its cascade there. `sheetRelaxation` is Jacobi's γ for the particles of sheets and solids in the
// vertex-centric sweep (SolverSettings::sheetRelaxation; 0: `relaxation`).
using RoundHook = void (*)(void* context, int roundsDone);

// How the sweeps of one solve run: the backend of the fine sweeps and its settings, from
// SolverSettings (solveSettingsOf).
struct SolveSettings {
  SolverKind sweepKind = SolverKind::ColoredGaussSeidel;  // multigrid: its smoother
  Real relaxation = 1;
  Real chebyshevRho = kChebyshevSpectralRadius;
  Real sheetRelaxation = 0;
  bool optimizedPaths = true;
  RoundHook betweenRounds = nullptr;
  void* hookContext = nullptr;
};
SolveSettings solveSettingsOf(const SolverSettings& solver);

double solveConstraints(ConstraintPools& pools, ParticlePool& particles, const SweepPlan& plan,
                        ContactPool& contacts, const ColliderPool& colliders,
                        PrimitiveContactPool& primitiveContacts, Real h,
                        const SolveSettings& settings);

// Constraint projections one substep of `plan` performs (for throughput figures).
std::uint64_t countProjections(const ConstraintPools& pools, const ParticlePool& particles,
                               const SweepPlan& plan);

}  // namespace nucleon
