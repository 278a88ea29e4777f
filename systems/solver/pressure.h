// The pressure of closed cloth surfaces (Material::pressure), solved with the constraints: one
// compliant constraint per surface on its enclosed volume V (XPBD, Macklin et al. 2016),
//   ∂V/∂x_k = Σ over k's triangles (k, a, b) of (x_a × x_b)/6 = a third of the sum of their area
//   vectors ½ (x_a − x_k) × (x_b − x_k) on a closed surface (computed so: one cross product per
//   triangle),   S = Σ_k w_k ‖∂V/∂x_k‖²,
//   Δx_k = w_k ∂V/∂x_k Δλ, and the force on the surface is (λ/h²) ∂V/∂x_k.
// KeepVolume: C = V − V*, Δλ = (−C − α̃λ)/(S + α̃), α̃ = α/h².
// Gas (P·V = c·M): the force must be the pressure difference, λ/h² = c·M/V − P_ambient. Newton's
// step on that equation with V linearised along the correction, V + S Δλ, is the XPBD step of a
// constraint whose compliance is the gas's compressibility at V, α = V/P:
//   Δλ = (h² (P − P_ambient) − λ) / (1 + h² S P / V),   P = c·M / V.
#pragma once

#include <span>

#include "components/objects.h"
#include "components/particles.h"
#include "components/pressure_pool.h"

namespace nucleon {

// Appends the pressured surface of `record` (object number `objectIndex`, its particles already
// in the pool at record.firstParticle): its vertices, the incidence of their triangles, its rest
// volume and its starting gas. The caller has checked that the surface is closed.
void appendPressureSurface(PressurePool& pool, const ObjectRecord& record,
                           std::uint32_t objectIndex);

// At a substep's start (positions x, the world's time `time`, substep h): the multipliers reset,
// and each gas's pump and leak applied over the substep.
void startPressureSubstep(PressurePool& pool, double time, Real h);

// One projection of every surface's volume constraint on the predicted positions p (with
// `objectRuns`, only the surfaces of the objects it marks: a per-object schedule's round).
void projectPressure(PressurePool& pool, ParticlePool& particles, Real h,
                     const std::uint8_t* objectRuns = nullptr);

// The enclosed volume of surface `s` at positions x (m³).
double pressureVolume(const PressurePool& pool, std::size_t s, std::span<const Vec3> x);

}  // namespace nucleon
