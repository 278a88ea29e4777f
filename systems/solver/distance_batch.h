// Distance-type constraints (stretch, tether) projected eight at a time with AVX2 and FMA, for
// the colored Gauss–Seidel sweep: within a color no two constraints share a free particle, so a
// batch can gather its particles, project all eight at once and scatter the results. The
// projection is the undamped XPBD update of constraint_kernels.h (Macklin et al. 2016, eq. 18):
//   C = |x_a − x_b| − L,  Δλ = (−C − α̃λ) / (w_a + w_b + α̃),  x_a += w_a Δλ n,  x_b −= w_b Δλ n,
// with n = (x_a − x_b)/|x_a − x_b| and α̃ the stretch or compression compliance over h² by the
// side the multiplier ends on (the sign of (w_a + w_b) λ − C; kernel_detail::belowRest). Results
// equal the scalar path's up to floating-point rounding (FMA contraction).
#pragma once

#include <array>

#include "nucleon/types.h"
#include "systems/solver/batch_parameters.h"

namespace nucleon {

constexpr Index kDistanceBatchSize = 8;

// The batch's record (batch_parameters.h): in place, for colored Gauss–Seidel and the cascade.
using DistanceBatch = InPlaceBatch<2>;

// The Jacobi form of the same projection (batch_parameters.h): corrections into the slots
// correction[2c], correction[2c + 1].
using DistanceJacobiBatch = JacobiBatch<2>;

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
