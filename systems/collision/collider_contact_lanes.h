// The projection of collider contacts (systems/collision/particle_contacts.h, projectContacts)
// for the common case of a particle with one contact: many contacts at once, written as one loop
// of independent lanes so that the compiler runs 4, 8 or 16 side by side (positions gathered by
// particle index). Each lane computes what projectContact computes, operation for operation and
// in the same order (Eigen's sums of three included), so the result is the same bits.
#pragma once

#include <cstddef>

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

}  // namespace nucleon
