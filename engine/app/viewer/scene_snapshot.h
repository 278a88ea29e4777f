// What the viewer draws of a world at one instant, copied by the simulation thread after a step
// so that drawing never waits for the solver (view_command.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "nucleon/world.h"

namespace nucleon::viewer {

struct ObjectSnapshot {
  std::string name;
  ObjectKind kind = ObjectKind::Cloth;
  std::vector<Vec3> x;
  std::vector<std::array<Index, 3>> triangles;
  std::vector<std::array<Index, 2>> edges;  // ropes
  std::vector<float> strain;                // per vertex: the most strained incident edge
  float radius = 0;                         // the contact thickness: particles' and ropes' size
};

// The per-stage profile of the last step, in ms.
struct StageTimes {
  double forces = 0, predict = 0, solve = 0, cascade = 0, broadPhase = 0, narrowPhase = 0,
         collisions = 0, update = 0;
};

struct SceneSnapshot {
  std::uint64_t frame = 0;  // steps taken
  double time = 0;
  std::vector<ObjectSnapshot> objects;
  std::vector<SphereCollider> spheres;
  std::vector<Vec3> contactPoints;  // World::contactPoints
  GroundPlane ground;
  double stepMs = 0;
  StageTimes stages;
  double meanStrain = 0, maxStrain = 0;  // of the drawn edges (takeSnapshot)
  std::uint64_t contacts = 0, recoveries = 0;
};

// Copies the world's objects into `out`, reusing its storage; `rest` holds each object's first
// positions (the rest shape of every bundled kind), from which the strain colours are taken.
void takeSnapshot(const World& world, const std::vector<std::vector<Vec3>>& rest,
                  SceneSnapshot& out);

}  // namespace nucleon::viewer
