// The projection of collider contacts (systems/collision/particle_contacts.h, projectContacts)
// for the common case of a particle with one contact: many contacts at once, written as one loop
// of independent lanes so that the compiler runs 4, 8 or 16 side by side (positions gathered by
// particle index). Each lane computes what projectContact computes, operation for operation and
// in the same order (Eigen's sums of three included), so the result is the same bits.
#pragma once

#include <cstddef>
#include <cstdint>

#include "components/collider_pool.h"
#include "components/contact_pool.h"
#include "components/particles.h"

namespace nucleon {

// Projects contacts [begin, end), each the only contact of its particle (no two share one):
// the push out along the normal (λ += −C where C < 0), then friction over the substep, as
// projectContact does for one. Every collider must be a plane of radius 0 or a sphere of positive
// radius: the lanes tell them apart by the radius (projectContacts checks it).
void projectSingleContacts(ContactPool& contacts, const ColliderPool& colliders,
                           ParticlePool& particles, std::size_t begin, std::size_t end);

// Detection's predicate (particle_contacts.cpp, needsContact) for particles [begin, end) at once:
// count[i] is how many colliders particle i gets a contact with, those whose contact surface its
// motion x → x + h v comes within reach of (the motion's length + `contactReach` + extraReach[i],
// from either end), or its motion x → reached[i], where `reached` is given; 0 where w = 0; and
// bit k of colliderBits[i] says whether collider k is one of them. The gaps, lengths and
// comparisons are the scalar predicate's operations in its order, so every count is the scalar
// one. `extraReach` may be null (no extra reach). Colliders as above, and at most kLaneColliders.
constexpr std::size_t kLaneColliders = 32;
void countCollidersInReach(const ColliderPool& colliders, const ParticlePool& particles, Real h,
                           Real contactReach, const Real* extraReach, const Vec3* reached,
                           std::size_t begin, std::size_t end, Index* count, Index* colliderBits);

// addReachedContacts' first pass (particle_contacts.cpp) for particles [begin, end) at once: for
// each particle with w ≠ 0 and no contact (runStart[i] == runStart[i + 1]), count[i] and
// colliderBits[i] as countCollidersInReach gives them with reached = p; 0 for the others. Returns
// whether one of those particles' motion x → p comes within the reach without the extra reach of
// some collider (contactsMissing's test). The scalar predicate's bits, colliders as above.
bool countMissingContacts(const ColliderPool& colliders, const ParticlePool& particles, Real h,
                          Real contactReach, const Real* extraReach, const Index* runStart,
                          std::size_t begin, std::size_t end, Index* count, Index* colliderBits);

// Each contact's normal and depth (−gap) at its particle's predicted position x + h v, for
// contacts [begin, end): what detectContacts stores with a new contact, the same bits as
// surfaceAt. Colliders as above.
void setPredictedSurfaces(ContactPool& contacts, const ColliderPool& colliders,
                          const ParticlePool& particles, Real h, std::size_t begin,
                          std::size_t end);

// inside[i − begin] for particles [begin, end): whether p lies inside some collider's contact
// surface (gap < 0), each collider's gap taken at p as it is, the test that starts
// resolveMissedContacts' repair of a particle. Colliders as above.
void markInsideColliders(const ColliderPool& colliders, const ParticlePool& particles,
                         std::size_t begin, std::size_t end, std::uint8_t* inside);

}  // namespace nucleon
