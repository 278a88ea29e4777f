// The normal step of a primitive contact (systems/collision/primitive_contacts.h,
// projectPrimitiveContacts): one at a time for Gauss–Seidel, and many at once for the first half
// of a parallel backend's contact round, written as one loop of independent lanes so that the
// compiler runs 4, 8 or 16 contacts side by side (the particles' positions gathered by index).
// Each lane computes what the scalar step computes, operation for operation and in the same
// order, so the steps are the same bits.
#pragma once

#include <cstddef>

#include "components/particles.h"
#include "components/primitive_contact_pool.h"

namespace nucleon {

// The step Δλ of contact c at the current positions: C = n · Σ c_k p_k − distance must not be
// negative, and with stickiness s a separation C < s is pulled back to 0 as well.
inline Real primitiveContactStep(const PrimitiveContactPool& pool, const ParticlePool& particles,
                                 std::size_t c) {
  Vec3 sum = Vec3::Zero();
  for (int k = 0; k < 4; ++k) sum += pool.coefficient[c][k] * particles.p[pool.particles[c][k]];
  const Real C = pool.normal[c].dot(sum) - pool.distance[c];
  if (C >= pool.stickiness[c] || (C >= 0 && pool.stickiness[c] == 0)) return 0;
  const Real m = pool.inverseMass[c];
  return m > 0 ? -C / m : Real(0);
}

// For contacts [begin, end): step[c] = primitiveContactStep(pool, particles, c), bit for bit,
// and lambda[c] += step[c] × inverseMass[c]. Returns how many of the steps are not zero.
std::size_t primitiveContactSteps(PrimitiveContactPool& pool, const ParticlePool& particles,
                                  std::size_t begin, std::size_t end);

}  // namespace nucleon
