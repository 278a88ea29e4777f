// Particle pool: the 0-simplices every object is made of, as structure of arrays.
//
// Hot data (what every sweep touches) is x, v, w and the predicted positions p; everything about
// which object a particle belongs to beyond its phase lives in the object table. Per particle the
// hot record is 12 (x) + 12 (v) + 12 (p) + 4 (w) = 40 bytes in float.
#pragma once

#include <vector>

#include "nucleon/types.h"

namespace nucleon {

struct ParticlePool {
  std::vector<Vec3> x;               // position at the start of the substep
  std::vector<Vec3> v;               // velocity
  std::vector<Vec3> p;               // predicted position x + h v, moved by constraint sweeps
  std::vector<Real> w;               // inverse mass; 0 = pinned or kinematic
  std::vector<std::uint32_t> phase;  // object id the particle belongs to
  std::vector<Vec3> restPosition;    // cold: the shape the object was created in

  std::size_t size() const { return x.size(); }

  // Appends n particles and returns the index of the first.
  Index append(std::size_t n) {
    const Index first = static_cast<Index>(x.size());
    const std::size_t total = x.size() + n;
    x.resize(total, Vec3::Zero());
    v.resize(total, Vec3::Zero());
    p.resize(total, Vec3::Zero());
    w.resize(total, Real(0));
    phase.resize(total, 0);
    restPosition.resize(total, Vec3::Zero());
    return first;
  }
};

static_assert(sizeof(Vec3) * 3 + sizeof(Real) == 10 * sizeof(Real), "hot particle record budget");

}  // namespace nucleon
