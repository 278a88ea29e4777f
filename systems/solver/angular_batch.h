// Angular constraints projected eight at a time with AVX2 and FMA, like the distance batches
// (distance_batch.h): the dihedral hinges of cloth bend and curve twist (DihedralKernel) and the
// angles of curve bend and cloth shear (AngleKernel). Per lane, the kernel of constraint_kernels.h
//   hinge:  e = x1 − x0,  n1 = e × (x2 − x0),  n2 = (x3 − x0) × e,
//           φ = atan2((n1 × n2) · ê, n1 · n2),  ∇_x2 φ = −‖e‖ n1/‖n1‖²,  ∇_x3 φ = −‖e‖ n2/‖n2‖²,
//           ∇_x0 φ = −(1 − s2) ∇_x2 φ − (1 − s3) ∇_x3 φ,  ∇_x1 φ = −s2 ∇_x2 φ − s3 ∇_x3 φ,
//           s_k = (x_k − x0)·e/‖e‖²;
//   isometric hinge (IsometricBendKernel, hinges flat at rest): C = ‖v‖, v = Σ_k k_k x_k with
//           the constraint's weights k, ∇_x_k C = k_k v/‖v‖ (not wrapped: not an angle);
//   angle:  θ = atan2(‖û × v̂‖, û · v̂),  u = x0 − x2,  v = x1 − x2,
//           ∇_x0 θ = −t_u/‖u‖,  ∇_x1 θ = −t_v/‖v‖,  ∇_x2 θ = −∇_x0 θ − ∇_x1 θ,
// then the undamped XPBD step (Macklin et al. 2016, eq. 18)
//   C = wrap(θ − θ0),  Δλ = (−C − α̃λ) / (Σ_k w_k ‖∇_k θ‖² + α̃),  Δx_k = w_k Δλ ∇_k θ,
// C wrapped to (−π, π] and α̃ the compliance over h² by the side the multiplier ends on (the sign
// of s λ − C; kernel_detail::belowRest). The arctangent is a
// polynomial (the octant reduction and minimax odd polynomial of Cephes' atanf, relative error
// about 2e-7 on [0, 1]), not a call of the math library per constraint: the scalar kernels' atan2
// was most of their time. Degenerate constraints (an edge or a wing of zero length or area, a
// straight angle) and constraints of fixed particles make no correction, as in the scalar
// kernels. Results equal the scalar path's up to floating-point rounding.
#pragma once

#include <array>

#include "nucleon/types.h"
#include "systems/solver/batch_parameters.h"

namespace nucleon {

constexpr Index kAngularBatchSize = 8;

// The batches' records (batch_parameters.h). In place, the inverse masses come from
// endInverseMass; `unilateral` and the null-compliance form are the distance batches' only.
template <std::size_t N>
using AngularBatch = InPlaceBatch<N>;
template <std::size_t N>
using AngularJacobiBatch = JacobiBatch<N>;

// True when this build and CPU run the batched path (float solver state, AVX2 and FMA).
bool angularBatchesAvailable();

// Each projects constraints begin, begin+1, … in batches of eight (in place, or into the Jacobi
// slots) and returns the first constraint it left to the caller (fewer than eight remain, or the
// batched path is unavailable: then `begin`).
Index projectHingeBatches(const AngularBatch<4>& batch, Index begin, Index end);
Index projectHingeJacobiBatches(const AngularJacobiBatch<4>& batch, Index begin, Index end);
Index projectIsometricBendBatches(const AngularBatch<4>& batch, Index begin, Index end);
Index projectIsometricBendJacobiBatches(const AngularJacobiBatch<4>& batch, Index begin, Index end);
Index projectAngleBatches(const AngularBatch<3>& batch, Index begin, Index end);
Index projectAngleJacobiBatches(const AngularJacobiBatch<3>& batch, Index begin, Index end);

// Jacobi by colors (constraint_sweeps.h, solveJacobi): constraints [begin, end) of one color add
// their corrections to batch.sum per particle instead of writing their slots, with the slot
// path's bits for each constraint and its λ. `end` must lie within the pool's whole blocks of
// eight from constraint 0, and no constraint of the pool may be accelerated (every one soft).
// Return `end`, or `begin` where the batched path is unavailable.
Index accumulateHingeJacobiBatches(const AngularJacobiBatch<4>& batch, Index begin, Index end);
Index accumulateIsometricBendJacobiBatches(const AngularJacobiBatch<4>& batch, Index begin,
                                           Index end);
Index accumulateAngleJacobiBatches(const AngularJacobiBatch<3>& batch, Index begin, Index end);

}  // namespace nucleon
