#include "systems/solver/multigrid_cascade.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "systems/solver/distance_batch.h"
#include "systems/solver/tether_projection.h"

namespace nucleon {
namespace {

constexpr std::size_t kEdgeGrain = 1024;
constexpr std::size_t kParticleGrain = 2048;

bool cascades(const ObjectHierarchy& hierarchy, std::span<const ObjectRecord> objects) {
  return hierarchy.levels.size() >= 2 && hierarchy.object < objects.size() &&
         objects[hierarchy.object].material.longRangeStrain() >= 0;
}

// One unilateral limit |p_i − p_j| ≤ L: only a stretched edge is projected, by the PBD step
// Δp_i = −ω w_i/(w_i + w_j) (|d| − L) d/|d| with d = p_i − p_j (Müller 2008: coarse constraints
// grip only when the material between the two particles is fully stretched), over-relaxed by ω.
void projectLimit(ParticlePool& particles, const std::array<Index, 2>& edge, Real rest,
                  Real relaxation) {
  const Index i = edge[0], j = edge[1];
  const Real wi = particles.w[i], wj = particles.w[j];
  const Real wSum = wi + wj;
  if (!(wSum > 0)) return;
  const Vec3 d = particles.p[i] - particles.p[j];
  const Real length = d.norm();
  if (!(length > rest)) return;  // also skips a non-finite length
  const Vec3 correction = relaxation * (length - rest) / (wSum * length) * d;
  particles.p[i] -= wi * correction;
  particles.p[j] += wj * correction;
}

// A level this small is swept on the calling thread: a color of a few hundred edges costs less
// than the barrier a parallel loop puts after it. The colors are independent sets, and the
// parallel pieces of a color start a whole number of batches from its start (sweepLevel), so
// the serial sweep in color order gives the same result bit for bit. (Levels of 1,024 to 8,191
// edges were once shared by both threads in chunks of 64 edges, each colour waiting on a count
// of done chunks: 1–3% faster on a calm machine, but a thread descheduled inside a chunk held
// the other at the next colour, and under load the 256² cascade took 1.4–1.7 ms instead of
// 0.9–1.0: bench/results/2core-AMD-EPYC/solver_speed.md §12.)
constexpr std::size_t kSerialEdges = 8192;
constexpr std::size_t kSerialParticles = 8192;

// The limits' passes over coarse particles and edges (setContactLimits) are one loop each, not
// a sequence of colors, and cost 15–20 ns an item (square roots): on both threads from this
// many items, in pieces of kItemGrain (128² drape, 2 threads: level 2's 4,160 edges 60 → 35 µs).
constexpr std::size_t kSerialItems = 2048;
constexpr std::size_t kItemGrain = 512;

// Support ids: a sphere collider's index, or a static mesh's object id with the high bit set.
constexpr Index kNoSupport = ~Index(0);
constexpr Index kMeshSupport = Index(1) << 31;
// How far outside a support's surface a particle may be and still rest on it (m): within the
// contact pool's reach a particle may hover over the surface, where the surface's curvature says
// nothing about the material's.
constexpr Real kSupportGap = Real(0.0025);

// f(k) for k in [0, count): on the calling thread when `serial` (a small level), else split
// statically into pieces of `grain` among the arena's threads.
template <typename F>
void forEachIndex(std::size_t count, bool serial, std::size_t grain, F&& f) {
  if (serial) {
    for (std::size_t k = 0; k < count; ++k) f(k);
    return;
  }
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, count, grain),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t k = r.begin(); k != r.end(); ++k) f(k);
      },
      tbb::static_partitioner());
}

// Edges [begin, end) of one color: eight at a time where the AVX2 batch runs (the same PBD step,
// without multipliers), the rest one by one.
void sweepEdges(const HierarchyLevel& level, const Real* limit, Real relaxation,
                ParticlePool& particles, Index begin, Index end) {
  DistanceBatch batch;
  batch.relaxation = relaxation;
  batch.particles = level.edges.data();
  batch.rest = limit;
  batch.positions = particles.p.data();
  batch.inverseMass = particles.w.data();
  batch.unilateral = true;
  for (Index e = projectDistanceBatches(batch, begin, end); e != end; ++e)
    projectLimit(particles, level.edges[e], limit[e], relaxation);
}

void sweepLevel(const HierarchyLevel& level, const Real* limit, Real relaxation,
                ParticlePool& particles) {
  const bool serial = level.edges.size() < kSerialEdges;
  for (std::size_t c = 0; c < level.colorCount(); ++c) {
    const Index begin = level.colorOffset[c], end = level.colorOffset[c + 1];
    if (serial) {
      sweepEdges(level, limit, relaxation, particles, begin, end);
      continue;
    }
    // Pieces of whole batches: which edges the AVX2 batch takes, and which the scalar remainder
    // (they round differently), must not depend on how the loop is split, or the result would
    // depend on the thread count.
    const Index batches = (end - begin + kDistanceBatchSize - 1) / kDistanceBatchSize;
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, batches, kEdgeGrain / kDistanceBatchSize),
        [&](const tbb::blocked_range<Index>& r) {
          sweepEdges(level, limit, relaxation, particles, begin + r.begin() * kDistanceBatchSize,
                     std::min(end, begin + r.end() * kDistanceBatchSize));
        },
        tbb::static_partitioner());
  }
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
    // A particle inside every one of its tethers, with a margin that rounding cannot cross, is
    // where each projection below would leave it: their square roots are skipped.
    bool inside = true;
    for (Index t = level.tetherOffset[k]; t < end && inside; ++t)
      inside = surelyInsideTether(x, particles.p[level.tetherPin[t]], level.tetherLimit[t]);
    if (inside) return;
    for (Index t = level.tetherOffset[k]; t < end; t += 2)
      x = t + 1 < end
              ? projectOntoTetherPair(x, particles.p[level.tetherPin[t]], level.tetherLimit[t],
                                      particles.p[level.tetherPin[t + 1]], level.tetherLimit[t + 1])
              : projectOntoTether(x, particles.p[level.tetherPin[t]], level.tetherLimit[t]);
    particles.p[i] = x;
  };
  forEachIndex(level.particles.size(), level.edges.size() < kSerialEdges, kParticleGrain, project);
}

// sin(θ/2)/(θ/2) for the angle θ between two unit normals with cosine c: the chord of a
// circular arc of unit length turning by θ. With s = sin(θ/2) = √((1 − c)/2), θ/2 = asin s: up
// to θ = 60° by the series of asin s / s to s⁶ (relative error below 2e-4), a few multiplications
// (acos and sin for each coarse edge of a draped cloth took longer than the cascade's sweeps);
// wider turns, rare, exactly.
Real arcChordRatio(Real c) {
  const Real s2 = std::clamp((1 - c) / 2, Real(0), Real(1));
  if (s2 > Real(0.25)) {
    const Real s = std::sqrt(s2);
    return s / std::asin(s);
  }
  return 1 / (1 + s2 * (Real(1) / 6 + s2 * (Real(3) / 40 + s2 * (Real(5) / 112))));
}

// Between the sweeps of a level: each of its particles that rests on a static mesh is put back
// onto its contact's separating plane, n · p ≥ offset, along n (no multiplier: primitive contacts
// take their friction after the sweeps, and are projected with every other contact after the
// level). A coarse edge over a curved patch pulls its ends along the chord, into the support;
// left there for the level's remaining sweeps, a particle was dragged ever deeper toward its
// neighbours, and pushed out after the level it landed spread apart from them
// (bench/results/2core-AMD-EPYC/solver_speed.md §13). Particles on sphere colliders are settled
// by the hook (their contacts, with friction, as after every fine sweep round).
void keepOnMeshes(const HierarchyLevel& level, const CascadeScratch& scratch,
                  ParticlePool& particles) {
  const Index* support = scratch.supportId.data();
  forEachIndex(level.particles.size(), level.edges.size() < kSerialEdges, kParticleGrain,
               [&](std::size_t k) {
                 const Index i = level.particles[k];
                 if (support[i] == kNoSupport || !(support[i] & kMeshSupport)) return;
                 const Vec3& normal = scratch.supportNormal[i];
                 const Real gap = normal.dot(particles.p[i]) - scratch.supportOffset[i];
                 if (gap < 0) particles.p[i] -= gap * normal;
               });
}

// p_f = q_f + Σ_j w_fj (p_j − q_j) for the fine particles of `level` (total displacement), except
// the particles that have primitive contacts: they keep the place their contacts gave them. The
// prolonged place would drop that push (it starts from q_f), and an interpolated one would cut
// through what the particle touches; the fine sweeps then close the kink left around them. Under
// overwriting, a 200 m/s pellet got behind its cloth in 2 of 11 multigrid runs of bullet_cloth
// (iterations 4–16, 2 and 4 substeps), none with contact particles kept.
void prolong(const HierarchyLevel& level, bool serial, ParticlePool& particles,
             const std::vector<Vec3>& start, std::span<const Index> contactOffsets) {
  Vec3* p = particles.p.data();
  const Vec3* q = start.data();
  const Index* parentOffset = level.parentOffset.data();
  const Index* parent = level.parent.data();
  const Real* weight = level.weight.data();
  forEachIndex(level.fine.size(), serial, kParticleGrain, [&](std::size_t k) {
    const Index f = level.fine[k];
    if (!contactOffsets.empty() && contactOffsets[f + 1] > contactOffsets[f]) return;
    Vec3 moved = Vec3::Zero();
    for (Index n = parentOffset[k]; n != parentOffset[k + 1]; ++n)
      moved += weight[n] * (p[parent[n]] - q[parent[n]]);
    p[f] = q[f] + moved;
  });
}

// The limit each coarse edge is swept with this substep, where a collider holds the cloth.
// Its rest-pose distance bounds the chord only while the patch it stands for lies flat: over a
// curved patch (cloth draped on a sphere) the chord is shorter than the material between its
// ends, and a chord limit stays slack while that material stretches, so the coarse levels stop
// carrying stretch exactly where a collider holds the cloth. With the chord c and the current
// length P of the edge's path through the finer level (HierarchyLevel::path, rest length R),
// the patch is at rest length when P = R; keeping the shape's chord-to-path ratio, its chord is
// then c R / P. Where the path is stretched (P > R) the limit is the smaller of that and the
// rest distance: unchanged for a flat patch (c R / P is the rest distance under uniform
// stretch), it grips a curved one as soon as its material stretches. Only edges with both
// particles held bent get it: in contact with a sphere collider, or with a mesh collider (any
// particle of inverse mass 0) that is at rest this substep. A fold the cloth may open by itself is
// no such constraint (holding its chord made free hanging cloths worse); the ground bends nothing
// (there the limit only squeezed a pile's folds); and a curtain pushed by a moving box, its shape
// measured at the prediction, got chords no motion could give it (an edge at 3.6 times its rest
// length: bench/results/2core-AMD-EPYC/solver_speed.md §11). Measured once per cascade, from the
// positions it starts from. The same pass finds each coarse particle's support (the sphere
// collider or static mesh it rests on), which gives the convex-support limit below and what the
// pauses between a level's sweeps keep the particle on (keepOnMeshes, the hook's BetweenSweeps).
// `contacts` and `primitive` are the substep's collider and primitive contacts, null for none.
void setContactLimits(const ObjectHierarchy& hierarchy, const ParticlePool& particles,
                      const ContactPool* contacts, const ColliderPool* colliders,
                      const PrimitiveContactPool* primitive, CascadeScratch& scratch) {
  // Each of the object's particles held bent or not, once: by a sphere collider (a plane bends
  // nothing), or by a primitive contact with a particle of inverse mass 0 that does not move this
  // substep.
  const auto heldBent = [&](Index i) {
    if (contacts)
      for (Index c = contacts->runStart[i]; c != contacts->runStart[i + 1]; ++c)
        if (colliders->shape[contacts->collider[c]] != ColliderShape::Plane) return true;
    if (primitive)
      for (Index k = primitive->incidenceOffset[i]; k != primitive->incidenceOffset[i + 1]; ++k) {
        const Index c = primitive->incidence[k] >> 2;
        for (int s = 0; s < 4; ++s) {
          const Index j = primitive->particles[c][s];
          if (primitive->coefficient[c][s] != 0 && particles.w[j] == 0 &&
              particles.p[j] == particles.x[j])
            return true;
        }
      }
    return false;
  };
  // The surface a particle rests on: a sphere collider's contact surface (its normal at the
  // particle), or the separating plane of a vertex contact with a static mesh at rest.
  const auto findSupport = [&](Index i) {
    if (particles.w[i] == 0) return;  // a pin stays where it is
    if (contacts)
      for (Index c = contacts->runStart[i]; c != contacts->runStart[i + 1]; ++c) {
        const Index k = contacts->collider[c];
        if (colliders->shape[k] != ColliderShape::Sphere) continue;
        const Vec3 offset = particles.p[i] - colliders->point[k];
        const Real distance = offset.norm();
        if (!(distance > Real(1e-12))) continue;
        const Real surface = colliders->radius[k] + colliders->thickness[k];
        if (distance - surface > kSupportGap) continue;
        // The hook projects this particle's own contacts between sweeps: only the normal is kept.
        scratch.supportId[i] = k;
        scratch.supportNormal[i] = offset / distance;
        return;
      }
    if (primitive)
      for (Index e = primitive->incidenceOffset[i]; e != primitive->incidenceOffset[i + 1]; ++e) {
        const Index c = primitive->incidence[e] >> 2, slot = primitive->incidence[e] & 3;
        if (primitive->coefficient[c][slot] != 1) continue;  // not the contact's lone vertex
        bool staticMesh = true;
        Index mesh = kNoSupport;
        Real offset = primitive->distance[c];
        const Vec3 normal = primitive->normal[c];
        for (Index s = 0; s < 4 && staticMesh; ++s) {
          const Real coefficient = primitive->coefficient[c][s];
          if (s == slot || coefficient == 0) continue;
          const Index j = primitive->particles[c][s];
          staticMesh = particles.w[j] == 0 && particles.p[j] == particles.x[j];
          mesh = particles.phase[j];
          offset -= coefficient * normal.dot(particles.p[j]);
        }
        if (!staticMesh || mesh == kNoSupport) continue;
        if (normal.dot(particles.p[i]) - offset > kSupportGap) continue;
        scratch.supportId[i] = kMeshSupport | mesh;
        scratch.supportNormal[i] = normal;
        scratch.supportOffset[i] = offset;
        return;
      }
  };
  std::uint8_t* held = scratch.held.data();
  // Only the coarse particles end coarse edges and are swept: level 1 holds them all.
  const std::vector<Index>& coarse = hierarchy.levels[1].particles;
  forEachIndex(coarse.size(), coarse.size() < kSerialItems, kItemGrain, [&](std::size_t k) {
    const Index i = coarse[k];
    held[i] = heldBent(i) ? 1 : 0;
    scratch.supportId[i] = kNoSupport;
    findSupport(i);
  });
  const Index* support = scratch.supportId.data();
  const Vec3* supportNormal = scratch.supportNormal.data();
  for (std::size_t l = 1; l < hierarchy.levels.size(); ++l) {
    const HierarchyLevel& level = hierarchy.levels[l];
    Real* limit = scratch.limit.data() + level.scratchBase;
    forEachIndex(
        level.edges.size(), level.edges.size() < kSerialItems, kItemGrain, [&](std::size_t e) {
          const std::array<Index, 4>& path = level.path[e];
          const Real rest = level.restLength[e];
          limit[e] = rest;
          // Both ends on one curved support that turns away between them (convex): the
          // material between them, at rest length along the surface, is an arc of the
          // turning angle θ between the supports' normals, whose chord is rest ×
          // sin(θ/2)/(θ/2). Over a concave support the material may span straight.
          const Index from = path[0], to = path[3];
          if (support[from] != kNoSupport && support[from] == support[to] &&
              (supportNormal[to] - supportNormal[from]).dot(particles.p[to] - particles.p[from]) >
                  0) {
            limit[e] = rest * arcChordRatio(supportNormal[from].dot(supportNormal[to]));
          }
          if (!held[path[0]] || !held[path[3]]) return;
          const Vec3 a = particles.p[path[0]], f = particles.p[path[1]], g = particles.p[path[2]],
                     b = particles.p[path[3]];
          const Real length = (f - a).norm() + (g - f).norm() + (b - g).norm();
          if (!(length > level.pathRest[e])) return;
          limit[e] = std::min(limit[e], (b - a).norm() * level.pathRest[e] / length);
        });
  }
}

}  // namespace

std::size_t runMultigridCascade(const LevelHierarchies& hierarchies,
                                std::span<const ObjectRecord> objects, ParticlePool& particles,
                                CascadeScratch& scratch, std::span<const int> sweepsPerLevel,
                                CascadeHook afterLevel, void* context,
                                const CascadeContacts& contacts, Real relaxation) {
  if (sweepsOfLevel(sweepsPerLevel, 1) <= 0) return 0;
  std::vector<Vec3>& start = scratch.start;
  start.resize(particles.size());
  scratch.limit.resize(hierarchies.coarseEdges);
  scratch.held.resize(particles.size());
  scratch.supportId.resize(particles.size());
  scratch.supportNormal.resize(particles.size());
  scratch.supportOffset.resize(particles.size());
  const std::size_t n = particles.size();
  const ContactPool* colliderContacts = contacts.colliderContacts && contacts.colliders &&
                                                contacts.colliderContacts->size() > 0 &&
                                                contacts.colliderContacts->runStart.size() == n + 1
                                            ? contacts.colliderContacts
                                            : nullptr;
  const PrimitiveContactPool* primitiveContacts =
      contacts.primitiveContacts && contacts.primitiveContacts->size() > 0 &&
              contacts.primitiveContacts->incidenceOffset.size() == n + 1
          ? contacts.primitiveContacts
          : nullptr;
  // The CSR offsets of the particles' primitive contacts (empty for none).
  const std::span<const Index> contactOffsets =
      primitiveContacts ? std::span<const Index>(primitiveContacts->incidenceOffset)
                        : std::span<const Index>();
  const bool limits = colliderContacts || primitiveContacts;
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
    if (limits)
      setContactLimits(hierarchy, particles, colliderContacts, contacts.colliders,
                       primitiveContacts, scratch);
    for (std::size_t l = hierarchy.levels.size() - 1; l >= 1; --l) {
      const HierarchyLevel& level = hierarchy.levels[l];
      const Real* limit =
          limits ? scratch.limit.data() + level.scratchBase : level.restLength.data();
      const int sweeps = sweepsOfLevel(sweepsPerLevel, l);
      // The level's particles resting on a sphere collider, whose contacts the hook projects
      // between sweeps (a plane bends nothing, and a coarse edge's pull along it stays on it).
      std::vector<Index>& onSpheres = scratch.onSpheres;
      onSpheres.clear();
      if (limits && sweeps > 1)
        for (const Index i : level.particles)
          if (scratch.supportId[i] != kNoSupport && !(scratch.supportId[i] & kMeshSupport))
            onSpheres.push_back(i);
      if (afterLevel && !onSpheres.empty())
        afterLevel(context, onSpheres, CascadeMoment::BeforeSweeps);
      for (int k = 0; k < sweeps; ++k) {
        sweepLevel(level, limit, relaxation, particles);
        // After the last sweep the hook settles every contact of the level's particles.
        if (!limits || k + 1 == sweeps) continue;
        keepOnMeshes(level, scratch, particles);
        if (afterLevel && !onSpheres.empty())
          afterLevel(context, onSpheres, CascadeMoment::BetweenSweeps);
      }
      if (sweeps > 0) sweepLevelTethers(level, particles);
      projections += level.edges.size() * static_cast<std::size_t>(sweeps) +
                     (sweeps > 0 ? level.tetherPin.size() : 0);
      if (afterLevel) afterLevel(context, level.particles, CascadeMoment::AfterLevel);
      // A prolongation of a few thousand particles stays on the calling thread, which has just
      // written their parents (on both threads the 3,136 of a 128² cloth's level 1 took twice as
      // long).
      prolong(hierarchy.levels[l - 1], hierarchy.levels[l - 1].fine.size() < kSerialParticles,
              particles, start, contactOffsets);
    }
    if (afterLevel) afterLevel(context, {}, CascadeMoment::AfterCascade);
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
