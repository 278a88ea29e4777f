// The explicit parts of a substep (ARCHITECTURE.md §2): "implicit on velocity, explicit on
// position".
//
//   1. applyForces:      v ← v + h g                    (free particles only, w > 0)
//   2. predictPositions: p ← x + h v                    (the state the constraints are solved at)
//   3. (constraint sweeps move p; a move Δp is the velocity change δv = Δp / h)
//   4. updateState:      v ← v + (p − (x + h v)) / h,  x ← p
//
// An unconstrained particle therefore follows symplectic Euler exactly:
//   v_{n+1} = v_n + h g,  x_{n+1} = x_n + h v_{n+1}.
#pragma once

#include "components/particles.h"

namespace nucleon {

void applyForces(ParticlePool& particles, const Vec3& gravity, Real h);
void predictPositions(ParticlePool& particles, Real h);
// Returns the number of particles whose new state was not finite; those keep their position and
// lose their velocity, so one bad constraint cannot spread NaN through the state.
std::size_t updateState(ParticlePool& particles, Real h);

}  // namespace nucleon
