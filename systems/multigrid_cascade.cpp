#include "systems/multigrid_cascade.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace nucleon {
namespace {

constexpr std::size_t kEdgeGrain = 1024;
constexpr std::size_t kParticleGrain = 2048;

bool cascades(const ObjectHierarchy& hierarchy, std::span<const ObjectRecord> objects) {
  return hierarchy.levels.size() >= 2 && hierarchy.object < objects.size() &&
         objects[hierarchy.object].material.stretchCompliance == 0;
}

// One unilateral limit |p_i − p_j| ≤ L: only a stretched edge is projected, by the PBD step
// Δp_i = −w_i/(w_i + w_j) (|d| − L) d/|d| with d = p_i − p_j (Müller 2008: coarse constraints grip
// only when the material between the two particles is fully stretched).
void projectLimit(ParticlePool& particles, const std::array<Index, 2>& edge, Real rest) {
  const Index i = edge[0], j = edge[1];
  const Real wi = particles.w[i], wj = particles.w[j];
  const Real wSum = wi + wj;
  if (!(wSum > 0)) return;
  const Vec3 d = particles.p[i] - particles.p[j];
  const Real length = d.norm();
  if (!(length > rest)) return;  // also skips a non-finite length
  const Vec3 correction = (length - rest) / (wSum * length) * d;
  particles.p[i] -= wi * correction;
  particles.p[j] += wj * correction;
}

void sweepLevel(const HierarchyLevel& level, ParticlePool& particles) {
  for (std::size_t c = 0; c < level.colorCount(); ++c)
    tbb::parallel_for(
        tbb::blocked_range<Index>(level.colorOffset[c], level.colorOffset[c + 1], kEdgeGrain),
        [&](const tbb::blocked_range<Index>& r) {
          for (Index e = r.begin(); e != r.end(); ++e)
            projectLimit(particles, level.edges[e], level.restLength[e]);
        });
}

// p_f = q_f + Σ_j w_fj (p_j − q_j) for the fine particles of `level` (total displacement).
void prolong(const HierarchyLevel& level, ParticlePool& particles, const std::vector<Vec3>& start) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, level.fine.size(), kParticleGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k != r.end(); ++k) {
                        const Index f = level.fine[k];
                        const auto parents = level.parentsOf(k);
                        const auto weights = level.weightsOf(k);
                        Vec3 moved = Vec3::Zero();
                        for (std::size_t n = 0; n < parents.size(); ++n)
                          moved += weights[n] * (particles.p[parents[n]] - start[parents[n]]);
                        particles.p[f] = start[f] + moved;
                      }
                    });
}

}  // namespace

std::size_t runMultigridCascade(const LevelHierarchies& hierarchies,
                                std::span<const ObjectRecord> objects, ParticlePool& particles,
                                std::vector<Vec3>& start, int sweepsPerLevel,
                                CascadeHook afterLevel, void* context) {
  if (sweepsPerLevel <= 0) return 0;
  start.resize(particles.size());
  std::size_t projections = 0;
  for (const ObjectHierarchy& hierarchy : hierarchies.objects) {
    if (!cascades(hierarchy, objects)) continue;
    const Index first = hierarchy.firstParticle, end = first + hierarchy.particleCount;
    tbb::parallel_for(tbb::blocked_range<Index>(first, end, kParticleGrain),
                      [&](const tbb::blocked_range<Index>& r) {
                        for (Index i = r.begin(); i != r.end(); ++i) start[i] = particles.p[i];
                      });
    for (std::size_t l = hierarchy.levels.size() - 1; l >= 1; --l) {
      const HierarchyLevel& level = hierarchy.levels[l];
      for (int s = 0; s < sweepsPerLevel; ++s) sweepLevel(level, particles);
      projections += level.edges.size() * static_cast<std::size_t>(sweepsPerLevel);
      if (afterLevel) afterLevel(context);
      prolong(hierarchy.levels[l - 1], particles, start);
    }
    if (afterLevel) afterLevel(context);
  }
  return projections;
}

std::size_t cascadeProjections(const LevelHierarchies& hierarchies,
                               std::span<const ObjectRecord> objects, int sweepsPerLevel) {
  if (sweepsPerLevel <= 0) return 0;
  std::size_t projections = 0;
  for (const ObjectHierarchy& hierarchy : hierarchies.objects) {
    if (!cascades(hierarchy, objects)) continue;
    for (std::size_t l = 1; l < hierarchy.levels.size(); ++l)
      projections += hierarchy.levels[l].edges.size() * static_cast<std::size_t>(sweepsPerLevel);
  }
  return projections;
}

}  // namespace nucleon
