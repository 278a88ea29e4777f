#include "systems/dynamics/kinematic_motion.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace nucleon {
namespace {

// Particles per task: posing a vertex is a few dozen flops, so tasks must be long to pay off.
constexpr std::size_t kGrain = 2048;

// sin(x) / x without the cancellation near 0 (the next term of the series is below double
// rounding for |x| < 1e-4).
double sinc(double x) {
  return std::abs(x) < 1e-4 ? 1 - x * x / 6 : std::sin(x) / x;
}

template <typename F>
void forEachParticle(Index count, F&& body) {
  tbb::parallel_for(tbb::blocked_range<Index>(0, count, kGrain),
                    [&](const tbb::blocked_range<Index>& r) {
                      for (Index i = r.begin(); i != r.end(); ++i) body(i);
                    });
}

}  // namespace

RigidPose keyframePose(const KinematicTrack& track, double t) {
  const std::vector<double>& times = track.times;
  if (times.empty()) return {};
  if (track.loop && times.size() >= 2 && t > times.back()) {
    const double period = times.back() - times.front();
    t = times.front() + std::fmod(t - times.front(), period);
  }
  if (t <= times.front()) return {track.rotations.front(), track.translations.front()};
  if (t >= times.back()) return {track.rotations.back(), track.translations.back()};
  // times[a] <= t < times[b]: at a keyframe's own time the fraction is exactly 0, so the pose is
  // exactly that keyframe's.
  const std::size_t b =
      static_cast<std::size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
  const std::size_t a = b - 1;
  const double u = (t - times[a]) / (times[b] - times[a]);
  RigidPose pose;
  pose.translation = track.translations[a] + u * (track.translations[b] - track.translations[a]);
  pose.rotation = track.rotations[a].slerp(u, track.rotations[b]);
  return pose;
}

double bendCurvature(const BendMotion& bend, double t) {
  if (bend.curvature == 0) return 0;
  return bend.curvature * std::sin(2 * std::numbers::pi * bend.frequency * t);
}

// With u = along, n = axis × along and the rest point r = s u + y n + z axis, the line y = z = 0
// becomes the arc of radius R = 1/κ about the centre R n, and r rides on the arc's normal at
// arc length s, keeping its offsets y and z:
//   r' = (R − y) sin θ u + (R − (R − y) cos θ) n + z axis,   θ = κ s.
// Written with sinc so that κ → 0 gives r back without dividing by κ:
//   (R − y) sin θ = s sinc θ − y sin θ,   R (1 − cos θ) = s (θ/2) sinc²(θ/2).
Vec3d bendPoint(const BendMotion& bend, double kappa, const Vec3d& r) {
  const Vec3d n = bend.axis.cross(bend.along);
  const double s = r.dot(bend.along), y = r.dot(n), z = r.dot(bend.axis);
  const double theta = kappa * s;
  const double half = sinc(theta / 2);
  const double alongPart = s * sinc(theta) - y * std::sin(theta);
  const double normalPart = s * (theta / 2) * half * half + y * std::cos(theta);
  return alongPart * bend.along + normalPart * n + z * bend.axis;
}

namespace {

// A track's pose at one time, ready to place points: its rotation as a matrix, where the pivot
// goes, and the bend's curvature.
struct PoseAt {
  Eigen::Matrix3d rotation;
  Vec3d shift;
  double kappa;
};

PoseAt poseAt(const KinematicTrack& track, double t) {
  const RigidPose pose = keyframePose(track, t);
  return {pose.rotation.toRotationMatrix(), track.pivot + pose.translation,
          bendCurvature(track.bend, t)};
}

// Where `pose` puts the point whose rest position is `rest`: bent, then turned about the pivot
// and moved.
Vec3d placed(const KinematicTrack& track, const PoseAt& pose, const Vec3d& rest) {
  Vec3d r = rest - track.pivot;
  if (pose.kappa != 0) r = bendPoint(track.bend, pose.kappa, r);
  return pose.rotation * r + pose.shift;
}

// Poses `count` particles with the track's motion at time t: `rest(i)` is the i-th one's rest
// position.
template <typename RestOf>
void poseEach(const KinematicTrack& track, Index count, RestOf&& rest, double t, Vec3* out) {
  const PoseAt pose = poseAt(track, t);
  forEachParticle(count, [&](Index i) {
    out[i] = placed(track, pose, rest(i).template cast<double>()).template cast<Real>();
  });
}

}  // namespace

void posePositions(const KinematicTrack& track, std::span<const Vec3> rest, double t,
                   std::span<Vec3> out) {
  const Index count = static_cast<Index>(std::min(rest.size(), out.size()));
  poseEach(
      track, count, [&](Index i) -> const Vec3& { return rest[i]; }, t, out.data());
}

void animateKinematics(KinematicTracks& kinematics, ParticlePool& particles, int substep,
                       int substeps, double endTime, Real h) {
  for (KinematicTrack& track : kinematics.tracks) {
    Vec3* target = kinematics.target.data() + track.firstTarget;
    auto x = [&](Index i) -> const Vec3& { return particles.x[track.particle(i)]; };
    if (!track.drivenByTargets) {
      poseEach(
          track, track.particleCount,
          [&](Index i) -> const Vec3& { return particles.restPosition[track.particle(i)]; },
          endTime, target);
    } else if (!track.targetsPending) {  // no targets for this step: hold still
      forEachParticle(track.particleCount, [&](Index i) { target[i] = x(i); });
    } else {
      if (substep == 0)
        forEachParticle(track.particleCount, [&](Index i) { track.stepStart[i] = x(i); });
      if (substep + 1 == substeps) {  // the last substep lands exactly on the goal
        std::copy(track.goal.begin(), track.goal.end(), target);
        track.targetsPending = false;
      } else {
        const Real f = static_cast<Real>(substep + 1) / static_cast<Real>(substeps);
        forEachParticle(track.particleCount, [&](Index i) {
          target[i] = track.stepStart[i] + f * (track.goal[i] - track.stepStart[i]);
        });
      }
    }
    forEachParticle(track.particleCount,
                    [&](Index i) { particles.v[track.particle(i)] = (target[i] - x(i)) / h; });
  }
}

void finishKinematics(const KinematicTracks& kinematics, ParticlePool& particles) {
  for (const KinematicTrack& track : kinematics.tracks) {
    const Vec3* target = kinematics.target.data() + track.firstTarget;
    forEachParticle(track.particleCount, [&](Index i) {
      const Index particle = track.particle(i);
      particles.x[particle] = target[i];
      particles.p[particle] = target[i];
    });
  }
}

double kinematicTravel(const KinematicTracks& kinematics, const ParticlePool& particles, double t0,
                       double t1) {
  double farthest = 0;
  for (const KinematicTrack& track : kinematics.tracks) {
    const Index count = track.particleCount;
    if (track.drivenByTargets) {
      if (!track.targetsPending) continue;
      for (Index i = 0; i < count; ++i)
        farthest = std::max(
            farthest,
            double((track.goal[i] - particles.x[track.particle(i)]).cast<double>().norm()));
      continue;
    }
    // The pose at each sample time, then every particle along them.
    std::array<PoseAt, kTravelSamples + 1> poses;
    for (int k = 0; k <= kTravelSamples; ++k)
      poses[k] = poseAt(track, t0 + (t1 - t0) * k / kTravelSamples);
    // The largest of per-particle lengths: the same for any split of the particles.
    const double trackFarthest = tbb::parallel_reduce(
        tbb::blocked_range<Index>(0, count, kGrain), 0.0,
        [&](const tbb::blocked_range<Index>& r, double most) {
          for (Index i = r.begin(); i != r.end(); ++i) {
            const Vec3d rest = particles.restPosition[track.particle(i)].cast<double>();
            Vec3d previous = placed(track, poses[0], rest);
            double length = 0;
            for (int k = 1; k <= kTravelSamples; ++k) {
              const Vec3d next = placed(track, poses[k], rest);
              length += (next - previous).norm();
              previous = next;
            }
            most = std::max(most, length);
          }
          return most;
        },
        [](double a, double b) { return std::max(a, b); });
    farthest = std::max(farthest, trackFarthest);
  }
  return farthest;
}

}  // namespace nucleon
