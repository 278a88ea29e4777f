// Kinematic tracks: how each animated collider and each group of animated pins moves
// (ARCHITECTURE.md §4). Static lifetime: a track is made when its object is added; the target
// buffer keeps its size, so animating a substep allocates nothing.
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "nucleon/object_def.h"
#include "nucleon/types.h"

namespace nucleon {

using Rotation = Eigen::Quaternion<double, Eigen::DontAlign>;

struct KinematicTrack {
  Index object = 0;  // index in the object table
  // The particles the track moves, particleCount of them: a collider's contiguous run from
  // firstParticle when `particles` is empty, else the listed particles (global indices, distinct:
  // the vertices of a pin group, in the group's order).
  Index firstParticle = 0;
  Index particleCount = 0;
  std::vector<Index> particles;
  Index firstTarget = 0;  // the track's run in KinematicTracks::target

  // The global index of the track's i-th particle.
  Index particle(Index i) const { return particles.empty() ? firstParticle + i : particles[i]; }

  // Keyframed motion, in double: the pose is evaluated at world times that grow without bound.
  Vec3d pivot = Vec3d::Zero();
  std::vector<double> times;        // strictly increasing; empty = the identity pose
  std::vector<Vec3d> translations;  // per keyframe
  std::vector<Rotation> rotations;  // per keyframe, unit quaternions
  bool loop = false;
  BendMotion bend;  // axes normalised; curvature 0 = rigid

  // Targets set through the API (World::setColliderTargets) instead of a motion (colliders only,
  // so always a contiguous run): the collider goes linearly from `stepStart` to `goal` over the
  // substeps of the next step, then holds.
  bool drivenByTargets = false;
  bool targetsPending = false;  // `goal` is for the coming step
  std::vector<Vec3> goal;
  std::vector<Vec3> stepStart;
};

struct KinematicTracks {
  std::vector<KinematicTrack> tracks;
  // Per animated particle, track after track, in each track's particle order: where the particle is
  // at the end of the current substep. Written before predict, copied into x and p after update.
  std::vector<Vec3> target;

  bool empty() const { return tracks.empty(); }
};

}  // namespace nucleon
