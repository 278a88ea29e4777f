#include "systems/solver/attachments.h"

#include <cmath>

#include "systems/dynamics/kinematic_motion.h"

namespace nucleon {

void startAttachmentSubstep(AttachmentPool& pool, double endTime) {
  std::fill(pool.lambda.begin(), pool.lambda.end(), 0.0);
  for (std::size_t i = 0; i < pool.size(); ++i)
    if (pool.kind[i] == AttachmentKind::PointToTransform)
      posePositions(pool.tracks[pool.track[i]], std::span<const Vec3>(&pool.rest[i], 1), endTime,
                    std::span<Vec3>(&pool.target[i], 1));
}

void projectAttachments(AttachmentPool& pool, ParticlePool& particles, Real h,
                        const std::uint8_t* objectRuns) {
  const double h2 = double(h) * double(h);
  for (std::size_t i = 0; i < pool.size(); ++i) {
    if (pool.broken[i] || pool.removed[i]) continue;
    const auto& ids = pool.particles[i];
    if (objectRuns && !objectRuns[particles.phase[ids[0]]]) continue;
    const AttachmentKind kind = pool.kind[i];
    Vec3d target;
    Vec3d normal;  // ∇ of C with respect to the attached particle
    double c, targetWeight = 0;
    const Vec3d x = particles.p[ids[0]].cast<double>();
    const double wa = double(particles.w[ids[0]]);
    const bool surface =
        kind == AttachmentKind::PointToSurface || kind == AttachmentKind::SlideOnSurface;
    if (kind == AttachmentKind::PointToTransform) {
      target = pool.target[i].cast<double>();
    } else if (kind == AttachmentKind::PointToPoint) {
      target = particles.p[ids[1]].cast<double>();
      targetWeight = double(particles.w[ids[1]]);
    } else {
      target = Vec3d::Zero();
      for (int k = 0; k < 3; ++k) {
        const double beta = double(pool.weights[i][k]);
        target += beta * particles.p[ids[k + 1]].cast<double>();
        targetWeight += beta * beta * double(particles.w[ids[k + 1]]);
      }
    }
    if (kind == AttachmentKind::SlideOnSurface) {
      const Vec3d a = particles.p[ids[1]].cast<double>(), b = particles.p[ids[2]].cast<double>(),
                  d = particles.p[ids[3]].cast<double>();
      normal = (b - a).cross(d - a);
      const double area = normal.norm();
      if (!(area > 0)) continue;  // a collapsed triangle has no plane
      normal /= area;
      c = normal.dot(x - target) - double(pool.distance[i]);
    } else {
      normal = x - target;
      const double length = normal.norm();
      if (!(length > 1e-12)) continue;  // on its target: nothing to correct, no direction
      normal /= length;
      c = length - double(pool.distance[i]);
    }
    const double alpha = double(pool.compliance[i]) / h2;
    const double denominator = wa + targetWeight + alpha;
    if (!(denominator > 0)) continue;
    const double step = (-c - alpha * pool.lambda[i]) / denominator;
    pool.lambda[i] += step;
    particles.p[ids[0]] += (wa * step * normal).cast<Real>();
    if (kind == AttachmentKind::PointToPoint) {
      particles.p[ids[1]] -= (double(particles.w[ids[1]]) * step * normal).cast<Real>();
    } else if (surface) {
      for (int k = 0; k < 3; ++k)
        particles.p[ids[k + 1]] -=
            (double(pool.weights[i][k]) * double(particles.w[ids[k + 1]]) * step * normal)
                .cast<Real>();
    }
  }
}

std::size_t breakAttachments(AttachmentPool& pool, Real h) {
  const double h2 = double(h) * double(h);
  std::size_t broke = 0;
  for (std::size_t i = 0; i < pool.size(); ++i) {
    if (pool.broken[i] || pool.removed[i] || !(pool.strength[i] > 0)) continue;
    if (std::abs(pool.lambda[i]) / h2 > double(pool.strength[i])) {
      pool.broken[i] = 1;
      ++broke;
    }
  }
  pool.brokenCount += broke;
  return broke;
}

}  // namespace nucleon
