#include "systems/setup/build_derived_tables.h"

#include <algorithm>
#include <numeric>
#include <type_traits>

#include "systems/setup/build_constraint_graph.h"
#include "systems/setup/sweep_schedule.h"
#include "systems/solver/family_pools.h"
#include "systems/solver/jacobi_vertex.h"
#include "systems/solver/solve_constraints.h"
#include "systems/solver/tether_sweep.h"

namespace nucleon {

namespace {

template <class Pool>
ParticleTuples tuplesOfPool(const Pool& pool) {
  if constexpr (std::is_same_v<Pool, UserConstraintPool>)
    return {pool.particles.data(), pool.arity(), pool.size()};
  else
    return tuplesOf(std::span<const std::array<Index, Pool::kArity>>(pool.particles));
}

}  // namespace

void buildDerivedTables(ConstraintPools& pools, const ParticlePool& particles, SolverKind kind) {
  forEachPoolWithKernel(pools, [&](auto& pool, auto tag) {
    using Pool = std::remove_reference_t<decltype(pool)>;
    constexpr unsigned paths = decltype(tag)::kPaths;
    const std::size_t n = pool.arity();
    if constexpr ((paths & kTetherLayers) != 0) {
      // Tethers have their own sweep over vertices, in layers (systems/solver/tether_sweep.h).
      layerTethers(pool);
    } else {
      pool.coloring = colorConstraints(tuplesOfPool(pool), particles.size(), particles.w);
    }
    // Colored Gauss–Seidel stores the pool in color order, so that a color is contiguous in
    // memory and its sweep streams through the constraint columns. Sequential Gauss–Seidel
    // visits the same order through coloring.order (its stable order, constraint_sweeps.h);
    // Jacobi keeps the mesh order, whose neighbouring constraints share particles.
    // Jacobi stores a soft angular pool in color order too, for its sweep by colors
    // (constraint_sweeps.h, solveJacobi): the mesh order's locality served the slot path's
    // gather, which that sweep does without.
    const bool colorJacobi = (paths & kAngularBatch) != 0 && !pool.coloring.overflow && [&] {
      // Every constraint soft (a compliance or damping): the angular families accelerate
      // hard constraints only, whose history lives in the slots.
      for (std::size_t c = 0; c < pool.size(); ++c)
        if (pool.compliance[c] == 0 && pool.compressionCompliance[c] == 0 && pool.damping[c] == 0)
          return false;
      return true;
    }();
    if ((kind == SolverKind::ColoredGaussSeidel || kind == SolverKind::Multigrid || colorJacobi) &&
        !pool.coloring.inPlace) {
      pool.permute(pool.coloring.order);
      std::iota(pool.coloring.order.begin(), pool.coloring.order.end(), Index(0));
      pool.coloring.inPlace = true;
    }
    pool.undamped =
        std::all_of(pool.damping.begin(), pool.damping.end(), [](Real tau) { return tau == 0; });
    pool.incidence = buildIncidence(tuplesOfPool(pool), particles.size());
    pool.splitInverseMass.resize(particles.size());
    for (std::size_t i = 0; i < particles.size(); ++i)
      pool.splitInverseMass[i] =
          particles.w[i] * Real(pool.incidence.offset[i + 1] - pool.incidence.offset[i]);
    pool.correction.assign(n * pool.size(), Vec3::Zero());
    pool.lambdaMove.assign(pool.size(), 0);
    pool.lambda.assign(pool.size(), 0);
    if constexpr (!std::is_same_v<Pool, UserConstraintPool>) {
      constexpr std::size_t arity = Pool::kArity;
      // Jacobi by colors (above).
      pool.correctionSum.clear();
      if (colorJacobi && pool.coloring.inPlace)
        pool.correctionSum.assign(particles.size(), Vec3::Zero());
      pool.endInverseMass.resize(pool.size());
      for (std::size_t c = 0; c < pool.size(); ++c)
        for (std::size_t k = 0; k < arity; ++k)
          pool.endInverseMass[c][k] = particles.w[pool.particles[c][k]];
      // The vertex-centric Jacobi sweep (jacobi_vertex.h) for pools of hard, undamped distance
      // constraints. Built only for the Jacobi sweeps (a few bytes per slot that the other
      // backends never read).
      pool.vertexJacobi = false;
      pool.vertexHistory = false;
      pool.vertexRows = {};
      pool.vertexMove.clear();
      pool.vertexLaneLambda.clear();
      if constexpr ((paths & kVertexJacobi) != 0) {
        static_assert(arity == 2, "the vertex-centric sweep is for distance constraints");
        const bool hard =
            pool.undamped &&
            std::all_of(pool.compliance.begin(), pool.compliance.end(),
                        [](Real alpha) { return alpha == 0; }) &&
            std::all_of(pool.compressionCompliance.begin(), pool.compressionCompliance.end(),
                        [](Real alpha) { return alpha == 0; });
        if (kind == SolverKind::Jacobi && hard && pool.size() > 0) {
          const std::span<const std::array<Index, 2>> tuples = pool.particles;
          pool.vertexRows =
              buildVertexSlotRows(tuples, pool.rest, pool.incidence, pool.splitInverseMass);
          pool.vertexMove.assign(3 * VertexSlotRows::kLanes * pool.vertexRows.blockCount(), 0);
          pool.vertexLaneLambda.assign(pool.vertexRows.other.size(), 0);
          pool.vertexJacobi = true;
        }
      }
    }
  });
}

SweepPlan buildSweepPlan(const SolverSettings& solver, std::span<const ObjectRecord> objects,
                         const ConstraintPools& pools, const ParticlePool& particles) {
  SweepPlan plan = planSweeps(solver, objects, pools.familyCount());
  plan.projectionsPerSubstep = countProjections(pools, particles, plan);
  return plan;
}

}  // namespace nucleon
