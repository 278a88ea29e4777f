// The density constraints of the liquids (position-based fluids, Macklin and Müller 2013;
// ARCHITECTURE.md §2), one per particle:
//   C_i = ρ_i/ρ0 − 1 ≥ 0,   ρ_i = Σ_j m_j W(p_i − p_j)   (poly6, itself included),
//   ∇_j C_i = −(m_j/ρ0) ∇W(p_i − p_j),   ∇_i C_i = (1/ρ0) Σ_j m_j ∇W(p_i − p_j)   (spiky),
//   λ_i = −C_i / (Σ_k w_k |∇_k C_i|² + ε)   (eq. 11),
//   Δp_i = w_i Σ_j (λ_i m_j/ρ0_i + λ_j m_i/ρ0_j + s_corr m_j/ρ0_i) ∇W(p_i − p_j)   (eq. 12, 14
//   with masses: each constraint moves a particle by w ∇C λ),
//   s_corr = −k (W(p_i − p_j)/W(Δq))^n   (eq. 13, artificial pressure).
// The constraint holds the density from above only: a liquid resists compression, while a
// particle at the free surface, short of neighbours, is not pulled inwards (that is surface
// tension's job), which removes the tensile instability at the surface. Jacobi over particles:
// every λ from the same positions, then every Δp, then the moves, so the result does not
// depend on the thread count.
#pragma once

#include <span>
#include <vector>

#include "components/liquid_pool.h"
#include "components/particles.h"

namespace nucleon {

// The kernel radius H = kernelScale · d, d = (m/ρ0)^(1/3), of a liquid of `count` particles
// weighing `mass` in all.
Real liquidKernelRadius(const Liquid& liquid, Real mass, std::size_t count);

// Appends a liquid object (object number `objectIndex`, its particles already in the pool at
// [first, first + count) with their inverse masses). The caller has checked that its kernel
// radius is the pool's (or that the pool is empty).
void appendLiquidObject(LiquidPool& pool, std::uint32_t objectIndex, Index first, std::size_t count,
                        const Liquid& liquid, Real mass);

// At a substep's start: the neighbour lists from the predicted positions p.
void startLiquidSubstep(LiquidPool& pool, const ParticlePool& particles);

// One Jacobi projection of every liquid particle's density constraint on p (with `objectRuns`,
// only the particles of the objects it marks). A move longer than maxMove is shortened to it and
// counted in pool.limitedMoves.
void projectDensity(LiquidPool& pool, ParticlePool& particles, Real maxMove,
                    const std::uint8_t* objectRuns = nullptr);

// Each liquid particle's SPH density (kg/m³) at positions x, in the pool's list order (neighbours
// found anew from x; the pool is not changed).
std::vector<Real> liquidDensities(const LiquidPool& pool, std::span<const Vec3> x);

}  // namespace nucleon
