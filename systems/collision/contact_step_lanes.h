// The normal step of many primitive contacts at once: the first half of a parallel backend's
// contact round (systems/collision/primitive_contacts.h, projectPrimitiveContacts), written as
// one loop of independent lanes so that the compiler runs 4, 8 or 16 contacts side by side (the
// particles' positions gathered by index). Each lane computes what the scalar contact step
// computes, operation for operation and in the same order, so the steps are the same bits.
#pragma once

#include <cstddef>

#include "components/particles.h"
#include "components/primitive_contact_pool.h"

namespace nucleon {

// For contacts [begin, end): step[c] = Δλ of C = n · Σ c_k p_k − distance ≥ 0 at the current
// positions (0 where the contact holds, or is separated by no more than its stickiness), and
// lambda[c] += step[c] × inverseMass[c].
void primitiveContactSteps(PrimitiveContactPool& pool, const ParticlePool& particles,
                           std::size_t begin, std::size_t end);

}  // namespace nucleon
