// Animated colliders and animated pins (ARCHITECTURE.md §4): where a kinematic track puts its
// particles at a time, and the two ends of a substep's animation.
//
//   animateKinematics (before predict): target ← the track's positions at the substep's end,
//                                        v ← (target − x) / h, so predict's p = x + h v is the
//                                        target up to rounding;
//   finishKinematics (after update):    x, p ← target, so the collider is exactly on its track at
//                                        every substep's end and rounding never accumulates.
//
// Animated particles (a collider's, or a pin group's) have inverse mass 0, so nothing in between
// moves them: over the substep they go from x to p along the straight line the collision code
// assumes. Every particle's work is its own, so the parallel loops give the same result for any
// thread count, and nothing here allocates.
#pragma once

#include <span>

#include "components/kinematic_tracks.h"
#include "components/particles.h"

namespace nucleon {

// The keyframed rigid part of a track's motion at time t.
struct RigidPose {
  Rotation rotation = Rotation::Identity();
  Vec3d translation = Vec3d::Zero();
};
RigidPose keyframePose(const KinematicTrack& track, double t);

// Curvature of the bend at time t, in rad/m.
double bendCurvature(const BendMotion& bend, double t);
// A point `r` relative to the pivot, bent with curvature `kappa` (BendMotion in object_def.h).
// The bend's axes must be unit and perpendicular.
Vec3d bendPoint(const BendMotion& bend, double kappa, const Vec3d& r);

// The positions a keyframed track gives to `rest` (its particles' rest positions, in the track's
// particle order) at time t.
void posePositions(const KinematicTrack& track, std::span<const Vec3> rest, double t,
                   std::span<Vec3> out);

// `substep` counts from 0 within a step of `substeps`; `endTime` is the world time the substep
// ends at.
void animateKinematics(KinematicTracks& kinematics, ParticlePool& particles, int substep,
                       int substeps, double endTime, Real h);
void finishKinematics(const KinematicTracks& kinematics, ParticlePool& particles);

// The farthest any animated particle (of a collider or a pin group) travels over the world times
// [t0, t1]: per particle, the length of its path through kTravelSamples equal parts of the
// interval (a turn's arc by its chords, at least 99% of it for turns up to half a turn per
// interval), the largest of them. A collider driven by targets goes in a straight line from where
// it is to its goal (nowhere without one).
constexpr int kTravelSamples = 8;
double kinematicTravel(const KinematicTracks& kinematics, const ParticlePool& particles, double t0,
                       double t1);

}  // namespace nucleon
