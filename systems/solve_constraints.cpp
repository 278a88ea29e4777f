#include "systems/solve_constraints.h"

#include <algorithm>
#include <chrono>

#include "systems/constraint_sweeps.h"
#include "systems/ground_contact.h"
#include "systems/sphere_contact.h"

namespace nucleon {
namespace {

double projectContacts(ParticlePool& particles, const ContactSurfaces& contacts) {
  const auto start = std::chrono::steady_clock::now();
  if (contacts.ground.enabled) projectGround(particles, contacts.ground);
  projectSpheres(particles, contacts.spheres);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Calls f(pool) for each pool a sweep of `family` visits.
template <typename F>
void forFamilyPools(ConstraintFamily family, const ConstraintPools& pools, F&& f) {
  switch (family) {
    case ConstraintFamily::Stretch:
      f(pools.stretch);
      break;
    case ConstraintFamily::Shear:
      f(pools.shear);
      break;
    case ConstraintFamily::Bend:
      f(pools.bend), f(pools.curveBend);
      break;
    case ConstraintFamily::Twist:
      f(pools.twist);
      break;
    case ConstraintFamily::Volume:
      f(pools.volume);
      break;
    case ConstraintFamily::Tether:
      f(pools.tether);
      break;
  }
}

}  // namespace

double solveConstraints(ConstraintPools& pools, ParticlePool& particles, const SweepPlan& plan,
                        const ContactSurfaces& contacts, SolverKind kind, Real h, Real relaxation) {
  pools.forEach([](auto& pool) { std::fill(pool.lambda.begin(), pool.lambda.end(), Real(0)); });
  SweepContext context{particles, h, relaxation, nullptr};
  double contactSeconds = 0;
  for (const SweepOp& op : plan.ops) {
    context.objectRuns =
        op.objectRunsOffset < 0 ? nullptr : plan.objectRuns.data() + op.objectRunsOffset;
    switch (op.family) {
      case ConstraintFamily::Stretch:
        solveSweep<DistanceKernel>(kind, pools.stretch, context);
        break;
      case ConstraintFamily::Shear:
        solveSweep<AngleKernel>(kind, pools.shear, context);
        break;
      case ConstraintFamily::Bend:
        solveSweep<DihedralKernel>(kind, pools.bend, context);
        solveSweep<AngleKernel>(kind, pools.curveBend, context);
        break;
      case ConstraintFamily::Twist:
        solveSweep<DihedralKernel>(kind, pools.twist, context);
        break;
      case ConstraintFamily::Volume:
        solveSweep<VolumeKernel>(kind, pools.volume, context);
        break;
      case ConstraintFamily::Tether:
        solveSweep<TetherKernel>(kind, pools.tether, context);
        break;
    }
    if (op.endsRound && contacts.any()) contactSeconds += projectContacts(particles, contacts);
  }
  if (plan.ops.empty() && contacts.any()) contactSeconds += projectContacts(particles, contacts);
  return contactSeconds;
}

std::uint64_t countProjections(const ConstraintPools& pools, const ParticlePool& particles,
                               const SweepPlan& plan) {
  std::uint64_t total = 0;
  for (const SweepOp& op : plan.ops) {
    const std::uint8_t* runs =
        op.objectRunsOffset < 0 ? nullptr : plan.objectRuns.data() + op.objectRunsOffset;
    forFamilyPools(op.family, pools, [&](const auto& pool) {
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
