#include "systems/solver/pressure.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace nucleon {
namespace {

// Surfaces up to this many vertices are summed and moved on the calling thread: a parallel loop
// costs more than their work.
constexpr std::size_t kSerialVertices = 2 * kPressureBlock;

// ∂V/∂x_k of surface vertex k (its index in pool.vertices) at positions x, taken about the point
// r: the volume of a closed surface, and so its gradient, does not depend on the origin, and
// coordinates near the surface keep the cross products' precision.
Vec3d volumeGradient(const PressurePool& pool, std::size_t k, std::span<const Vec3> x,
                     const Vec3d& r) {
  Vec3d g = Vec3d::Zero();
  for (Index i = pool.wingBegin[k]; i < pool.wingBegin[k + 1]; ++i) {
    const Vec3d a = x[pool.wings[i][0]].cast<double>() - r;
    const Vec3d b = x[pool.wings[i][1]].cast<double>() - r;
    g += a.cross(b);
  }
  return g / 6.0;
}

struct VolumeSums {
  double volume = 0;
  double gradientNorm = 0;  // S = Σ_k w_k ‖∂V/∂x_k‖²
};

// Fills pool.gradient for surface s at positions x and returns V and S, summed per fixed block
// in block order (the same bits at any thread count).
VolumeSums gradientAndSums(PressurePool& pool, std::size_t s, std::span<const Vec3> x,
                           std::span<const Real> w) {
  const std::size_t begin = pool.vertexBegin[s], end = pool.vertexBegin[s + 1];
  const std::size_t count = end - begin;
  const Vec3d r = x[pool.vertices[begin]].cast<double>();
  const std::size_t blocks = (count + kPressureBlock - 1) / kPressureBlock;
  auto block = [&](std::size_t b) {
    double threeVolume = 0, norm = 0;
    const std::size_t last = std::min(end, begin + (b + 1) * kPressureBlock);
    for (std::size_t k = begin + b * kPressureBlock; k < last; ++k) {
      const Index particle = pool.vertices[k];
      const Vec3d g = volumeGradient(pool, k, x, r);
      pool.gradient[k] = g;
      threeVolume += (x[particle].cast<double>() - r).dot(g);
      norm += double(w[particle]) * g.squaredNorm();
    }
    pool.blockSums[b] = {threeVolume, norm};
  };
  if (count <= kSerialVertices) {
    for (std::size_t b = 0; b < blocks; ++b) block(b);
  } else {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, 1),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t b = range.begin(); b < range.end(); ++b) block(b);
                      });
  }
  VolumeSums sums;
  for (std::size_t b = 0; b < blocks; ++b) {
    sums.volume += pool.blockSums[b][0];
    sums.gradientNorm += pool.blockSums[b][1];
  }
  sums.volume /= 3.0;
  return sums;
}

}  // namespace

void appendPressureSurface(PressurePool& pool, const ObjectRecord& record,
                           std::uint32_t objectIndex) {
  const Index first = record.firstParticle;
  // Surface slot of each local vertex on the surface, in vertex order.
  std::vector<char> onSurface(record.particleCount, 0);
  for (const auto& t : record.surface)
    for (Index v : t) onSurface[v] = 1;
  std::vector<Index> slot(record.particleCount, 0);
  const std::size_t vertexStart = pool.vertices.size();
  for (Index v = 0; v < record.particleCount; ++v)
    if (onSurface[v]) {
      slot[v] = static_cast<Index>(pool.vertices.size() - vertexStart);
      pool.vertices.push_back(first + v);
    }
  const std::size_t count = pool.vertices.size() - vertexStart;
  // Wings by counting sort on the vertex: the triangles' order is kept within each vertex.
  std::vector<Index> wingCount(count + 1, 0);
  for (const auto& t : record.surface)
    for (Index v : t) ++wingCount[slot[v] + 1];
  for (std::size_t k = 0; k < count; ++k) wingCount[k + 1] += wingCount[k];
  const std::size_t wingStart = pool.wings.size();
  pool.wings.resize(wingStart + record.surface.size() * 3);
  std::vector<Index> cursor(wingCount.begin(), wingCount.end() - 1);
  for (const auto& t : record.surface)
    for (int c = 0; c < 3; ++c)
      pool.wings[wingStart + cursor[slot[t[c]]]++] = {first + t[(c + 1) % 3],
                                                      first + t[(c + 2) % 3]};
  for (std::size_t k = 0; k < count; ++k)
    pool.wingBegin.push_back(static_cast<Index>(wingStart + wingCount[k + 1]));
  pool.vertexBegin.push_back(static_cast<Index>(pool.vertices.size()));

  const Pressure& settings = record.material.pressure;
  pool.object.push_back(objectIndex);
  pool.settings.push_back(settings);
  pool.restVolume.push_back(record.restVolume);
  pool.gas.push_back((double(settings.ambient) + double(settings.startPressure)) *
                     record.restVolume);
  pool.lambda.push_back(0);
  pool.gradient.resize(pool.vertices.size());
  pool.blockSums.resize(
      std::max(pool.blockSums.size(), (count + kPressureBlock - 1) / kPressureBlock));
}

double pressureVolume(const PressurePool& pool, std::size_t s, std::span<const Vec3> x) {
  const std::size_t begin = pool.vertexBegin[s], end = pool.vertexBegin[s + 1];
  const Vec3d r = x[pool.vertices[begin]].cast<double>();
  double threeVolume = 0;
  for (std::size_t k = begin; k < end; ++k)
    threeVolume += (x[pool.vertices[k]].cast<double>() - r).dot(volumeGradient(pool, k, x, r));
  return threeVolume / 3.0;
}

void startPressureSubstep(PressurePool& pool, double time, Real h) {
  std::fill(pool.lambda.begin(), pool.lambda.end(), 0.0);
  for (std::size_t s = 0; s < pool.size(); ++s) {
    const Pressure& settings = pool.settings[s];
    if (settings.mode != PressureMode::Gas) continue;
    // Each over the part of the substep [time, time + h] in which it runs, so that the gas does
    // not depend on where the substeps fall against the pump's stop and the leak's start.
    const double end = time + double(h);
    const double pumping = std::max(0.0, std::min(end, settings.pumpStop) - time);
    pool.gas[s] += double(settings.ambient) * double(settings.pumpRate) * pumping;
    const double leaking = std::max(0.0, end - std::max(time, settings.leakStart));
    if (settings.leakRate > 0 && leaking > 0) {
      // Towards the rest fill, exactly over that time.
      const double rest = double(settings.ambient) * pool.restVolume[s];
      pool.gas[s] = rest + (pool.gas[s] - rest) * std::exp(-double(settings.leakRate) * leaking);
    }
  }
}

void projectPressure(PressurePool& pool, ParticlePool& particles, Real h) {
  const double h2 = double(h) * double(h);
  for (std::size_t s = 0; s < pool.size(); ++s) {
    const VolumeSums sums = gradientAndSums(pool, s, particles.p, particles.w);
    if (!(sums.gradientNorm > 0) || !std::isfinite(sums.volume)) continue;
    const Pressure& settings = pool.settings[s];
    double& lambda = pool.lambda[s];
    double step;
    if (settings.mode == PressureMode::Gas) {
      double volume = sums.volume;
      const double least = kMinPressureVolume * pool.restVolume[s];
      if (volume < least) {
        volume = least;
        ++pool.collapsedProjections;
      }
      const double pressure = pool.gas[s] / volume;
      step = (h2 * (pressure - double(settings.ambient)) - lambda) /
             (1 + h2 * sums.gradientNorm * pressure / volume);
    } else {
      const double c = sums.volume - double(settings.volumeScale) * pool.restVolume[s];
      const double alpha = double(settings.compliance) / h2;
      step = (-c - alpha * lambda) / (sums.gradientNorm + alpha);
    }
    lambda += step;
    const std::size_t begin = pool.vertexBegin[s], end = pool.vertexBegin[s + 1];
    auto move = [&](std::size_t from, std::size_t to) {
      for (std::size_t k = from; k < to; ++k) {
        const Index i = pool.vertices[k];
        particles.p[i] += (double(particles.w[i]) * step * pool.gradient[k]).cast<Real>();
      }
    };
    if (end - begin <= kSerialVertices)
      move(begin, end);
    else
      tbb::parallel_for(
          tbb::blocked_range<std::size_t>(begin, end, kPressureBlock),
          [&](const tbb::blocked_range<std::size_t>& r) { move(r.begin(), r.end()); });
  }
}

}  // namespace nucleon
