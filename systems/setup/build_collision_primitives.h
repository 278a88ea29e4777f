// Builds the collision primitive lists (components/collision_primitives.h) from the object table:
// part of the derived tables, rebuilt when the topology changes.
#pragma once

#include <cstdint>
#include <vector>

#include "components/collision_primitives.h"
#include "components/objects.h"

namespace nucleon {

// Points, edges and triangles of every object by its kind and collision flags, with radii from
// its thickness, in global particle indices and object order. `excludedObjectPairs` holds
// CollisionPrimitives::pairKey values of object pairs that must not collide; objects whose
// material turns self-collision off are added as (a, a).
// `excludedVertexSets` holds pairs of particle lists (global indices) whose primitives never
// collide with each other (at most 16 pairs); `particleCount` sizes the sets' masks.
struct VertexSetExclusion {
  std::vector<Index> a, b;
};
void buildCollisionPrimitives(CollisionPrimitives& out, const std::vector<ObjectRecord>& objects,
                              const std::vector<std::uint64_t>& excludedObjectPairs,
                              const std::vector<VertexSetExclusion>& excludedVertexSets = {},
                              std::size_t particleCount = 0);

}  // namespace nucleon
