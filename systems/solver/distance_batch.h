// Distance-type constraints (stretch, tether) projected eight at a time with AVX2 and FMA, for
// the colored Gauss–Seidel sweep: within a color no two constraints share a free particle, so a
// batch can gather its particles, project all eight at once and scatter the results. The
// projection is the undamped XPBD update of constraint_kernels.h (Macklin et al. 2016, eq. 18):
//   C = |x_a − x_b| − L,  Δλ = (−C − α̃λ) / (w_a + w_b + α̃),  x_a += w_a Δλ n,  x_b −= w_b Δλ n,
// with n = (x_a − x_b)/|x_a − x_b| and α̃ the stretch or compression compliance over h² by the
// sign of C. Results equal the scalar path's up to floating-point rounding (FMA contraction).
#pragma once

#include <array>

#include "nucleon/types.h"

namespace nucleon {

constexpr Index kDistanceBatchSize = 8;

struct DistanceBatch {
  const std::array<Index, 2>* particles = nullptr;
  const Real* rest = nullptr;
  // Null compliances and multipliers: hard constraints without multipliers, the plain PBD step
  // Δx_a = −w_a C n / (w_a + w_b) (the multigrid cascade's coarse limits).
  const Real* compliance = nullptr;
  const Real* compressionCompliance = nullptr;
  Real* lambda = nullptr;
  Vec3* positions = nullptr;
  const Real* inverseMass = nullptr;
  Real inverseH2 = 0;       // 1/h²
  bool unilateral = false;  // tethers: only C > 0 is corrected
  // (w_a, w_b) of each constraint in pool order, if the pool has them: two contiguous loads
  // instead of two gathers of `inverseMass`.
  const std::array<Real, 2>* endInverseMass = nullptr;
};

// The Jacobi form of the same projection: every constraint of the range reads the same positions
// and writes its two corrections into its slots (correction[2c], correction[2c + 1]) instead of
// moving the particles, with each particle's inverse mass multiplied by its constraint count
// (mass splitting) and the Chebyshev update of constraint_sweeps.h applied to the slots:
//   u = ω γ Δx + (ω − 1) u_prev  for hard constraints when `carry` ≠ 0,  u = γ Δx otherwise,
// and λ += (ω γ or γ) Δλ alike. Constraints may share particles: nothing is written to them.
struct DistanceJacobiBatch {
  const std::array<Index, 2>* particles = nullptr;
  const Real* rest = nullptr;
  const Real* compliance = nullptr;
  const Real* compressionCompliance = nullptr;
  Real* lambda = nullptr;
  const Vec3* positions = nullptr;
  const Real* splitInverseMass = nullptr;  // w_i times the family's constraint count on i
  Vec3* correction = nullptr;
  Real inverseH2 = 0;       // 1/h²
  bool unilateral = false;  // tethers: only C > 0 is corrected
  Real relaxation = 1;      // γ
  Real step = 1;            // ω γ
  Real carry = 0;           // ω − 1 (0: plain sweep, the old slots are not read)
};

// True when this build and CPU run the batched path (float solver state, AVX2 and FMA).
bool distanceBatchesAvailable();

// Projects constraints begin, begin+1, … in batches of eight, none of which may share a free
// particle (pins, w = 0, are read but never written). Returns the first constraint it left to
// the caller (fewer than eight remain, or the batched path is unavailable: then `begin`).
Index projectDistanceBatches(const DistanceBatch& batch, Index begin, Index end);

// Projects constraints begin, begin+1, … in batches of eight into their Jacobi slots. Returns the
// first constraint it left to the caller, like projectDistanceBatches.
Index projectDistanceJacobiBatches(const DistanceJacobiBatch& batch, Index begin, Index end);

}  // namespace nucleon
