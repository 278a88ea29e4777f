// Contact with static sphere colliders: a unilateral position constraint per particle and sphere,
// C = |p − c| − (r + thickness) ≥ 0, projected between sweep rounds like the ground, with the same
// position-based Coulomb friction about the sphere's normal at the contact.
#pragma once

#include <cstddef>
#include <span>

#include "components/particles.h"
#include "nucleon/world.h"

namespace nucleon {

// Projects every free particle out of every sphere (in parallel; independent per particle).
void projectSpheres(ParticlePool& particles, std::span<const SphereCollider> spheres);

// Particles within `tolerance` of some sphere's contact surface.
std::size_t countSphereContacts(const ParticlePool& particles,
                                std::span<const SphereCollider> spheres, Real tolerance);

}  // namespace nucleon
