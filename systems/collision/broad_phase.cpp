#include "systems/collision/broad_phase.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

namespace nucleon {
namespace {

// Embree rejects bounds beyond ±1.844e18 (FLT_LARGE); a box must stay inside to be stored.
constexpr double kMaxCoordinate = 1e18;
constexpr std::size_t kBoxGrain = 2048;
constexpr std::size_t kPairGrain = 4096;

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::span<const Index> pointParticles(const CollisionPrimitives& primitives, std::size_t i) {
  return {&primitives.pointParticle[i], 1};
}
std::span<const Index> edgeParticles(const CollisionPrimitives& primitives, std::size_t i) {
  return primitives.edgeParticles[i];
}
std::span<const Index> triangleParticles(const CollisionPrimitives& primitives, std::size_t i) {
  return primitives.triangleParticles[i];
}

// The swept box of each primitive of one kind into `boxes`; returns how many are empty.
template <class Particles>
std::size_t computeBoxes(std::vector<PrimitiveBox>& boxes, std::size_t count,
                         const CollisionPrimitives& primitives, const std::vector<Real>& radius,
                         Particles particlesOf, std::span<const Vec3> x, std::span<const Vec3> p,
                         Real margin) {
  boxes.resize(count);
  // Integer sums: the same total for any partitioning.
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, count, kBoxGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t empty) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          boxes[i] = sweptBox(particlesOf(primitives, i), x, p, radius[i] + margin / 2);
          empty += boxes[i].isEmpty();
        }
        return empty;
      },
      std::plus<>());
}

// What the pair callbacks need to filter a pair and keep it.
struct PairFilter {
  const CollisionPrimitives* primitives;
  const Real* w;
  const Index* isolatedPoints;  // tree primitive → point, for the IsolatedPoints tree
  std::vector<std::vector<std::uint64_t>>* found;  // one list per thread of the arena
};

// The filters every pair of overlapping boxes goes through, in the order of their cost; a pair
// kept is stored as first << 32 | second in the running thread's list.
template <PairKind kKind>
void keepPairs(void* raw, const Index* a, const Index* b, std::size_t count) {
  const PairFilter& f = *static_cast<const PairFilter*>(raw);
  const CollisionPrimitives& prims = *f.primitives;
  // Embree's traversal runs as tasks of the caller's arena, whose threads have indices below its
  // concurrency, for which the lists were made.
  std::vector<std::uint64_t>& found =
      (*f.found)[static_cast<std::size_t>(tbb::this_task_arena::current_thread_index())];
  for (std::size_t k = 0; k < count; ++k) {
    Index first = a[k], second = b[k];
    std::span<const Index> particlesA, particlesB;
    std::uint32_t objectA, objectB;
    if constexpr (kKind == PairKind::VertexFace) {
      particlesA = {&prims.pointParticle[first], 1};
      particlesB = prims.triangleParticles[second];
      objectA = prims.pointObject[first], objectB = prims.triangleObject[second];
    } else if constexpr (kKind == PairKind::EdgeEdge) {
      particlesA = prims.edgeParticles[first];
      particlesB = prims.edgeParticles[second];
      objectA = prims.edgeObject[first], objectB = prims.edgeObject[second];
    } else if constexpr (kKind == PairKind::VertexEdge) {
      first = f.isolatedPoints[first];
      particlesA = {&prims.pointParticle[first], 1};
      particlesB = prims.edgeParticles[second];
      objectA = prims.pointObject[first], objectB = prims.edgeObject[second];
    } else {
      // The tree's points ascend, so first < second still holds.
      first = f.isolatedPoints[first], second = f.isolatedPoints[second];
      particlesA = {&prims.pointParticle[first], 1};
      particlesB = {&prims.pointParticle[second], 1};
      objectA = prims.pointObject[first], objectB = prims.pointObject[second];
    }
    bool shared = false, free = false;
    for (Index i : particlesA) {
      for (Index j : particlesB) shared |= i == j;
      free |= f.w[i] != 0;
    }
    if (shared) continue;
    for (Index j : particlesB) free |= f.w[j] != 0;
    if (!free) continue;
    if (!prims.excludedPairs.empty() && prims.excluded(objectA, objectB)) continue;
    found.push_back(std::uint64_t{first} << 32 | second);
  }
}

// Appends the pairs the threads found, of one kind whose first index is below `firsts`, to `out`
// sorted by (first, second): a counting sort by first index (integer atomics: the same counts
// in any order), then each first index's few partners sorted, so that the result does not depend
// on which thread found which pair. Returns how many were appended.
std::size_t appendInOrder(CandidatePairs& out, PrimitiveBvh& bvh, PairKind kind,
                          std::size_t firsts) {
  bvh.pairOffset.assign(firsts + 1, 0);
  for (std::vector<std::uint64_t>& found : bvh.threadPairs)
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, found.size(), kPairGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i)
                          std::atomic_ref<Index>(bvh.pairOffset[(found[i] >> 32) + 1])
                              .fetch_add(1, std::memory_order_relaxed);
                      });
  const std::size_t base = out.size();
  for (std::size_t i = 0; i < firsts; ++i) bvh.pairOffset[i + 1] += bvh.pairOffset[i];
  const std::size_t added = bvh.pairOffset[firsts];
  out.kind.resize(base + added, kind);
  out.first.resize(base + added);
  out.second.resize(base + added);
  bvh.pairCursor.assign(bvh.pairOffset.begin(), bvh.pairOffset.end() - 1);
  for (std::vector<std::uint64_t>& found : bvh.threadPairs) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, found.size(), kPairGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i) {
                          const Index first = static_cast<Index>(found[i] >> 32);
                          const Index at = std::atomic_ref<Index>(bvh.pairCursor[first])
                                               .fetch_add(1, std::memory_order_relaxed);
                          out.second[base + at] = static_cast<Index>(found[i] & 0xffffffffu);
                        }
                      });
    found.clear();
  }
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, firsts, kBoxGrain),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const std::size_t begin = base + bvh.pairOffset[i], end = base + bvh.pairOffset[i + 1];
          std::sort(out.second.begin() + begin, out.second.begin() + end);
          std::fill(out.first.begin() + begin, out.first.begin() + end, static_cast<Index>(i));
        }
      });
  return added;
}

}  // namespace

PrimitiveBox sweptBox(std::span<const Index> particles, std::span<const Vec3> x,
                      std::span<const Vec3> p, Real inflation) {
  double lower[3] = {kMaxCoordinate, kMaxCoordinate, kMaxCoordinate};
  double upper[3] = {-kMaxCoordinate, -kMaxCoordinate, -kMaxCoordinate};
  for (Index i : particles)
    for (const Vec3* position : {&x[i], &p[i]})
      for (int k = 0; k < 3; ++k) {
        const double v = (*position)[k];
        // Written so that a NaN fails the test too.
        if (!(std::abs(v) <= kMaxCoordinate)) return PrimitiveBox::empty();
        lower[k] = std::min(lower[k], v);
        upper[k] = std::max(upper[k], v);
      }
  const double grow = inflation;
  if (!(std::abs(grow) <= kMaxCoordinate)) return PrimitiveBox::empty();
  PrimitiveBox box;
  for (int k = 0; k < 3; ++k) {
    // Rounded to the nearest float, then one float further out: the float box contains the
    // double one whatever the rounding of the conversion and of the double arithmetic before it.
    const double lo = lower[k] - grow, hi = upper[k] + grow;
    if (!(std::abs(lo) <= kMaxCoordinate && std::abs(hi) <= kMaxCoordinate))
      return PrimitiveBox::empty();
    box.lower[k] = std::nextafter(static_cast<float>(lo), -std::numeric_limits<float>::infinity());
    box.upper[k] = std::nextafter(static_cast<float>(hi), std::numeric_limits<float>::infinity());
  }
  return box;
}

BroadPhaseStats findCandidatePairs(CandidatePairs& out, PrimitiveBvh& bvh,
                                   const CollisionPrimitives& primitives, std::span<const Vec3> x,
                                   std::span<const Vec3> p, std::span<const Real> w, Real margin) {
  BroadPhaseStats stats;
  const std::size_t points = primitives.points(), edges = primitives.edges(),
                    triangles = primitives.triangles();
  auto& triangleBoxes = bvh.boxes[static_cast<std::size_t>(BvhTree::Triangles)];
  auto& edgeBoxes = bvh.boxes[static_cast<std::size_t>(BvhTree::Edges)];
  auto& isolatedBoxes = bvh.boxes[static_cast<std::size_t>(BvhTree::IsolatedPoints)];
  auto& pointBoxes = bvh.boxes[static_cast<std::size_t>(BvhTree::Points)];

  // Boxes.
  Clock::time_point start = Clock::now();
  stats.skippedPrimitives =
      computeBoxes(pointBoxes, points, primitives, primitives.pointRadius, pointParticles, x, p,
                   margin) +
      computeBoxes(edgeBoxes, edges, primitives, primitives.edgeRadius, edgeParticles, x, p,
                   margin) +
      computeBoxes(triangleBoxes, triangles, primitives, primitives.triangleRadius,
                   triangleParticles, x, p, margin);
  bvh.isolatedPoints.clear();
  for (std::size_t i = 0; i < points; ++i)
    if (primitives.pointIsolated[i]) bvh.isolatedPoints.push_back(static_cast<Index>(i));
  isolatedBoxes.resize(bvh.isolatedPoints.size());
  for (std::size_t k = 0; k < bvh.isolatedPoints.size(); ++k)
    isolatedBoxes[k] = pointBoxes[bvh.isolatedPoints[k]];
  // Every point's box is needed only against triangles.
  if (triangles == 0) pointBoxes.clear();
  stats.boxSeconds = secondsSince(start);

  // Trees.
  start = Clock::now();
  stats.rebuilt = bvh.commit();
  stats.commitSeconds = secondsSince(start);

  // Pairs, kind by kind, each found by one dual-tree traversal and then put in order.
  start = Clock::now();
  out.clear();
  bvh.threadPairs.resize(
      std::max<std::size_t>(bvh.threadPairs.size(), tbb::this_task_arena::max_concurrency()));
  for (std::vector<std::uint64_t>& found : bvh.threadPairs) found.clear();
  PairFilter filter{&primitives, w.data(), bvh.isolatedPoints.data(), &bvh.threadPairs};
  struct Traversal {
    PairKind kind;
    BvhTree a, b;
    PrimitiveBvh::PairVisitor keep;
  };
  constexpr std::array<Traversal, 4> traversals = {{
      {PairKind::VertexFace, BvhTree::Points, BvhTree::Triangles, &keepPairs<PairKind::VertexFace>},
      {PairKind::EdgeEdge, BvhTree::Edges, BvhTree::Edges, &keepPairs<PairKind::EdgeEdge>},
      {PairKind::VertexEdge, BvhTree::IsolatedPoints, BvhTree::Edges,
       &keepPairs<PairKind::VertexEdge>},
      {PairKind::VertexVertex, BvhTree::IsolatedPoints, BvhTree::IsolatedPoints,
       &keepPairs<PairKind::VertexVertex>},
  }};
  for (const Traversal& t : traversals) {
    bvh.forEachOverlappingPair(t.a, t.b, t.keep, &filter);
    const std::size_t firsts = t.kind == PairKind::EdgeEdge ? edges : points;
    stats.pairs[static_cast<std::size_t>(t.kind)] = appendInOrder(out, bvh, t.kind, firsts);
  }
  stats.querySeconds = secondsSince(start);
  return stats;
}

void predictMotionBounds(CandidatePairs& pairs, std::span<const Vec3> x, std::span<const Vec3> p,
                         std::span<const Real> w, const Vec3& g, Real h, int remaining) {
  pairs.boundLower.resize(x.size());
  pairs.boundUpper.resize(x.size());
  const Real steps = static_cast<Real>(remaining);
  const Vec3 fall = (steps * (steps - 1) / 2 * h * h) * g;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, x.size(), kBoxGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        Vec3 end = x[i] + steps * (p[i] - x[i]);
                        if (w[i] > 0) end += fall;
                        pairs.boundLower[i] = x[i].cwiseMin(end);
                        pairs.boundUpper[i] = x[i].cwiseMax(end);
                      }
                    });
}

void setMotionBounds(CandidatePairs& pairs, std::span<const Vec3> start,
                     std::span<const Vec3> end) {
  pairs.boundLower.resize(start.size());
  pairs.boundUpper.resize(start.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, start.size(), kBoxGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        pairs.boundLower[i] = start[i].cwiseMin(end[i]);
                        pairs.boundUpper[i] = start[i].cwiseMax(end[i]);
                      }
                    });
}

Real boundSlack(const CollisionPrimitives& primitives, Real margin) {
  return kBoundSlackFraction * (2 * primitives.smallestRadius + margin);
}

void growParticleBounds(CandidatePairs& pairs, Real slack) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pairs.boundLower.size(), kBoxGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        pairs.boundLower[i].array() -= slack;
                        pairs.boundUpper[i].array() += slack;
                      }
                    });
}

bool withinParticleBounds(const CandidatePairs& pairs, std::span<const Vec3> p) {
  if (pairs.boundLower.size() != p.size()) return false;
  const std::size_t outside = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, p.size(), kBoxGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t count) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
          // Written so that a non-finite coordinate does not count as outside.
          count += (p[i].array() < pairs.boundLower[i].array()).any() ||
                   (p[i].array() > pairs.boundUpper[i].array()).any();
        return count;
      },
      std::plus<>());
  return outside == 0;
}

BroadPhaseStats findCandidatePairsBruteForce(CandidatePairs& out,
                                             const CollisionPrimitives& primitives,
                                             std::span<const Vec3> x, std::span<const Vec3> p,
                                             std::span<const Real> w, Real margin) {
  BroadPhaseStats stats;
  out.clear();
  std::vector<PrimitiveBox> pointBoxes, edgeBoxes, triangleBoxes;
  for (std::size_t i = 0; i < primitives.points(); ++i)
    pointBoxes.push_back(
        sweptBox(pointParticles(primitives, i), x, p, primitives.pointRadius[i] + margin / 2));
  for (std::size_t i = 0; i < primitives.edges(); ++i)
    edgeBoxes.push_back(
        sweptBox(edgeParticles(primitives, i), x, p, primitives.edgeRadius[i] + margin / 2));
  for (std::size_t i = 0; i < primitives.triangles(); ++i)
    triangleBoxes.push_back(sweptBox(triangleParticles(primitives, i), x, p,
                                     primitives.triangleRadius[i] + margin / 2));
  for (const auto* boxes : {&pointBoxes, &edgeBoxes, &triangleBoxes})
    for (const PrimitiveBox& box : *boxes) stats.skippedPrimitives += box.isEmpty();

  auto admissible = [&](std::span<const Index> a, std::uint32_t objectA, std::span<const Index> b,
                        std::uint32_t objectB) {
    bool free = false;
    for (Index i : a) {
      for (Index j : b)
        if (i == j) return false;
      free |= w[i] != 0;
    }
    for (Index j : b) free |= w[j] != 0;
    return free && !primitives.excluded(objectA, objectB);
  };
  auto add = [&](PairKind kind, std::size_t a, std::size_t b) {
    out.push_back(kind, static_cast<Index>(a), static_cast<Index>(b));
    ++stats.pairs[static_cast<std::size_t>(kind)];
  };

  for (std::size_t i = 0; i < primitives.points(); ++i)
    for (std::size_t t = 0; t < primitives.triangles(); ++t)
      if (overlaps(pointBoxes[i], triangleBoxes[t]) &&
          admissible(pointParticles(primitives, i), primitives.pointObject[i],
                     triangleParticles(primitives, t), primitives.triangleObject[t]))
        add(PairKind::VertexFace, i, t);
  for (std::size_t a = 0; a < primitives.edges(); ++a)
    for (std::size_t b = a + 1; b < primitives.edges(); ++b)
      if (overlaps(edgeBoxes[a], edgeBoxes[b]) &&
          admissible(edgeParticles(primitives, a), primitives.edgeObject[a],
                     edgeParticles(primitives, b), primitives.edgeObject[b]))
        add(PairKind::EdgeEdge, a, b);
  for (std::size_t i = 0; i < primitives.points(); ++i) {
    if (!primitives.pointIsolated[i]) continue;
    for (std::size_t e = 0; e < primitives.edges(); ++e)
      if (overlaps(pointBoxes[i], edgeBoxes[e]) &&
          admissible(pointParticles(primitives, i), primitives.pointObject[i],
                     edgeParticles(primitives, e), primitives.edgeObject[e]))
        add(PairKind::VertexEdge, i, e);
  }
  for (std::size_t i = 0; i < primitives.points(); ++i) {
    if (!primitives.pointIsolated[i]) continue;
    for (std::size_t j = i + 1; j < primitives.points(); ++j)
      if (primitives.pointIsolated[j] && overlaps(pointBoxes[i], pointBoxes[j]) &&
          admissible(pointParticles(primitives, i), primitives.pointObject[i],
                     pointParticles(primitives, j), primitives.pointObject[j]))
        add(PairKind::VertexVertex, i, j);
  }
  return stats;
}

}  // namespace nucleon
