// The liquids' velocity pass, after the velocity update of every substep (ARCHITECTURE.md §2):
// what position-based fluids add to the velocities (Macklin and Müller 2013, §5), with
// V_j = m_j/ρ_j and ∇W_ij = ∇W(x_i − x_j) (spiky):
//   vorticity ω_i = Σ_j V_j ∇W_ij × (v_j − v_i), and confinement (eq. 16, Fedkiw et al. 2001)
//     v_i += h ε (N × ω_i), N = η/|η|, η = Σ_j V_j (|ω_j| − |ω_i|) ∇W_ij;
//   surface tension (Akinci et al. 2013, eqs. 1–7): cohesion and curvature,
//     v_i += −h γ Σ_j K_ij (m_j C(r_ij) x̂_ij + (n_i − n_j)), K_ij = 2ρ0/(ρ_i + ρ_j),
//     n_i = H Σ_j V_j ∇W_ij;
//   XSPH viscosity (eq. 17): v_i += c Σ_j V_j (v_j − v_i) W_ij.
// Each term reads the velocities from before the pass, so the result does not depend on the
// order or the thread count.
#pragma once

#include "components/liquid_pool.h"
#include "components/particles.h"

namespace nucleon {

// Applies the pass to every liquid particle with w > 0, over the neighbour lists the substep
// found at its start (distances measured anew at x). Does nothing when no liquid has viscosity,
// vorticity or surface tension.
void applyLiquidVelocities(LiquidPool& pool, ParticlePool& particles, Real h);

}  // namespace nucleon
