// What the AVX2 batches of eight constraints (distance_batch.h, angular_batch.h) read and write,
// for constraints of N particles: one record for the in-place sweeps (colored Gauss–Seidel, the
// multigrid cascade), one for Jacobi's slot path. constraint_sweeps.h fills them from a pool.
#pragma once

#include <array>
#include <cstddef>

#include "nucleon/types.h"

namespace nucleon {

// The pool's columns both forms read: its constraints' particles, rest values, compliances and
// multipliers.
template <std::size_t N>
struct BatchColumns {
  const std::array<Index, N>* particles = nullptr;
  const Real* rest = nullptr;
  // Null compliances and multipliers (in place, distance batches only): hard constraints without
  // multipliers, the plain PBD step Δx_a = −w_a C n / (w_a + w_b) (the cascade's coarse limits).
  const Real* compliance = nullptr;
  const Real* compressionCompliance = nullptr;
  Real* lambda = nullptr;
  Real inverseH2 = 0;       // 1/h²
  bool unilateral = false;  // tethers: only C > 0 is corrected (distance batches only)
  // Each constraint's weights (the isometric hinges: ConstraintSettings::weights); null otherwise.
  const std::array<Real, N>* weights = nullptr;
};

// In place: the constraints of a range share no free particle, so each batch gathers its
// particles, projects all eight and writes the free ones back (pins, w = 0, are read but never
// written).
template <std::size_t N>
struct InPlaceBatch : BatchColumns<N> {
  Vec3* positions = nullptr;
  // Hard distance batches (no multipliers: the cascade's coarse limits): every step scaled by ω,
  // successive over-relaxation of the Gauss–Seidel sweep (SolverSettings::cascadeRelaxation).
  Real relaxation = 1;
  const Real* inverseMass = nullptr;  // per particle (distance batches without endInverseMass)
  // The inverse masses of each constraint's particles in pool order (the pool's endInverseMass):
  // contiguous loads instead of one per particle. The angular batches need it.
  const std::array<Real, N>* endInverseMass = nullptr;
};

// Jacobi: every constraint of the range reads the same positions and writes its N corrections
// into its slots (correction[N c + k]) instead of moving the particles, with each particle's
// inverse mass multiplied by its constraint count (mass splitting) and the Chebyshev update of
// constraint_sweeps.h applied to the slots:
//   u = ω γ Δx + (ω − 1) u_prev  for hard constraints when `carry` ≠ 0 (a slot whose history
//   opposes the new step restarts),  u = γ Δx otherwise,
// and λ += (ω γ or γ) Δλ alike. Distance batches accelerate compliant constraints as well, with
// their multiplier's history (`lambdaMove`, δλ of the last sweep; constraint_sweeps.h): a
// compliant constraint restarts its slots and that history together, where Δλ opposes it, and
// λ += δλ = ω γ Δλ + (ω − 1) δλ_prev. Constraints may share particles: nothing is written to
// them.
template <std::size_t N>
struct JacobiBatch : BatchColumns<N> {
  const Vec3* positions = nullptr;
  const Real* splitInverseMass = nullptr;  // w_i times the family's constraint count on i
  Vec3* correction = nullptr;
  Real relaxation = 1;         // γ
  Real step = 1;               // ω γ
  Real carry = 0;              // ω − 1 (0: plain sweep, the old slots are not read)
  Real* lambdaMove = nullptr;  // distance batches: δλ per constraint (ConstraintPool::lambdaMove)
  // Jacobi by colors (angular batches): per particle, the sum of the corrections so far this
  // sweep, which the accumulating batches add to in place of the slots.
  Vec3* sum = nullptr;
};

}  // namespace nucleon
