#include "systems/collision/broad_phase.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/partitioner.h>

namespace nucleon {
namespace {

// Embree rejects bounds beyond ±1.844e18 (FLT_LARGE); a box must stay inside to be stored.
constexpr double kMaxCoordinate = 1e18;
constexpr std::size_t kBoxGrain = 2048;
// Queries per chunk: the fixed unit of parallel work, and of output order.
constexpr std::size_t kQueryChunk = 256;

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

// The primitive a query is made for, and where its partners go.
struct QueryContext {
  const CollisionPrimitives* primitives;
  const Real* w;
  const Index* isolatedPoints;  // tree primitive → point, for the IsolatedPoints tree
  std::vector<Index>* partners;
  std::array<Index, 2> particles;
  int particleCount;
  std::uint32_t object;
  bool pinned;  // all of the query's particles have inverse mass 0
  Index self;   // same-kind pairs keep only partners above the query: each pair once
};

// The filters every candidate goes through, in the order of their cost. Only boxes that overlap
// the query's reach here.
template <PairKind kKind>
void keepPartner(void* raw, Index primitive) {
  QueryContext& c = *static_cast<QueryContext*>(raw);
  const CollisionPrimitives& prims = *c.primitives;
  Index partner = primitive;
  std::span<const Index> particles;
  std::uint32_t object;
  if constexpr (kKind == PairKind::VertexFace) {
    particles = prims.triangleParticles[partner];
    object = prims.triangleObject[partner];
  } else if constexpr (kKind == PairKind::EdgeEdge || kKind == PairKind::VertexEdge) {
    if (kKind == PairKind::EdgeEdge && partner <= c.self) return;
    particles = prims.edgeParticles[partner];
    object = prims.edgeObject[partner];
  } else {
    partner = c.isolatedPoints[primitive];
    if (partner <= c.self) return;
    particles = {&prims.pointParticle[partner], 1};
    object = prims.pointObject[partner];
  }
  for (int k = 0; k < c.particleCount; ++k)
    for (Index b : particles)
      if (c.particles[k] == b) return;
  if (c.pinned &&
      std::all_of(particles.begin(), particles.end(), [&](Index b) { return c.w[b] == 0; }))
    return;
  if (!prims.excludedPairs.empty() && prims.excluded(c.object, object)) return;
  c.partners->push_back(partner);
}

// The queries of one pair kind: which tree they search, how many there are, where their chunks
// and per-query counts start.
struct Segment {
  PairKind kind;
  BvhTree tree;
  std::size_t queries;
  std::size_t firstChunk;
  std::size_t firstQuery;
};

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

  // Boxes.
  Clock::time_point start = Clock::now();
  stats.skippedPrimitives =
      computeBoxes(bvh.pointBoxes, points, primitives, primitives.pointRadius, pointParticles, x, p,
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
    isolatedBoxes[k] = bvh.pointBoxes[bvh.isolatedPoints[k]];
  stats.boxSeconds = secondsSince(start);

  // Trees.
  start = Clock::now();
  stats.rebuilt = bvh.commit();
  stats.commitSeconds = secondsSince(start);

  // Queries, in the output order: kind by kind, each over its queries in index order.
  start = Clock::now();
  const std::size_t isolated = bvh.isolatedPoints.size();
  std::array<Segment, 4> segments = {
      Segment{PairKind::VertexFace, BvhTree::Triangles, triangles ? points : 0, 0, 0},
      Segment{PairKind::EdgeEdge, BvhTree::Edges, edges, 0, 0},
      Segment{PairKind::VertexEdge, BvhTree::Edges, edges ? isolated : 0, 0, 0},
      Segment{PairKind::VertexVertex, BvhTree::IsolatedPoints, isolated, 0, 0}};
  std::size_t chunks = 0, queries = 0;
  for (Segment& s : segments) {
    s.firstChunk = chunks;
    s.firstQuery = queries;
    chunks += (s.queries + kQueryChunk - 1) / kQueryChunk;
    queries += s.queries;
  }
  bvh.partnerCount.resize(queries);
  if (bvh.chunkPartners.size() < chunks) bvh.chunkPartners.resize(chunks);
  bvh.chunkOffset.resize(chunks + 1);

  // The first index of each query's pairs: a point or an edge of the primitive lists.
  auto queryPrimitive = [&](const Segment& s, std::size_t q) -> Index {
    return s.kind == PairKind::VertexEdge || s.kind == PairKind::VertexVertex
               ? bvh.isolatedPoints[q]
               : static_cast<Index>(q);
  };
  auto segmentOf = [&](std::size_t chunk) -> const Segment& {
    std::size_t s = 3;
    while (segments[s].firstChunk > chunk || segments[s].queries == 0) --s;
    return segments[s];
  };

  // Chunks are fixed ranges of queries, so which pairs a chunk holds, and in which order, does
  // not depend on the thread that runs it; the scheduler is free to balance them.
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, chunks, 1),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t chunk = r.begin(); chunk != r.end(); ++chunk) {
          const Segment& s = segmentOf(chunk);
          const std::size_t begin = (chunk - s.firstChunk) * kQueryChunk;
          const std::size_t end = std::min(s.queries, begin + kQueryChunk);
          std::vector<Index>& partners = bvh.chunkPartners[chunk];
          partners.clear();
          QueryContext context{
              &primitives, w.data(), bvh.isolatedPoints.data(), &partners, {}, 0, 0, false, 0};
          PrimitiveBvh::Visitor visit = nullptr;
          switch (s.kind) {
            case PairKind::VertexFace:
              visit = &keepPartner<PairKind::VertexFace>;
              break;
            case PairKind::EdgeEdge:
              visit = &keepPartner<PairKind::EdgeEdge>;
              break;
            case PairKind::VertexEdge:
              visit = &keepPartner<PairKind::VertexEdge>;
              break;
            case PairKind::VertexVertex:
              visit = &keepPartner<PairKind::VertexVertex>;
              break;
          }
          for (std::size_t q = begin; q < end; ++q) {
            const std::size_t first = partners.size();
            const Index self = queryPrimitive(s, q);
            const PrimitiveBox* box;
            if (s.kind == PairKind::EdgeEdge) {
              const auto& e = primitives.edgeParticles[self];
              context.particles = e;
              context.particleCount = 2;
              context.object = primitives.edgeObject[self];
              context.pinned = w[e[0]] == 0 && w[e[1]] == 0;
              box = &edgeBoxes[self];
            } else {
              const Index particle = primitives.pointParticle[self];
              context.particles = {particle, particle};
              context.particleCount = 1;
              context.object = primitives.pointObject[self];
              context.pinned = w[particle] == 0;
              box = &bvh.pointBoxes[self];
            }
            context.self = self;
            bvh.forEachOverlap(s.tree, *box, visit, &context);
            // Embree reports in tree order; sorting each query's partners makes the output
            // independent of the tree's shape (and so of a rebuild or a refit).
            std::sort(partners.begin() + first, partners.end());
            bvh.partnerCount[s.firstQuery + q] = static_cast<Index>(partners.size() - first);
          }
        }
      },
      tbb::simple_partitioner());

  std::size_t total = 0;
  for (const Segment& s : segments) {
    const std::size_t segmentChunks = (s.queries + kQueryChunk - 1) / kQueryChunk;
    const std::size_t segmentStart = total;
    for (std::size_t chunk = s.firstChunk; chunk < s.firstChunk + segmentChunks; ++chunk) {
      bvh.chunkOffset[chunk] = total;
      total += bvh.chunkPartners[chunk].size();
    }
    stats.pairs[static_cast<std::size_t>(s.kind)] = total - segmentStart;
  }
  bvh.chunkOffset[chunks] = total;
  out.kind.resize(total);
  out.first.resize(total);
  out.second.resize(total);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, chunks, 1),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t chunk = r.begin(); chunk != r.end(); ++chunk) {
          const Segment& s = segmentOf(chunk);
          const std::size_t begin = (chunk - s.firstChunk) * kQueryChunk;
          const std::size_t end = std::min(s.queries, begin + kQueryChunk);
          const std::vector<Index>& partners = bvh.chunkPartners[chunk];
          std::size_t at = bvh.chunkOffset[chunk], next = 0;
          for (std::size_t q = begin; q < end; ++q) {
            const Index first = queryPrimitive(s, q);
            for (Index k = 0; k < bvh.partnerCount[s.firstQuery + q]; ++k, ++at, ++next) {
              out.kind[at] = s.kind;
              out.first[at] = first;
              out.second[at] = partners[next];
            }
          }
        }
      },
      tbb::simple_partitioner());
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
