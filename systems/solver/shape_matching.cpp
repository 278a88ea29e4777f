#include "systems/solver/shape_matching.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

#include "systems/solver/fixed_blocks.h"

namespace nucleon {

Mat3d polarRotation(const Mat3d& a) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(Eigen::Matrix3d(a),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d v = svd.matrixV();
  if ((u * v.transpose()).determinant() < 0) u.col(2) = -u.col(2);
  return Mat3d(u * v.transpose());
}

void appendShapeMatchCluster(ShapeMatchPool& pool, const ObjectRecord& record,
                             std::uint32_t objectIndex, const ParticlePool& particles) {
  const Index first = record.firstParticle, count = record.particleCount;
  double total = 0;
  Vec3d center = Vec3d::Zero();
  for (Index i = first; i < first + count; ++i) {
    const double m = 1.0 / double(particles.w[i]);
    total += m;
    center += m * particles.restPosition[i].cast<double>();
  }
  center /= total;
  for (Index i = first; i < first + count; ++i) {
    pool.particles.push_back(i);
    pool.masses.push_back(1.0 / double(particles.w[i]));
    pool.rest.push_back(particles.restPosition[i].cast<double>() - center);
  }
  pool.particleBegin.push_back(static_cast<Index>(pool.particles.size()));
  pool.object.push_back(objectIndex);
  pool.rigidity.push_back(record.material.rigidity);
  pool.mass.push_back(total);
  pool.blockSums.resize(
      std::max(pool.blockSums.size(), (count + kShapeMatchBlock - 1) / kShapeMatchBlock));
}

void projectShapeMatching(ShapeMatchPool& pool, ParticlePool& particles, int rounds,
                          const std::uint8_t* objectRuns) {
  for (std::size_t c = 0; c < pool.size(); ++c) {
    if (objectRuns && !objectRuns[pool.object[c]]) continue;
    const std::size_t begin = pool.particleBegin[c], count = pool.particleBegin[c + 1] - begin;
    forFixedBlocks(count, kShapeMatchBlock, [&](std::size_t b) {
      std::array<double, 12> sums{};
      const std::size_t last = std::min(begin + count, begin + (b + 1) * kShapeMatchBlock);
      for (std::size_t k = begin + b * kShapeMatchBlock; k < last; ++k) {
        const Vec3d mp = pool.masses[k] * particles.p[pool.particles[k]].cast<double>();
        const Vec3d& r = pool.rest[k];
        for (int i = 0; i < 3; ++i) {
          sums[i] += mp[i];
          for (int j = 0; j < 3; ++j) sums[3 + 3 * i + j] += mp[i] * r[j];
        }
      }
      pool.blockSums[b] = sums;
    });
    std::array<double, 12> total{};
    for (std::size_t b = 0; b < (count + kShapeMatchBlock - 1) / kShapeMatchBlock; ++b)
      for (int i = 0; i < 12; ++i) total[i] += pool.blockSums[b][i];
    const Vec3d center = Vec3d(total[0], total[1], total[2]) / pool.mass[c];
    Mat3d a;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a(i, j) = total[3 + 3 * i + j];
    const Mat3d rotation = polarRotation(a);
    const double rigidity = double(pool.rigidity[c]);
    const double share =
        rigidity >= 1 ? 1.0 : 1.0 - std::pow(1.0 - rigidity, 1.0 / std::max(rounds, 1));
    forFixedBlocks(count, kShapeMatchBlock, [&](std::size_t b) {
      const std::size_t last = std::min(begin + count, begin + (b + 1) * kShapeMatchBlock);
      for (std::size_t k = begin + b * kShapeMatchBlock; k < last; ++k) {
        if (particles.w[pool.particles[k]] == 0) continue;
        Vec3& p = particles.p[pool.particles[k]];
        const Vec3d goal = center + rotation * pool.rest[k];
        p += (share * (goal - p.cast<double>())).cast<Real>();
      }
    });
  }
}

}  // namespace nucleon
