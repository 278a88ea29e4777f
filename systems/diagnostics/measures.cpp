#include "systems/diagnostics/measures.h"

#include <algorithm>
#include <cmath>

#include "nucleon/hash.h"

namespace nucleon {

StrainStats measureStrain(const StretchConstraints& constraints, std::span<const Vec3> x) {
  struct Sum {
    double max = 0, sum = 0;
    std::size_t count = 0;
  };
  const std::size_t n = constraints.size();
  Sum total;
  for (std::size_t c = 0; c < n; ++c) {
    const auto [i, j] = constraints.particles[c];
    const double rest = constraints.rest[c];
    if (rest <= 0) continue;
    const double strain = std::abs((x[i] - x[j]).cast<double>().norm() / rest - 1.0);
    total.max = std::max(total.max, strain);
    total.sum += strain;
    ++total.count;
  }
  return {total.max, total.count ? total.sum / static_cast<double>(total.count) : 0.0};
}

double nearestRankPercentile(std::vector<double>& values, double q) {
  if (values.empty()) return 0;
  const std::size_t n = values.size();
  // Rank ⌈q n⌉, at least 1; index = rank − 1. The product is rounded and may land a hair above
  // an integer it should equal (0.99 × 300), which ⌈⌉ would push to the next rank.
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(n) - 1e-9));
  const std::size_t index = std::min(n, std::max<std::size_t>(rank, 1)) - 1;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(index),
                   values.end());
  return values[index];
}

StrainDistribution measureStrainDistribution(const StretchConstraints& constraints,
                                             std::span<const Vec3> x) {
  StrainDistribution d;
  std::vector<double> magnitudes;
  magnitudes.reserve(constraints.size());
  double sum = 0;
  for (std::size_t c = 0; c < constraints.size(); ++c) {
    const auto [i, j] = constraints.particles[c];
    const double rest = constraints.rest[c];
    if (rest <= 0) continue;
    const double strain = (x[i] - x[j]).cast<double>().norm() / rest - 1.0;
    if (!std::isfinite(strain)) continue;
    const double magnitude = std::abs(strain);
    d.max = std::max(d.max, magnitude);
    d.maxStretch = std::max(d.maxStretch, strain);
    d.maxCompression = std::max(d.maxCompression, -strain);
    sum += magnitude;
    magnitudes.push_back(magnitude);
  }
  d.count = magnitudes.size();
  if (d.count) d.mean = sum / static_cast<double>(d.count);
  d.p99 = nearestRankPercentile(magnitudes, 0.99);
  return d;
}

double maxTetherViolation(const TetherConstraints& tethers, std::span<const Vec3> x) {
  double worst = 0;
  for (std::size_t c = 0; c < tethers.size(); ++c) {
    const auto [free, pin] = tethers.particles[c];
    const double rest = tethers.rest[c];
    if (rest <= 0) continue;
    worst = std::max(worst, (x[free] - x[pin]).cast<double>().norm() / rest - 1.0);
  }
  return worst;
}

double kineticEnergy(const ParticlePool& particles) {
  double e = 0;
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (particles.w[i] > 0) e += 0.5 * particles.v[i].cast<double>().squaredNorm() / particles.w[i];
  return e;
}

double potentialEnergy(const ParticlePool& particles, const Vec3& gravity) {
  double e = 0;
  const Vec3d g = gravity.cast<double>();
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (particles.w[i] > 0) e -= g.dot(particles.x[i].cast<double>()) / particles.w[i];
  return e;
}

std::size_t countNonFinite(const ParticlePool& particles) {
  std::size_t bad = 0;
  for (std::size_t i = 0; i < particles.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      bad += !std::isfinite(particles.x[i][k]);
      bad += !std::isfinite(particles.v[i][k]);
    }
  return bad;
}

double enclosedVolume(std::span<const std::array<Index, 3>> surface, std::span<const Vec3> x,
                      Index first) {
  double volume = 0;
  for (const auto& t : surface) {
    const Vec3d a = x[first + t[0]].cast<double>();
    const Vec3d b = x[first + t[1]].cast<double>();
    const Vec3d c = x[first + t[2]].cast<double>();
    volume += a.dot(b.cross(c));
  }
  return volume / 6.0;
}

std::uint64_t hashState(const ParticlePool& particles) {
  Fnv1a hash;
  hash.add(particles.x.data(), particles.x.size() * sizeof(Vec3));
  hash.add(particles.v.data(), particles.v.size() * sizeof(Vec3));
  return hash.value;
}

}  // namespace nucleon
