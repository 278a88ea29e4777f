#include "systems/solve_constraints.h"

#include <algorithm>
#include <chrono>
#include <type_traits>

#include "systems/constraint_sweeps.h"
#include "systems/particle_contacts.h"
#include "systems/primitive_contacts.h"
#include "systems/tether_sweep.h"

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

template <class Kernel>
struct KernelTag {
  using type = Kernel;
};

// Calls f(pool, KernelTag<Kernel>{}) for each pool a sweep of `family` visits, with the kernel
// that projects it: the one place that maps families to pools and kernels.
template <class Pools, class F>
void forFamilyPools(ConstraintFamily family, Pools& pools, F&& f) {
  switch (family) {
    case ConstraintFamily::Stretch:
      f(pools.stretch, KernelTag<DistanceKernel>{});
      break;
    case ConstraintFamily::Shear:
      f(pools.shear, KernelTag<AngleKernel>{});
      break;
    case ConstraintFamily::Bend:
      f(pools.bend, KernelTag<DihedralKernel>{});
      f(pools.curveBend, KernelTag<AngleKernel>{});
      break;
    case ConstraintFamily::Twist:
      f(pools.twist, KernelTag<DihedralKernel>{});
      break;
    case ConstraintFamily::Volume:
      f(pools.volume, KernelTag<VolumeKernel>{});
      break;
    case ConstraintFamily::Tether:
      f(pools.tether, KernelTag<TetherKernel>{});
      break;
  }
}

}  // namespace

double solveConstraints(ConstraintPools& pools, ParticlePool& particles, const SweepPlan& plan,
                        ContactPool& contacts, const ColliderPool& colliders,
                        PrimitiveContactPool& primitiveContacts, SolverKind kind, Real h,
                        Real relaxation, Real chebyshevRho, RoundHook betweenRounds,
                        void* hookContext, Real sheetRelaxation) {
  // The step passes the fine sweeps' backend (fineSweepKind: multigrid's smoother); a caller
  // that passes multigrid itself gets its default smoother, colored Gauss–Seidel.
  if (kind == SolverKind::Multigrid) kind = SolverKind::ColoredGaussSeidel;
  const bool anyContacts = contacts.size() > 0 || primitiveContacts.size() > 0;
  pools.forEach([](auto& pool) { std::fill(pool.lambda.begin(), pool.lambda.end(), Real(0)); });
  SweepContext context{particles, h, relaxation, nullptr};
  context.chebyshevRho = chebyshevRho;
  context.sheetRelaxation = sheetRelaxation;
  double contactSeconds = 0;
  int roundsDone = 0;
  for (const SweepOp& op : plan.ops) {
    context.objectRuns =
        op.objectRunsOffset < 0 ? nullptr : plan.objectRuns.data() + op.objectRunsOffset;
    forFamilyPools(op.family, pools, [&](auto& pool, auto kernel) {
      using Kernel = typename decltype(kernel)::type;
      if constexpr (std::is_same_v<Kernel, TetherKernel>)
        solveTethers(kind, pool, context);
      else
        solveSweep<Kernel>(kind, pool, context);
    });
    if (op.endsRound && anyContacts)
      contactSeconds += timedContacts(contacts, colliders, primitiveContacts, particles, kind);
    if (op.endsRound && ++roundsDone < plan.rounds && betweenRounds)
      betweenRounds(hookContext, roundsDone);
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
    forFamilyPools(op.family, pools, [&](const auto& pool, auto) {
      if (!runs) {
        total += pool.size();
        return;
      }
      for (std::size_t c = 0; c < pool.size(); ++c)
        total += runs[particles.phase[pool.particles[c][0]]] != 0;
    });
  }
  return total;
}

}  // namespace nucleon
