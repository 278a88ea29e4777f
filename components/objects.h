// Object table: what each entity is made of. Cold data: read when building pools, measuring and
// writing output, never inside a sweep.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "components/simplicial_complex.h"
#include "components/tear_state.h"
#include "nucleon/object_def.h"

namespace nucleon {

struct ObjectRecord {
  std::string name;
  ObjectKind kind = ObjectKind::Particles;
  Index slot = 0;           // its handle's entry in the slot table (ObjectId::index1 − 1)
  Index firstParticle = 0;  // the object's particles are [firstParticle, firstParticle + count)
  Index particleCount = 0;
  Material material;
  SimplicialComplex complex;                  // local vertex indices
  std::vector<std::array<Index, 3>> surface;  // oriented surface triangles, local indices
  bool closed = false;                        // the surface bounds a volume
  double restVolume = 0;                      // enclosed volume in the rest shape
  Schedule schedule;                          // empty: the world's
  TearState tear;                             // tearable cloth only (Material::tear)
};

// An entry of the slot table behind ObjectId (index1 − 1): the object it names now (its index in
// the object table, which stays dense), or kNoObject once that object is removed. Removal counts
// the generation up, so an id of a removed object never names the object a reused slot gets.
struct ObjectSlot {
  static constexpr Index kNoObject = ~Index{0};
  Index object = kNoObject;
  std::uint32_t generation = 1;
};

}  // namespace nucleon
