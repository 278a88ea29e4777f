#include "systems/derived_tables.h"

#include <algorithm>
#include <numeric>

#include "systems/constraint_graph_build.h"
#include "systems/jacobi_vertex.h"
#include "systems/solve_constraints.h"
#include "systems/sweep_schedule.h"
#include "systems/tether_sweep.h"

namespace nucleon {

void buildDerivedTables(ConstraintPools& pools, const ParticlePool& particles, SolverKind kind) {
  pools.forEach([&](auto& pool) {
    constexpr std::size_t n = std::remove_reference_t<decltype(pool)>::kArity;
    const std::span<const std::array<Index, n>> tuples = pool.particles;
    if (static_cast<const void*>(&pool) == static_cast<const void*>(&pools.tether)) {
      // Tethers have their own sweep over vertices, in layers (systems/tether_sweep.h).
      layerTethers(pools.tether);
    } else {
      pool.coloring = colorConstraints(tuples, particles.size(), particles.w);
    }
    // Colored Gauss–Seidel stores the pool in color order, so that a color is contiguous in
    // memory and its sweep streams through the constraint columns. Sequential Gauss–Seidel
    // visits the same order through coloring.order (its stable order, constraint_sweeps.h);
    // Jacobi keeps the mesh order, whose neighbouring constraints share particles.
    if ((kind == SolverKind::ColoredGaussSeidel || kind == SolverKind::Multigrid) &&
        !pool.coloring.inPlace) {
      pool.permute(pool.coloring.order);
      std::iota(pool.coloring.order.begin(), pool.coloring.order.end(), Index(0));
      pool.coloring.inPlace = true;
    }
    pool.undamped =
        std::all_of(pool.damping.begin(), pool.damping.end(), [](Real tau) { return tau == 0; });
    pool.endInverseMass.resize(pool.size());
    for (std::size_t c = 0; c < pool.size(); ++c)
      for (std::size_t k = 0; k < n; ++k)
        pool.endInverseMass[c][k] = particles.w[pool.particles[c][k]];
    pool.incidence = buildIncidence(tuples, particles.size());
    pool.splitInverseMass.resize(particles.size());
    for (std::size_t i = 0; i < particles.size(); ++i)
      pool.splitInverseMass[i] =
          particles.w[i] * Real(pool.incidence.offset[i + 1] - pool.incidence.offset[i]);
    pool.correction.assign(n * pool.size(), Vec3::Zero());
    // The vertex-centric Jacobi sweep (jacobi_vertex.h) for pools of hard, undamped distance
    // constraints; not the tethers, which are unilateral and have their own sweep. Built only
    // for the Jacobi sweeps (a few bytes per slot that the other backends never read).
    pool.vertexJacobi = false;
    pool.vertexHistory = false;
    pool.vertexRows = {};
    pool.vertexMove.clear();
    pool.vertexLaneLambda.clear();
    if constexpr (n == 2) {
      const bool hard =
          pool.undamped &&
          std::all_of(pool.compliance.begin(), pool.compliance.end(),
                      [](Real alpha) { return alpha == 0; }) &&
          std::all_of(pool.compressionCompliance.begin(), pool.compressionCompliance.end(),
                      [](Real alpha) { return alpha == 0; });
      if (kind == SolverKind::Jacobi && hard && pool.size() > 0 &&
          static_cast<const void*>(&pool) != static_cast<const void*>(&pools.tether)) {
        pool.vertexRows =
            buildVertexSlotRows(tuples, pool.rest, pool.incidence, pool.splitInverseMass);
        pool.vertexMove.assign(3 * VertexSlotRows::kLanes * pool.vertexRows.blockCount(), 0);
        pool.vertexLaneLambda.assign(pool.vertexRows.other.size(), 0);
        pool.vertexJacobi = true;
      }
    }
  });
}

SweepPlan buildSweepPlan(const SolverSettings& solver, std::span<const ObjectRecord> objects,
                         const ConstraintPools& pools, const ParticlePool& particles) {
  SweepPlan plan = planSweeps(solver, objects);
  plan.projectionsPerSubstep = countProjections(pools, particles, plan);
  return plan;
}

}  // namespace nucleon
