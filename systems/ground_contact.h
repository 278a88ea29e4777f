// Contact with a ground plane y = height: the one collider every scene may have without meshes.
// A unilateral position constraint per particle, C = y − (height + thickness) ≥ 0, projected
// between sweep rounds, with Coulomb friction applied to the motion of the substep (position-based
// friction, Macklin et al. 2014 §6): a particle whose tangential motion is below μ_s times its
// penetration sticks, otherwise it slides with its motion shortened by μ_k times the penetration.
#pragma once

#include <cstddef>

#include "components/particles.h"
#include "nucleon/world.h"

namespace nucleon {

// Projects every free particle out of the ground (in parallel; independent per particle).
void projectGround(ParticlePool& particles, const GroundPlane& ground);

// Particles within `tolerance` of the contact surface: the contacts reported in the stats.
std::size_t countGroundContacts(const ParticlePool& particles, const GroundPlane& ground,
                                Real tolerance);

}  // namespace nucleon
