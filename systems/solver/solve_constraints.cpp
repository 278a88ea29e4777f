#include "systems/solver/solve_constraints.h"

#include <algorithm>
#include <chrono>
#include <type_traits>

#include "systems/collision/particle_contacts.h"
#include "systems/collision/primitive_contacts.h"
#include "systems/solver/constraint_sweeps.h"
#include "systems/solver/family_pools.h"
#include "systems/solver/tether_sweep.h"

namespace nucleon {
namespace {

double timedContacts(ContactPool& contacts, const ColliderPool& colliders,
                     PrimitiveContactPool& primitiveContacts, ParticlePool& particles,
                     SolverKind kind) {
  const auto start = std::chrono::steady_clock::now();
  // Collider contacts last: a stack of layers pressed onto the ground ends the round on it.
  if (primitiveContacts.size() > 0) projectPrimitiveContacts(primitiveContacts, particles, kind);
  if (contacts.size() > 0) projectContacts(contacts, colliders, particles, kind);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

SolveSettings solveSettingsOf(const SolverSettings& solver) {
  SolveSettings settings;
  settings.sweepKind = fineSweepKind(solver);
  settings.relaxation = solver.relaxation;
  settings.chebyshevRho = solver.chebyshevRho;
  settings.sheetRelaxation = solver.sheetRelaxation;
  settings.optimizedPaths = solver.optimizedPaths;
  return settings;
}

double solveConstraints(ConstraintPools& pools, ParticlePool& particles, const SweepPlan& plan,
                        ContactPool& contacts, const ColliderPool& colliders,
                        PrimitiveContactPool& primitiveContacts, Real h,
                        const SolveSettings& settings) {
  SolverKind kind = settings.sweepKind;
  // The step passes the fine sweeps' backend (fineSweepKind: multigrid's smoother); a caller
  // that passes multigrid itself gets its default smoother, colored Gauss–Seidel.
  if (kind == SolverKind::Multigrid) kind = SolverKind::ColoredGaussSeidel;
  const bool anyContacts = contacts.size() > 0 || primitiveContacts.size() > 0;
  pools.forEach([](auto& pool) { std::fill(pool.lambda.begin(), pool.lambda.end(), Real(0)); });
  SweepContext context{particles, h, settings.relaxation, nullptr};
  context.chebyshevRho = settings.chebyshevRho;
  // A registered family that did not opt into Jacobi's acceleration turns it off for every
  // family: extrapolated stretch against a hard, unaccelerated constraint on the same particles
  // was seen to diverge (a cloth corner held on a plane, double build), and plain Jacobi
  // converges, only more slowly.
  for (const UserConstraintPool& pool : pools.user)
    if (pool.size() > 0 && !pool.family.jacobiAcceleration) context.chebyshevRho = 0;
  context.sheetRelaxation = settings.sheetRelaxation;
  context.optimizedPaths = settings.optimizedPaths;
  double contactSeconds = 0;
  int roundsDone = 0;
  for (const SweepOp& op : plan.ops) {
    context.objectRuns =
        op.objectRunsOffset < 0 ? nullptr : plan.objectRuns.data() + op.objectRunsOffset;
    forEachPoolOf(op.family, pools, [&](auto& pool, auto tag) {
      using Tag = decltype(tag);
      if constexpr ((Tag::kPaths & kTetherLayers) != 0)
        solveTethers(kind, pool, context);
      else
        solveSweep<typename Tag::Kernel, Tag::kPaths>(kind, pool, context);
    });
    if (op.endsRound && anyContacts)
      contactSeconds += timedContacts(contacts, colliders, primitiveContacts, particles, kind);
    if (op.endsRound && ++roundsDone < plan.rounds && settings.betweenRounds)
      settings.betweenRounds(settings.hookContext, roundsDone);
  }
  if (plan.ops.empty() && anyContacts)
    contactSeconds += timedContacts(contacts, colliders, primitiveContacts, particles, kind);
  return contactSeconds;
}

std::uint64_t countProjections(const ConstraintPools& pools, const ParticlePool& particles,
                               const SweepPlan& plan) {
  std::uint64_t total = 0;
  for (const SweepOp& op : plan.ops) {
    const std::uint8_t* runs =
        op.objectRunsOffset < 0 ? nullptr : plan.objectRuns.data() + op.objectRunsOffset;
    forEachPoolOf(op.family, pools, [&](const auto& pool, auto) {
      if (!runs) {
        total += pool.size();
        return;
      }
      for (std::size_t c = 0; c < pool.size(); ++c)
        total += runs[particles.phase[pool.particle(c, 0)]] != 0;
    });
  }
  return total;
}

}  // namespace nucleon
