// Dihedral hinges (cloth bend, curve twist: DihedralKernel) projected eight at a time with AVX2 and
// FMA, like the distance batches (distance_batch.h). Per lane, the kernel of constraint_kernels.h:
//   e = x1 − x0,  n1 = e × (x2 − x0),  n2 = (x3 − x0) × e,
//   φ = atan2((n1 × n2) · ê, n1 · n2),
//   ∇_x2 φ = −‖e‖ n1/‖n1‖²,  ∇_x3 φ = −‖e‖ n2/‖n2‖²,
//   ∇_x0 φ = −(1 − s2) ∇_x2 φ − (1 − s3) ∇_x3 φ,  ∇_x1 φ = −s2 ∇_x2 φ − s3 ∇_x3 φ,
// with s_k = (x_k − x0)·e/‖e‖², then the undamped XPBD step (Macklin et al. 2016, eq. 18)
//   C = wrap(φ − φ0),  Δλ = (−C − α̃λ) / (Σ_k w_k ‖∇_k φ‖² + α̃),  Δx_k = w_k Δλ ∇_k φ,
// C wrapped to (−π, π] and α̃ the compliance over h² by the sign of C. The arctangent is a
// polynomial (the octant reduction and minimax odd polynomial of Cephes' atanf, relative error
// about 2e-7 on [0, 1]), not a call of the math library per hinge: the scalar kernel's atan2 was
// most of its time. Degenerate hinges (an edge or a wing of zero length or area) and hinges of
// fixed particles make no correction, as in the scalar kernel. Results equal the scalar path's up
// to floating-point rounding.
#pragma once

#include <array>

#include "nucleon/types.h"

namespace nucleon {

constexpr Index kHingeBatchSize = 8;

// Colored Gauss–Seidel: the hinges of a range share no free particle, so each batch gathers its
// particles, projects all eight and writes the free ones back.
struct HingeBatch {
  const std::array<Index, 4>* particles = nullptr;
  const Real* rest = nullptr;
  const Real* compliance = nullptr;
  const Real* compressionCompliance = nullptr;
  Real* lambda = nullptr;
  Vec3* positions = nullptr;
  // The inverse masses of each hinge's particles in pool order (the pool's endInverseMass).
  const std::array<Real, 4>* endInverseMass = nullptr;
  Real inverseH2 = 0;  // 1/h²
};

// Jacobi: every hinge reads the same positions and writes its four corrections into its slots
// (correction[4c + k]), with split inverse masses and the Chebyshev update of
// constraint_sweeps.h: u = ω γ Δx + (ω − 1) u_prev for hard hinges when `carry` ≠ 0 (a slot whose
// history opposes the new step restarts), u = γ Δx otherwise; λ += (ω γ or γ) Δλ alike.
struct HingeJacobiBatch {
  const std::array<Index, 4>* particles = nullptr;
  const Real* rest = nullptr;
  const Real* compliance = nullptr;
  const Real* compressionCompliance = nullptr;
  Real* lambda = nullptr;
  const Vec3* positions = nullptr;
  const Real* splitInverseMass = nullptr;  // w_i times the family's constraint count on i
  Vec3* correction = nullptr;
  Real inverseH2 = 0;   // 1/h²
  Real relaxation = 1;  // γ
  Real step = 1;        // ω γ
  Real carry = 0;       // ω − 1 (0: plain sweep, the old slots are not read)
};

// True when this build and CPU run the batched path (float solver state, AVX2 and FMA).
bool hingeBatchesAvailable();

// Projects hinges begin, begin+1, … in batches of eight, in place. Returns the first hinge it left
// to the caller (fewer than eight remain, or the batched path is unavailable: then `begin`).
Index projectHingeBatches(const HingeBatch& batch, Index begin, Index end);

// Projects hinges begin, begin+1, … in batches of eight into their Jacobi slots; returns the
// first hinge it left to the caller.
Index projectHingeJacobiBatches(const HingeJacobiBatch& batch, Index begin, Index end);

}  // namespace nucleon
