#include "systems/dynamics/integrate.h"

#include <algorithm>
#include <array>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace nucleon {
static_assert(sizeof(Vec3) == 3 * sizeof(Real), "positions and velocities are read as flat arrays");

namespace {
// Particles per task: large enough that scheduling is negligible against the loop body.
constexpr std::size_t kGrain = 4096;
}  // namespace

void applyForces(ParticlePool& particles, const Vec3& gravity, Real h) {
  const Vec3 dv = h * gravity;
  // h g repeated over eight particles: a group of eight free particles is one flat sum of 24
  // numbers, which the compiler runs in lanes (a per-particle select over packed triples does not).
  constexpr std::size_t kGroup = 8;
  std::array<Real, 3 * kGroup> dvOfGroup;
  for (std::size_t j = 0; j < dvOfGroup.size(); ++j) dvOfGroup[j] = dv[j % 3];
  const Real* w = particles.w.data();
  Real* v = particles.v.data()->data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      // A select, not a sum with zero, where a particle is pinned: its −0
                      // stays −0.
                      const auto addOne = [&](std::size_t i) {
                        const bool free = w[i] > 0;
                        for (int c = 0; c < 3; ++c)
                          v[3 * i + c] = free ? v[3 * i + c] + dv[c] : v[3 * i + c];
                      };
                      std::size_t i = r.begin();
                      for (; i + kGroup <= r.end(); i += kGroup) {
                        bool allFree = true;
                        for (std::size_t k = 0; k < kGroup; ++k) allFree &= w[i + k] > 0;
                        if (!allFree) {
                          for (std::size_t k = 0; k < kGroup; ++k) addOne(i + k);
                          continue;
                        }
                        Real* group = v + 3 * i;
                        for (std::size_t j = 0; j < 3 * kGroup; ++j) group[j] += dvOfGroup[j];
                      }
                      for (; i != r.end(); ++i) addOne(i);
                    });
}

void predictPositions(ParticlePool& particles, Real h) {
  const Real* x = particles.x.data()->data();
  const Real* v = particles.v.data()->data();
  Real* p = particles.p.data()->data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t j = 3 * r.begin(); j != 3 * r.end(); ++j)
                        p[j] = x[j] + h * v[j];
                    });
}

std::size_t updateState(ParticlePool& particles, Real h) {
  const Real invH = Real(1) / h;
  // v ← v + (p − (x + h v)) / h, x ← p: component by component, so a block is taken as one flat
  // array, which the compiler runs in lanes.
  const Real* p = particles.p.data()->data();
  Real* x = particles.x.data()->data();
  Real* v = particles.v.data()->data();
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, particles.size(), kGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t bad) {
        const std::size_t begin = 3 * r.begin(), end = 3 * r.end();
        // The new velocities first, and whether they and the new positions are all finite
        // (y − y is 0 for a finite y only), as they nearly always are: then x ← p is one copy.
        int finite = 1;
        for (std::size_t j = begin; j < end; ++j) {
          // Same expression as predictPositions, so an uncorrected particle gets exactly δv = 0.
          v[j] = v[j] + (p[j] - (x[j] + h * v[j])) * invH;
          finite &= (p[j] - p[j] == 0) & (v[j] - v[j] == 0);
        }
        if (finite) {
          std::copy(p + begin, p + end, x + begin);
          return bad;
        }
        // A non-finite particle is reset to where it started the substep, at rest.
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          if (!particles.p[i].allFinite() || !particles.v[i].allFinite()) {
            particles.v[i].setZero();
            particles.p[i] = particles.x[i];
            ++bad;
            continue;
          }
          particles.x[i] = particles.p[i];
        }
        return bad;
      },
      std::plus<>());
}

}  // namespace nucleon
