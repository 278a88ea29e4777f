// Colliders without a mesh: the ground, tilted planes and static spheres. Inside the solver they
// are one list of collider kinds (components/collider_pool.h).
#pragma once

#include "nucleon/types.h"

namespace nucleon {

// A horizontal ground plane (y up). Particles stay `thickness` above it; friction is Coulomb's
// (μ_k sliding, μ_s sticking), bounding each substep's tangential motion by μ times the substep's
// normal correction.
struct GroundPlane {
  bool enabled = false;
  Real height = 0;
  Real thickness = Real(0.005);
  Real friction = Real(0.5);
  Real staticFriction = Real(0.6);
};

// A static sphere the particles may not enter (a collider without a mesh). Particles stay
// `thickness` outside its surface; friction as for the ground.
struct SphereCollider {
  Vec3 center = Vec3::Zero();
  Real radius = Real(0.5);
  Real thickness = Real(0.005);
  Real friction = Real(0.5);
  Real staticFriction = Real(0.6);
};

// A static plane of any orientation: the half-space behind `normal` is solid (a slope, a wall).
// `normal` need not be unit length but must not be zero. Particles stay `thickness` in front of
// it; friction as for the ground.
struct PlaneCollider {
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3(0, 1, 0);
  Real thickness = Real(0.005);
  Real friction = Real(0.5);
  Real staticFriction = Real(0.6);
};

}  // namespace nucleon
