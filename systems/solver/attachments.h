// Attachments (nucleon/attachments.h) in the solve: each an XPBD constraint on its particles
// (Macklin et al. 2016, eq. 18 without damping),
//   Δλ = (−C − α̃ λ) / (Σ_k w_k |∇_k C|² + α̃),   Δx_k = w_k ∇_k C Δλ,   α̃ = α/h²,
// with, for a target point q = Σ β_k x_k of the surface kinds, ∇_a C = n and ∇_k C = −β_k n.
// Projected one after another in the pool's order (attachments share particles: a seam's welds
// chain along it), so the result is the same for any thread count.
#pragma once

#include "components/attachment_pool.h"
#include "components/particles.h"

namespace nucleon {

// At a substep's start: multipliers reset, and the handles' targets set to where their tracks
// put them at `endTime`.
void startAttachmentSubstep(AttachmentPool& pool, double endTime);

// One projection of every attachment that has not broken, on the predicted positions p (with
// `objectRuns`, only those whose attached particle's object it marks).
void projectAttachments(AttachmentPool& pool, ParticlePool& particles, Real h,
                        const std::uint8_t* objectRuns = nullptr);

// After the solve: an attachment whose force |λ|/h² exceeded its strength breaks. Returns how
// many broke.
std::size_t breakAttachments(AttachmentPool& pool, Real h);

}  // namespace nucleon
