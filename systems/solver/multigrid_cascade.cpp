#include "systems/solver/multigrid_cascade.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <thread>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include "systems/solver/distance_batch.h"
#include "systems/solver/tether_projection.h"

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

// A level this small is swept on the calling thread: a color of a few hundred edges costs less
// than the barrier a parallel loop puts after it. The colors are independent sets, and the
// parallel pieces of a color start a whole number of batches from its start (sweepLevel), so
// the serial sweep in color order gives the same result bit for bit.
constexpr std::size_t kSerialEdges = 8192;

// Edges [begin, end) of one color: eight at a time where the AVX2 batch runs (the same PBD step,
// without multipliers), the rest one by one.
void sweepEdges(const HierarchyLevel& level, const Real* limit, ParticlePool& particles,
                Index begin, Index end) {
  DistanceBatch batch;
  batch.particles = level.edges.data();
  batch.rest = limit;
  batch.positions = particles.p.data();
  batch.inverseMass = particles.w.data();
  batch.unilateral = true;
  for (Index e = projectDistanceBatches(batch, begin, end); e != end; ++e)
    projectLimit(particles, level.edges[e], limit[e]);
}

void sweepLevel(const HierarchyLevel& level, const Real* limit, ParticlePool& particles) {
  const bool serial = level.edges.size() < kSerialEdges;
  for (std::size_t c = 0; c < level.colorCount(); ++c) {
    const Index begin = level.colorOffset[c], end = level.colorOffset[c + 1];
    if (serial) {
      sweepEdges(level, limit, particles, begin, end);
      continue;
    }
    // Pieces of whole batches: which edges the AVX2 batch takes, and which the scalar remainder
    // (they round differently), must not depend on how the loop is split, or the result would
    // depend on the thread count.
    const Index batches = (end - begin + kDistanceBatchSize - 1) / kDistanceBatchSize;
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, batches, kEdgeGrain / kDistanceBatchSize),
        [&](const tbb::blocked_range<Index>& r) {
          sweepEdges(level, limit, particles, begin + r.begin() * kDistanceBatchSize,
                     std::min(end, begin + r.end() * kDistanceBatchSize));
        },
        tbb::static_partitioner());
  }
}

// All `sweeps` sweeps of a level too small for a parallel loop per colour, shared by the arena's
// threads without one: every colour of every sweep is cut into chunks of kChunkEdges edges (whole
// batches from the colour's start, as above), numbered in sweep and colour order, and each thread
// takes the next number from a shared ticket counter. A chunk may start once every chunk of the
// earlier colours is done (a count of done chunks, waited on with a spin): chunks of one colour
// share no free particle, so they run in any order on any thread with the same result, bit for
// bit. No deadlock: a thread waits only for tickets drawn before its own, by threads that are
// running them and wait for nothing later; a thread that never joins draws none. A wait that
// lasts (the other thread descheduled: more threads than cores) yields the core. Against one
// thread per level, three alternating runs each (2 threads): cloth_hang_128_fast 0.845–0.860 →
// 0.822–0.831 ms/step, cloth_hang_256_fast 4.36–4.42 → 4.27–4.32, the same states.
constexpr Index kChunkEdges = 64;

// Waits until `done` reaches `count`: spins a while, then yields the core.
void waitForChunks(const std::atomic<std::uint64_t>& done, std::uint64_t count) {
  for (int spins = 0; done.load(std::memory_order_acquire) < count; ++spins) {
    if (spins < 4096) {
#if defined(__x86_64__) || defined(__i386__)
      _mm_pause();
#endif
    } else {
      std::this_thread::yield();
    }
  }
}

constexpr std::size_t kSharedLevelEdges = 1024;  // below: one thread (a chunk or two a colour)
constexpr std::size_t kMaxSharedColors = 64;

bool sweepLevelShared(const HierarchyLevel& level, const Real* limit, ParticlePool& particles,
                      int sweeps) {
  const std::size_t colors = level.colorCount();
  if (colors == 0 || colors > kMaxSharedColors || sweeps <= 0) return false;
  // First chunk of each colour within a sweep; the chunks of a sweep.
  std::array<Index, kMaxSharedColors + 1> colorChunk{};
  for (std::size_t c = 0; c < colors; ++c) {
    const Index edges = level.colorOffset[c + 1] - level.colorOffset[c];
    colorChunk[c + 1] = colorChunk[c] + (edges + kChunkEdges - 1) / kChunkEdges;
  }
  const std::uint64_t perSweep = colorChunk[colors];
  const std::uint64_t total = perSweep * static_cast<std::uint64_t>(sweeps);
  std::atomic<std::uint64_t> next{0}, done{0};
  const int threads = std::max(1, tbb::this_task_arena::max_concurrency());
  tbb::parallel_for(0, threads, [&](int) {
    for (;;) {
      const std::uint64_t ticket = next.fetch_add(1, std::memory_order_relaxed);
      if (ticket >= total) return;
      const std::uint64_t sweep = ticket / perSweep;
      const Index within = static_cast<Index>(ticket % perSweep);
      const std::size_t color = static_cast<std::size_t>(
          std::upper_bound(colorChunk.begin() + 1, colorChunk.begin() + colors + 1, within) -
          colorChunk.begin() - 1);
      // Every chunk of the earlier colours (this sweep's and all earlier sweeps') done.
      const std::uint64_t before = sweep * perSweep + colorChunk[color];
      waitForChunks(done, before);
      const Index begin = level.colorOffset[color] + (within - colorChunk[color]) * kChunkEdges;
      const Index end = std::min<Index>(level.colorOffset[color + 1], begin + kChunkEdges);
      sweepEdges(level, limit, particles, begin, end);
      done.fetch_add(1, std::memory_order_release);
    }
  });
  return true;
}

// The level's tethers, |p_i − p_pin| ≤ L, two at a time as in the fine tether sweep (a pin never
// moves). Particles are independent: parallel.
void sweepLevelTethers(const HierarchyLevel& level, ParticlePool& particles) {
  if (level.tetherOffset.empty()) return;
  auto project = [&](std::size_t k) {
    const Index i = level.particles[k];
    if (particles.w[i] == 0) return;
    Vec3 x = particles.p[i];
    const Index end = level.tetherOffset[k + 1];
    for (Index t = level.tetherOffset[k]; t < end; t += 2)
      x = t + 1 < end
              ? projectOntoTetherPair(x, particles.p[level.tetherPin[t]], level.tetherLimit[t],
                                      particles.p[level.tetherPin[t + 1]], level.tetherLimit[t + 1])
              : projectOntoTether(x, particles.p[level.tetherPin[t]], level.tetherLimit[t]);
    particles.p[i] = x;
  };
  if (level.edges.size() < kSerialEdges) {
    for (std::size_t k = 0; k < level.particles.size(); ++k) project(k);
    return;
  }
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, level.particles.size(), kParticleGrain),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t k = r.begin(); k != r.end(); ++k) project(k);
      },
      tbb::static_partitioner());
}

// p_f = q_f + Σ_j w_fj (p_j − q_j) for the fine particles of `level` (total displacement), except
// the particles that have primitive contacts: they keep the place their contacts gave them. The
// prolonged place would drop that push (it starts from q_f), and an interpolated one would cut
// through what the particle touches; the fine sweeps then close the kink left around them. Under
// overwriting, a 200 m/s pellet got behind its cloth in 2 of 11 multigrid runs of bullet_cloth
// (iterations 4–16, 2 and 4 substeps), none with contact particles kept.
void prolong(const HierarchyLevel& level, ParticlePool& particles, const std::vector<Vec3>& start,
             std::span<const Index> contactOffsets) {
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, level.fine.size(), kParticleGrain),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t k = r.begin(); k != r.end(); ++k) {
          const Index f = level.fine[k];
          const auto parents = level.parentsOf(k);
          const auto weights = level.weightsOf(k);
          Vec3 moved = Vec3::Zero();
          for (std::size_t n = 0; n < parents.size(); ++n)
            moved += weights[n] * (particles.p[parents[n]] - start[parents[n]]);
          const bool touching =
              !contactOffsets.empty() && contactOffsets[f + 1] > contactOffsets[f];
          if (!touching) particles.p[f] = start[f] + moved;
        }
      },
      tbb::static_partitioner());
}

// The limit each coarse edge is swept with this substep, where the cloth touches a collider.
// Its rest-pose distance bounds the chord only while the patch it stands for lies flat: over a
// curved patch (cloth draped on a sphere) the chord is shorter than the material between its
// ends, and a chord limit stays slack while that material stretches, so the coarse levels stop
// carrying stretch exactly where a collider holds the cloth. With the chord c and the current
// length P of the edge's path through the finer level (HierarchyLevel::path, rest length R),
// the patch is at rest length when P = R; keeping the shape's chord-to-path ratio, its chord is
// then c R / P. Where the path is stretched (P > R) the limit is the smaller of that and the
// rest distance: unchanged for a flat patch (c R / P is the rest distance under uniform
// stretch), it grips a curved one as soon as its material stretches. Only edges with both
// particles in collider contact get it, a patch the collider holds bent: a fold the cloth may
// open by itself is no such constraint (holding its chord made free hanging cloths worse), and
// with one particle in contact the edges across the folds of a pile on the ground pulled its
// layers together (bench/results/2core-AMD-EPYC/solver_speed.md §11). Measured once per cascade,
// from the positions it starts from.

void setContactLimits(const ObjectHierarchy& hierarchy, const ParticlePool& particles,
                      std::span<const Index> colliderRuns, CascadeScratch& scratch) {
  const auto touches = [&](Index i) { return colliderRuns[i] != colliderRuns[i + 1]; };
  for (std::size_t l = 1; l < hierarchy.levels.size(); ++l) {
    const HierarchyLevel& level = hierarchy.levels[l];
    Real* limit = scratch.limit.data() + level.scratchBase;
    const auto set = [&](std::size_t e) {
      const std::array<Index, 4>& path = level.path[e];
      limit[e] = level.restLength[e];
      if (!touches(path[0]) || !touches(path[3])) return;
      const Vec3 a = particles.p[path[0]], f = particles.p[path[1]], g = particles.p[path[2]],
                 b = particles.p[path[3]];
      const Real length = (f - a).norm() + (g - f).norm() + (b - g).norm();
      if (!(length > level.pathRest[e])) return;
      limit[e] = std::min(limit[e], (b - a).norm() * level.pathRest[e] / length);
    };
    if (level.edges.size() < kSerialEdges) {
      for (std::size_t e = 0; e < level.edges.size(); ++e) set(e);
      continue;
    }
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, level.edges.size(), kEdgeGrain),
        [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t e = r.begin(); e != r.end(); ++e) set(e);
        },
        tbb::static_partitioner());
  }
}

}  // namespace

std::size_t runMultigridCascade(const LevelHierarchies& hierarchies,
                                std::span<const ObjectRecord> objects, ParticlePool& particles,
                                CascadeScratch& scratch, std::span<const int> sweepsPerLevel,
                                CascadeHook afterLevel, void* context,
                                std::span<const Index> contactOffsets,
                                std::span<const Index> colliderRuns) {
  if (sweepsOfLevel(sweepsPerLevel, 1) <= 0) return 0;
  std::vector<Vec3>& start = scratch.start;
  start.resize(particles.size());
  scratch.limit.resize(hierarchies.coarseEdges);
  const bool contacts = colliderRuns.size() == particles.size() + 1;
  std::size_t projections = 0;
  for (const ObjectHierarchy& hierarchy : hierarchies.objects) {
    if (!cascades(hierarchy, objects)) continue;
    const Index first = hierarchy.firstParticle, end = first + hierarchy.particleCount;
    tbb::parallel_for(
        tbb::blocked_range<Index>(first, end, kParticleGrain),
        [&](const tbb::blocked_range<Index>& r) {
          for (Index i = r.begin(); i != r.end(); ++i) start[i] = particles.p[i];
        },
        tbb::static_partitioner());
    if (contacts) setContactLimits(hierarchy, particles, colliderRuns, scratch);
    for (std::size_t l = hierarchy.levels.size() - 1; l >= 1; --l) {
      const HierarchyLevel& level = hierarchy.levels[l];
      const Real* limit =
          contacts ? scratch.limit.data() + level.scratchBase : level.restLength.data();
      const int sweeps = sweepsOfLevel(sweepsPerLevel, l);
      const bool shared = level.edges.size() >= kSharedLevelEdges &&
                          level.edges.size() < kSerialEdges &&
                          sweepLevelShared(level, limit, particles, sweeps);
      if (!shared)
        for (int k = 0; k < sweeps; ++k) sweepLevel(level, limit, particles);
      if (sweeps > 0) sweepLevelTethers(level, particles);
      projections += level.edges.size() * static_cast<std::size_t>(sweeps) +
                     (sweeps > 0 ? level.tetherPin.size() : 0);
      if (afterLevel) afterLevel(context, level.particles);
      prolong(hierarchy.levels[l - 1], particles, start, contactOffsets);
    }
    if (afterLevel) afterLevel(context, {});
  }
  return projections;
}

std::size_t cascadeProjections(const LevelHierarchies& hierarchies,
                               std::span<const ObjectRecord> objects,
                               std::span<const int> sweepsPerLevel) {
  if (sweepsOfLevel(sweepsPerLevel, 1) <= 0) return 0;
  std::size_t projections = 0;
  for (const ObjectHierarchy& hierarchy : hierarchies.objects) {
    if (!cascades(hierarchy, objects)) continue;
    for (std::size_t l = 1; l < hierarchy.levels.size(); ++l) {
      const int sweeps = sweepsOfLevel(sweepsPerLevel, l);
      projections += hierarchy.levels[l].edges.size() * static_cast<std::size_t>(sweeps) +
                     (sweeps > 0 ? hierarchy.levels[l].tetherPin.size() : 0);
    }
  }
  return projections;
}

int sweepsOfLevel(std::span<const int> sweepsPerLevel, std::size_t level) {
  if (sweepsPerLevel.empty() || level == 0) return 0;
  return sweepsPerLevel[std::min(level, sweepsPerLevel.size()) - 1];
}

}  // namespace nucleon
