#include "systems/measures.h"

#include <cmath>

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
  std::uint64_t h = 14695981039346656037ull;
  auto mix = [&](const void* data, std::size_t bytes) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < bytes; ++k) {
      h ^= b[k];
      h *= 1099511628211ull;
    }
  };
  mix(particles.x.data(), particles.x.size() * sizeof(Vec3));
  mix(particles.v.data(), particles.v.size() * sizeof(Vec3));
  return h;
}

}  // namespace nucleon
