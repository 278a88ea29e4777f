// Sweeps over a ConstraintPool for any kernel, one per backend (DESIGN.md §3): Gauss–Seidel in
// pool order, Jacobi (corrections from the same state, averaged fixed-order gather) and colored
// Gauss–Seidel (colors in sequence, each in parallel). Dispatch is per family, never per
// constraint: the kernel is a template parameter.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "components/constraint_pool.h"
#include "components/particles.h"
#include "nucleon/world.h"
#include "systems/colored_sweep.h"
#include "systems/constraint_kernels.h"
#include "systems/jacobi_gather.h"

namespace nucleon {

namespace sweep_detail {
constexpr std::size_t kGrain = 512;

// Computes constraint c's correction from p; returns Δλ.
template <class Kernel, std::size_t N>
Real correct(const ConstraintPool<N>& pool, std::size_t c, const Vec3* p, const Real* w, Real invH2,
             Points<N>& dx) {
  Points<N> x;
  std::array<Real, N> weights;
  for (std::size_t k = 0; k < N; ++k) {
    x[k] = p[pool.particles[c][k]];
    weights[k] = w[pool.particles[c][k]];
  }
  return projectConstraint<Kernel>(x, weights, pool.rest[c], pool.compliance[c] * invH2,
                                   pool.lambda[c], dx);
}

template <class Kernel, std::size_t N>
void projectInPlace(ConstraintPool<N>& pool, std::size_t c, Vec3* p, const Real* w, Real invH2) {
  Points<N> dx;
  pool.lambda[c] += correct<Kernel>(pool, c, p, w, invH2, dx);
  for (std::size_t k = 0; k < N; ++k) p[pool.particles[c][k]] += dx[k];
}
}  // namespace sweep_detail

template <class Kernel, std::size_t N>
void solveGaussSeidel(ConstraintPool<N>& pool, ParticlePool& particles, Real h) {
  const Real invH2 = Real(1) / (h * h);
  for (std::size_t c = 0; c < pool.size(); ++c)
    sweep_detail::projectInPlace<Kernel>(pool, c, particles.p.data(), particles.w.data(), invH2);
}

template <class Kernel, std::size_t N>
void solveJacobi(ConstraintPool<N>& pool, ParticlePool& particles, Real h, Real relaxation) {
  const Real invH2 = Real(1) / (h * h);
  const Vec3* p = particles.p.data();
  const Real* w = particles.w.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pool.size(), sweep_detail::kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      Points<N> dx;
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        pool.lambda[c] += sweep_detail::correct<Kernel>(pool, c, p, w, invH2, dx);
                        for (std::size_t k = 0; k < N; ++k) pool.correction[N * c + k] = dx[k];
                      }
                    });
  gatherJacobiCorrections(pool.incidence, pool.correction, particles, relaxation);
}

template <class Kernel, std::size_t N>
void solveColored(ConstraintPool<N>& pool, ParticlePool& particles, Real h) {
  const Real invH2 = Real(1) / (h * h);
  Vec3* p = particles.p.data();
  const Real* w = particles.w.data();
  forEachColor(pool.coloring, sweep_detail::kGrain,
               [&](Index c) { sweep_detail::projectInPlace<Kernel>(pool, c, p, w, invH2); });
}

// Runs one sweep of the given backend.
template <class Kernel, std::size_t N>
void solveSweep(SolverKind kind, ConstraintPool<N>& pool, ParticlePool& particles, Real h,
                Real relaxation) {
  if (pool.size() == 0) return;
  switch (kind) {
    case SolverKind::Jacobi:
      solveJacobi<Kernel>(pool, particles, h, relaxation);
      break;
    case SolverKind::ColoredGaussSeidel:
      solveColored<Kernel>(pool, particles, h);
      break;
    default:
      solveGaussSeidel<Kernel>(pool, particles, h);
      break;
  }
}

}  // namespace nucleon
