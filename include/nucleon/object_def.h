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

// A pose of an animated collider at one time: the rest shape turned by `angle` radians
// (right-handed) about `axis` through the motion's pivot, then moved by `translation`.
struct Keyframe {
  double time = 0;  // seconds of simulated time since the world was created
  Vec3d translation = Vec3d::Zero();
  Vec3d axis = Vec3d(0, 1, 0);  // any non-zero length; only its direction counts
  double angle = 0;             // radians
};

// A non-rigid bend of the rest shape, applied before the keyframed pose. The line through the
// pivot along `along` is bent into a circular arc in the plane normal to `axis`, with curvature
// κ(t) = curvature · sin(2π · frequency · t) radians per metre; every point keeps its distance
// from that arc (it rides on the arc's normal plane), so lengths along the line are preserved. A
// positive κ turns `along` towards axis × along. κ(0) = 0: the body starts unbent.
struct BendMotion {
  Vec3d axis = Vec3d(0, 0, 1);   // the bend's rotation axis, perpendicular to `along`
  Vec3d along = Vec3d(1, 0, 0);  // the direction of the line that is bent
  double curvature = 0;          // peak curvature, rad/m; 0 = no bend
  double frequency = 0;          // Hz, positive when curvature is not 0
};

// How a collider, or a group of pins (PinGroup), is animated. Its vertex positions at time t are
// the rest vertices bent by `bend`, then turned and moved by the keyframed pose (translation
// linear, rotation by slerp between keyframes, taking the shorter way round: a turn of half a
// revolution or more needs keyframes in between). Before the first keyframe the first is held,
// after the last the last (or, with `loop`, the keyframes repeat with period last.time −
// first.time).
struct ColliderMotion {
  Vec3d pivot = Vec3d::Zero();
  std::vector<Keyframe> keyframes;  // strictly increasing times
  bool loop = false;
  BendMotion bend;
  bool animated() const { return !keyframes.empty() || bend.curvature != 0; }
};

// Pinned vertices of a cloth, rope, solid or particle cloud that follow a motion exactly as an
// animated collider's vertices do (ARCHITECTURE.md §4): at the end of every substep each is where
// `motion` puts its rest position at that time, and over the substep it moves in a straight line.
// They have inverse mass 0, like pins; the rest of the object follows them through its
// constraints and collides with them as with any kinematic primitive.
struct PinGroup {
  std::vector<Index> vertices;  // non-empty, distinct, in no other group and not in `pins`
  ColliderMotion motion;        // keyframes, a bend or both (animated() is true)
};

// An object defined by its rest shape. The simplices index `vertices`.
struct ObjectDef {
  std::string name;
  std::vector<Vec3> vertices;
  std::vector<std::array<Index, 2>> edges;      // ropes / curves
  std::vector<std::array<Index, 3>> triangles;  // cloth, colliders
  std::vector<std::array<Index, 4>> tets;       // soft solids
  Material material;
  std::vector<Index> pins;  // vertices held in place (inverse mass 0)
  // Not colliders: groups of pinned vertices, each moved by its own motion. Like a collider's
  // motion, it is evaluated at the world's time when the object is added.
  std::vector<PinGroup> pinGroups;
  Vec3 velocity = Vec3::Zero();  // initial velocity; for a kinematic collider, its constant motion
  // Colliders only: an animation that replaces the constant velocity (which must then be zero).
  ColliderMotion motion;
  // Sweep counts for this object's constraints; empty = the world's schedule. The interleaving
  // order is always the world's.
  Schedule schedule;
};

}  // namespace nucleon
