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
void buildCollisionPrimitives(CollisionPrimitives& out, const std::vector<ObjectRecord>& objects,
                              const std::vector<std::uint64_t>& excludedObjectPairs);

}  // namespace nucleon
