// Kinematic tracks: how each animated collider moves (ARCHITECTURE.md §4). Static lifetime: a
// track is made when its collider is added; the target buffer keeps its size, so animating a
// substep allocates nothing.
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "nucleon/object_def.h"
#include "nucleon/types.h"

namespace nucleon {

using Rotation = Eigen::Quaternion<double, Eigen::DontAlign>;

struct KinematicTrack {
  Index object = 0;  // index in the object table
  Index firstParticle = 0;
  Index particleCount = 0;
  Index firstTarget = 0;  // the track's run in KinematicTracks::target

  // Keyframed motion, in double: the pose is evaluated at world times that grow without bound.
  Vec3d pivot = Vec3d::Zero();
  std::vector<double> times;        // strictly increasing; empty = the identity pose
  std::vector<Vec3d> translations;  // per keyframe
  std::vector<Rotation> rotations;  // per keyframe, unit quaternions
  bool loop = false;
  BendMotion bend;  // axes normalised; curvature 0 = rigid

  // Targets set through the API (World::setColliderTargets) instead of a motion: the collider
  // goes linearly from `stepStart` to `goal` over the substeps of the next step, then holds.
  bool drivenByTargets = false;
  bool targetsPending = false;  // `goal` is for the coming step
  std::vector<Vec3> goal;
  std::vector<Vec3> stepStart;
};

struct KinematicTracks {
  std::vector<KinematicTrack> tracks;
  // Per animated particle, track after track: where the particle is at the end of the current
  // substep. Written before predict, copied into x and p after update.
  std::vector<Vec3> target;

  bool empty() const { return tracks.empty(); }
};

}  // namespace nucleon
