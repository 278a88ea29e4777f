// Per tearable cloth (Material::tear): how long each edge has been over-stretched, which vertices
// are torn copies of which, and the spare particles still free. Cold data, read and written
// between steps by systems/topology/tear_cloth.*; the collision primitives copy `origin` of the
// lips that have opened (ARCHITECTURE.md §2, "Tearing").
#pragma once

#include <cstdint>
#include <vector>

#include "nucleon/types.h"

namespace nucleon {

struct TearState {
  // Particles reserved right after the object's own: [firstParticle + particleCount,
  // firstParticle + particleCount + spareParticles). Inert until a split takes one.
  Index spareParticles = 0;
  // Per edge of the object's complex, in its order: consecutive seconds above the threshold.
  std::vector<double> overTime;
  // Per local vertex: the vertex of the untorn cloth it descends from (itself if never split).
  // Empty until the first tear.
  std::vector<Index> origin;
  // Per local vertex: 1 once it stands farther than the contact distance from every other vertex
  // of the same origin. Until then the lips of a fresh cut keep the rest shape's exemption from
  // self-contact (they start coincident); afterwards pairs across the cut collide.
  std::vector<std::uint8_t> opened;
};

}  // namespace nucleon
