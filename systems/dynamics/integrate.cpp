#include "systems/dynamics/integrate.h"

#include <atomic>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace nucleon {
namespace {
// Particles per task: large enough that scheduling is negligible against the loop body.
constexpr std::size_t kGrain = 4096;
}  // namespace

void applyForces(ParticlePool& particles, const Vec3& gravity, Real h) {
  const Vec3 dv = h * gravity;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        if (particles.w[i] > 0) particles.v[i] += dv;
                    });
}

void predictPositions(ParticlePool& particles, Real h) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        particles.p[i] = particles.x[i] + h * particles.v[i];
                    });
}

std::size_t updateState(ParticlePool& particles, Real h) {
  const Real invH = Real(1) / h;
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, particles.size(), kGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t bad) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          // Same expression as predictPositions, so an uncorrected particle gets exactly δv = 0.
          const Vec3 predicted = particles.x[i] + h * particles.v[i];
          const Vec3 v = particles.v[i] + (particles.p[i] - predicted) * invH;
          if (!particles.p[i].allFinite() || !v.allFinite()) {
            particles.v[i].setZero();
            particles.p[i] = particles.x[i];
            ++bad;
            continue;
          }
          particles.v[i] = v;
          particles.x[i] = particles.p[i];
        }
        return bad;
      },
      std::plus<>());
}

}  // namespace nucleon
