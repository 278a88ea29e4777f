// Sweeps over a ConstraintPool for any kernel, one per backend (ARCHITECTURE.md §3): Gauss–Seidel
// in coloring order one constraint at a time, Jacobi (corrections from the same state, averaged
// fixed-order gather) and colored Gauss–Seidel (colors in sequence, each in parallel). Dispatch is
// per family, never per constraint: the kernel is a template parameter.
//
// A sweep may be restricted to some objects (per-object schedules): `objectRuns`, when not null,
// says for each object index whether its constraints take part in this sweep. A constraint
// belongs to the object of its first particle (particles.phase).
#pragma once

#include <cstdint>

#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "components/constraint_pool.h"
#include "components/particles.h"
#include "nucleon/solver_settings.h"
#include "systems/colored_sweep.h"
#include "systems/constraint_kernels.h"
#include "systems/distance_batch.h"
#include "systems/jacobi_gather.h"

namespace nucleon {

// The state a sweep reads besides the pool: particles, substep length and the object filter.
struct SweepContext {
  ParticlePool& particles;
  Real h = 0;
  Real relaxation = 1;                       // Jacobi ω
  const std::uint8_t* objectRuns = nullptr;  // null: every object
};

namespace sweep_detail {
constexpr std::size_t kGrain = 512;

template <std::size_t N>
NUCLEON_KERNEL bool takesPart(const ConstraintPool<N>& pool, std::size_t c,
                              const SweepContext& context) {
  return !context.objectRuns ||
         context.objectRuns[context.particles.phase[pool.particles[c][0]]] != 0;
}

// Computes constraint c's correction from p (the positions being solved); returns Δλ.
// With `inverseMass` = pool.splitInverseMass (Jacobi), particle i's inverse mass is multiplied by
// the number of the family's constraints that share it (mass splitting): see solveJacobi.
template <class Kernel, std::size_t N>
NUCLEON_KERNEL Real correct(const ConstraintPool<N>& pool, std::size_t c, const Vec3* p,
                            const ParticlePool& ps, Real invH, Points<N>& dx,
                            const Real* inverseMass = nullptr) {
  Points<N> x, start;
  std::array<Real, N> weights;
  for (std::size_t k = 0; k < N; ++k) {
    const Index i = pool.particles[c][k];
    x[k] = p[i];
    weights[k] = inverseMass ? inverseMass[i] : ps.w[i];
  }
  const Real invH2 = invH * invH;
  ProjectionTerms terms;
  terms.rest = pool.rest[c];
  terms.alphaTilde = pool.compliance[c] * invH2;
  terms.alphaTildeBelow = pool.compressionCompliance[c] * invH2;
  terms.lambda = pool.lambda[c];
  if (pool.damping[c] > 0) {  // only damped constraints read the substep's start positions
    terms.gamma = pool.damping[c] * invH;
    for (std::size_t k = 0; k < N; ++k) start[k] = ps.x[pool.particles[c][k]];
  }
  return projectConstraint<Kernel>(x, start, weights, terms, dx);
}

template <class Kernel, std::size_t N>
NUCLEON_KERNEL void projectInPlace(ConstraintPool<N>& pool, std::size_t c, ParticlePool& ps,
                                   Real invH) {
  Points<N> dx;
  Vec3* p = ps.p.data();
  pool.lambda[c] += correct<Kernel>(pool, c, p, ps, invH, dx);
  // Pins (w = 0) get dx = 0 and are not written: constraints of one color may share them.
  for (std::size_t k = 0; k < N; ++k) {
    const Index i = pool.particles[c][k];
    if (ps.w[i] != 0) p[i] += dx[k];
  }
}
}  // namespace sweep_detail

// The sequential reference: Gauss–Seidel one constraint at a time, in coloring order (all of
// color 0, then color 1, …, then the overflow range). The order decides stability, not only the
// rate of convergence. A sweep of sequential projections is one nonlinear Gauss–Seidel iteration
// on the multipliers' system J W Jᵀ Δλ = −C (Macklin et al. 2016, eq. 18): it applies (D + L)⁻¹,
// L holding each constraint's couplings to those before it in the order, which is not
// symmetric. With one sweep per substep the sweep's correction is the whole velocity change, so
// the non-symmetric part acts as a non-conservative force (our reading of the measurements
// below), and it is largest where the order runs long chains of constraints that each start from
// the previous one's result. The pool's own order is such an order: edges sorted by vertex index,
// so a cloth's edges run along its rows, and one sweep carries a correction the whole width of the
// cloth. Measured in that order, on a 64×64 cloth hanging from two corners with 10 substeps of one
// sweep, the total energy rises from 10 J to 10⁵ J within a second, starting on the row between the
// pins; the reverse of that order diverges alike, while coloring order and a random order, with the
// same kernel and the same work, lose energy steadily, and ropes (no loops in their constraint
// graph) are stable in either order. Within a color no two constraints share a free particle,
// so a sweep carries a correction across at most one constraint per color (at most 15 on
// the grid cloths). The price is a slower spread of corrections per sweep: the strain left after
// one second is up to about twice that of the pool's order in the runs that order survives.
// colored-gs runs this same order with each color in parallel, so it matches this reference up to
// the rounding of its batched distance path. Needs pool.coloring current (the derived tables).
template <class Kernel, std::size_t N>
void solveGaussSeidel(ConstraintPool<N>& pool, const SweepContext& context) {
  const Real invH = 1 / context.h;
  for (const Index c : pool.coloring.order)
    if (sweep_detail::takesPart(pool, c, context))
      sweep_detail::projectInPlace<Kernel>(pool, c, context.particles, invH);
}

// Jacobi with mass splitting (Tonge et al. 2012): each constraint sees particle i with n_i times
// its inverse mass (n_i = the family's constraints on i), as if i's mass were shared equally
// among them; the gather then averages the copies, so that particle i moves by
//   Δx_i = ω Σ_c w_i ∇_i C_c Δλ_c,
// exactly the displacement that the multipliers account for. λ_c therefore accumulates ω Δλ_c,
// and the compliance term −α̃λ stays consistent with the positions: with plain averaging,
// particles move n_i times less than λ says, and a soft material comes out softer.
template <class Kernel, std::size_t N>
void solveJacobi(ConstraintPool<N>& pool, const SweepContext& context) {
  const ParticlePool& ps = context.particles;
  const Vec3* p = ps.p.data();
  const Real invH = 1 / context.h, omega = context.relaxation;
  const Real* splitInverseMass = pool.splitInverseMass.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pool.size(), sweep_detail::kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      Points<N> dx;
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        if (sweep_detail::takesPart(pool, c, context)) {
                          pool.lambda[c] += omega * sweep_detail::correct<Kernel>(
                                                        pool, c, p, ps, invH, dx, splitInverseMass);
                        } else {
                          for (auto& d : dx) d.setZero();
                        }
                        for (std::size_t k = 0; k < N; ++k) pool.correction[N * c + k] = dx[k];
                      }
                    });
  gatherJacobiCorrections(pool.incidence, pool.correction, context.particles, context.relaxation);
}

template <class Kernel, std::size_t N>
void solveColored(ConstraintPool<N>& pool, const SweepContext& context) {
  const Real invH = 1 / context.h;
  auto projectOne = [&](Index c) {
    if (sweep_detail::takesPart(pool, c, context))
      sweep_detail::projectInPlace<Kernel>(pool, c, context.particles, invH);
  };
  if constexpr (std::is_base_of_v<DistanceKernel, Kernel>) {
    // Undamped distance constraints stored in color order: eight at a time (distance_batch.h).
    if (!context.objectRuns && pool.undamped && pool.coloring.inPlace &&
        distanceBatchesAvailable()) {
      DistanceBatch batch;
      batch.particles = pool.particles.data();
      batch.rest = pool.rest.data();
      batch.compliance = pool.compliance.data();
      batch.compressionCompliance = pool.compressionCompliance.data();
      batch.lambda = pool.lambda.data();
      batch.positions = context.particles.p.data();
      batch.inverseMass = context.particles.w.data();
      batch.inverseH2 = invH * invH;
      batch.unilateral = std::is_same_v<Kernel, TetherKernel>;
      batch.endInverseMass = pool.endInverseMass.data();
      forEachColorRange(
          pool.coloring, sweep_detail::kGrain, kDistanceBatchSize,
          [&](Index begin, Index end) {
            for (Index c = projectDistanceBatches(batch, begin, end); c < end; ++c) projectOne(c);
          },
          projectOne);
      return;
    }
  }
  forEachColor(pool.coloring, sweep_detail::kGrain, projectOne);
}

// Runs one sweep of the given backend.
template <class Kernel, std::size_t N>
void solveSweep(SolverKind kind, ConstraintPool<N>& pool, const SweepContext& context) {
  if (pool.size() == 0) return;
  switch (kind) {
    case SolverKind::Jacobi:
      solveJacobi<Kernel>(pool, context);
      break;
    case SolverKind::ColoredGaussSeidel:
      solveColored<Kernel>(pool, context);
      break;
    default:
      solveGaussSeidel<Kernel>(pool, context);
      break;
  }
}

}  // namespace nucleon
