// Objects as the API creates them: kinds, handles and the rest-shape definition.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "nucleon/material.h"
#include "nucleon/schedule.h"
#include "nucleon/types.h"

namespace nucleon {

enum class ObjectKind { Cloth, Rope, Solid, Particles, Collider };
const char* toString(ObjectKind kind);

// Generational handle of an object. index1 is 1-based so that a value-initialised id is null.
struct ObjectId {
  std::uint32_t index1 = 0;
  std::uint32_t generation = 0;
  bool valid() const { return index1 != 0; }
};

// An object defined by its rest shape. The simplices index `vertices`.
struct ObjectDef {
  std::string name;
  std::vector<Vec3> vertices;
  std::vector<std::array<Index, 2>> edges;      // ropes / curves
  std::vector<std::array<Index, 3>> triangles;  // cloth, colliders
  std::vector<std::array<Index, 4>> tets;       // soft solids
  Material material;
  std::vector<Index> pins;       // vertices held in place (inverse mass 0)
  Vec3 velocity = Vec3::Zero();  // initial velocity; for a kinematic collider, its constant motion
  // Sweep counts for this object's constraints; empty = the world's schedule. The interleaving
  // order is always the world's.
  Schedule schedule;
};

}  // namespace nucleon
