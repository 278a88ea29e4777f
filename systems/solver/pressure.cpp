#include "systems/solver/pressure.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "systems/solver/fixed_blocks.h"

namespace nucleon {
namespace {

// Surfaces up to this many vertices are summed and moved on the calling thread: a parallel loop
// costs more than their work.
constexpr std::size_t kSerialVertices = 2 * kPressureBlock;

struct VolumeSums {
  double volume = 0;
  double gradientNorm = 0;  // S = Σ_k w_k ‖∂V/∂x_k‖²
};

// Fills pool.areaVector and pool.gradient for surface s at positions x and returns V and S, summed
// per fixed block in block order (the same bits at any thread count).
VolumeSums gradientAndSums(PressurePool& pool, std::size_t s, std::span<const Vec3> x,
                           std::span<const Real> w) {
  const std::size_t firstTriangle = pool.triangleBegin[s];
  const std::size_t triangleCount = pool.triangleBegin[s + 1] - firstTriangle;
  forFixedBlocks(triangleCount, kPressureBlock, [&](std::size_t b) {
    const std::size_t begin = firstTriangle + b * kPressureBlock;
    const std::size_t end = std::min(firstTriangle + triangleCount, begin + kPressureBlock);
    for (std::size_t t = begin; t < end; ++t) {
      const auto& tri = pool.triangles[t];
      const Vec3d a = x[tri[0]].cast<double>();
      pool.areaVector[t] = 0.5 * (x[tri[1]].cast<double>() - a).cross(x[tri[2]].cast<double>() - a);
    }
  });
  const std::size_t begin = pool.vertexBegin[s], count = pool.vertexBegin[s + 1] - begin;
  // About a point of the surface: the volume of a closed surface does not depend on the origin,
  // and coordinates near the surface keep the dot products' precision.
  const Vec3d r = x[pool.vertices[begin]].cast<double>();
  forFixedBlocks(count, kPressureBlock, [&](std::size_t b) {
    double threeVolume = 0, norm = 0;
    const std::size_t last = std::min(begin + count, begin + (b + 1) * kPressureBlock);
    for (std::size_t k = begin + b * kPressureBlock; k < last; ++k) {
      Vec3d g = Vec3d::Zero();
      for (Index i = pool.incidentBegin[k]; i < pool.incidentBegin[k + 1]; ++i)
        g += pool.areaVector[pool.incident[i]];
      g /= 3.0;
      pool.gradient[k] = g;
      const Index particle = pool.vertices[k];
      threeVolume += (x[particle].cast<double>() - r).dot(g);
      norm += double(w[particle]) * g.squaredNorm();
    }
    pool.blockSums[b] = {threeVolume, norm};
  });
  VolumeSums sums;
  for (std::size_t b = 0; b < (count + kPressureBlock - 1) / kPressureBlock; ++b) {
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
  // The triangles in global indices, and each vertex's incident triangles by counting sort on
  // the vertex (triangle order within a vertex).
  const std::size_t triangleStart = pool.triangles.size();
  for (const auto& t : record.surface)
    pool.triangles.push_back({first + t[0], first + t[1], first + t[2]});
  pool.triangleBegin.push_back(static_cast<Index>(pool.triangles.size()));
  std::vector<Index> incidentCount(count + 1, 0);
  for (const auto& t : record.surface)
    for (Index v : t) ++incidentCount[slot[v] + 1];
  for (std::size_t k = 0; k < count; ++k) incidentCount[k + 1] += incidentCount[k];
  const std::size_t incidentStart = pool.incident.size();
  pool.incident.resize(incidentStart + record.surface.size() * 3);
  std::vector<Index> cursor(incidentCount.begin(), incidentCount.end() - 1);
  for (std::size_t t = 0; t < record.surface.size(); ++t)
    for (Index v : record.surface[t])
      pool.incident[incidentStart + cursor[slot[v]]++] = static_cast<Index>(triangleStart + t);
  for (std::size_t k = 0; k < count; ++k)
    pool.incidentBegin.push_back(static_cast<Index>(incidentStart + incidentCount[k + 1]));
  pool.vertexBegin.push_back(static_cast<Index>(pool.vertices.size()));
  pool.areaVector.resize(pool.triangles.size());

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
  const Vec3d r = x[pool.vertices[pool.vertexBegin[s]]].cast<double>();
  double sixVolume = 0;
  for (std::size_t t = pool.triangleBegin[s]; t < pool.triangleBegin[s + 1]; ++t) {
    const auto& tri = pool.triangles[t];
    const Vec3d a = x[tri[0]].cast<double>() - r, b = x[tri[1]].cast<double>() - r,
                c = x[tri[2]].cast<double>() - r;
    sixVolume += a.dot(b.cross(c));
  }
  return sixVolume / 6.0;
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

void projectPressure(PressurePool& pool, ParticlePool& particles, Real h,
                     const std::uint8_t* objectRuns) {
  const double h2 = double(h) * double(h);
  for (std::size_t s = 0; s < pool.size(); ++s) {
    if (objectRuns && !objectRuns[pool.object[s]]) continue;
    const VolumeSums sums = gradientAndSums(pool, s, particles.p, particles.w);
    if (!(sums.gradientNorm > 0) || !std::isfinite(sums.volume)) continue;
    const Pressure& settings = pool.settings[s];
    double& lambda = pool.lambda[s];
    double step;
    if (settings.mode == PressureMode::Gas) {
      double volume = sums.volume;
      const double least = kMinPressureVolume * pool.restVolume[s];
      bool repaired = false;
      if (volume < least) {
        volume = least;
        repaired = true;
      }
      const double pressure = pool.gas[s] / volume;
      step = (h2 * (pressure - double(settings.ambient)) - lambda) /
             (1 + h2 * sums.gradientNorm * pressure / volume);
      // The step is Newton's on the volume linearised along the gradient. Far from equilibrium
      // the linear model is wrong: a gas at 1% of its rest fill asked in its first projection for
      // a change of volume 1,300 times the volume there was, and turned the balloon inside out
      // kilometres wide. A damped Newton step: the predicted change S Δλ is held to half the
      // volume there is (at least kMinPressureVolume of the rest volume), so a gas approaches its
      // volume over a few projections instead of jumping past it.
      const double most = kMaxPressureStep * volume / sums.gradientNorm;
      if (std::abs(step) > most) {
        step = std::copysign(most, step);
        ++pool.limitedSteps;
      }
      pool.collapsedProjections += repaired ? 1 : 0;
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
