// The broad phase (systems/broad_phase.*): Embree's candidate pairs against the brute force, pair
// for pair, on random primitive soups and on a cloth folded over itself; the same pairs for one
// and two threads; the tree refit while the counts stay and rebuilt when they change; the pair
// rules of components/candidate_pairs.h; non-finite positions and empty input.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <tuple>
#include <vector>

#include <tbb/task_arena.h>

#include <gtest/gtest.h>

#include "components/candidate_pairs.h"
#include "components/collision_primitives.h"
#include "components/primitive_bvh.h"
#include "nucleon/shapes.h"
#include "systems/collision/broad_phase.h"
#include "systems/collision/primitive_distance.h"

namespace nucleon {
namespace {

struct Scene {
  CollisionPrimitives primitives;
  std::vector<Vec3> x, p;
  std::vector<Real> w;
  Real margin = Real(0.01);

  BroadPhaseStats embree(CandidatePairs& out, PrimitiveBvh& bvh) const {
    return findCandidatePairs(out, bvh, primitives, x, p, w, margin);
  }
  BroadPhaseStats bruteForce(CandidatePairs& out) const {
    return findCandidatePairsBruteForce(out, primitives, x, p, w, margin);
  }
};

void addPoint(CollisionPrimitives& c, Index particle, Real radius, std::uint32_t object,
              bool isolated) {
  c.pointParticle.push_back(particle);
  c.pointRadius.push_back(radius);
  c.pointObject.push_back(object);
  c.pointIsolated.push_back(isolated);
}
void addEdge(CollisionPrimitives& c, Index a, Index b, Real radius, std::uint32_t object) {
  c.edgeParticles.push_back({std::min(a, b), std::max(a, b)});
  c.edgeRadius.push_back(radius);
  c.edgeObject.push_back(object);
}
void addTriangle(CollisionPrimitives& c, std::array<Index, 3> t, Real radius,
                 std::uint32_t object) {
  c.triangleParticles.push_back(t);
  c.triangleRadius.push_back(radius);
  c.triangleObject.push_back(object);
}

// Four objects of 60 particles in a unit cube moving up to 0.06 per axis: two triangle soups
// (with their edges), a rope with loose particles, a particle cloud. Radii vary per primitive;
// every sixth particle is pinned. Objects 0 and 1 never collide with each other and object 2 not
// with itself.
Scene randomScene(unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> unit(0, 1), motion(-0.06, 0.06), radius(0.002, 0.03);
  Scene s;
  const Index perObject = 60;
  for (std::uint32_t o = 0; o < 4; ++o) {
    const Index first = o * perObject;
    for (Index i = 0; i < perObject; ++i) {
      const Vec3 x(Real(unit(random)), Real(unit(random)), Real(unit(random)));
      s.x.push_back(x);
      s.p.push_back(x + Vec3(Real(motion(random)), Real(motion(random)), Real(motion(random))));
      s.w.push_back(random() % 6 == 0 ? Real(0) : Real(1));
    }
    std::vector<bool> inEdge(perObject, false);
    std::set<std::pair<Index, Index>> edges;
    auto local = [&](Index n) { return Index(random() % n); };
    if (o < 2) {
      for (int t = 0; t < 30; ++t) {
        // Corners drawn near each other, so that triangles are small and share vertices.
        const Index a = local(perObject - 6);
        std::array<Index, 3> tri = {first + a, first + a + 1 + local(3), first + a + 4 + local(2)};
        if (random() % 2) std::swap(tri[1], tri[2]);
        addTriangle(s.primitives, tri, Real(radius(random)), o);
        for (int k = 0; k < 3; ++k) {
          const Index u = std::min(tri[k], tri[(k + 1) % 3]),
                      v = std::max(tri[k], tri[(k + 1) % 3]);
          edges.insert({u, v});
        }
      }
    } else if (o == 2) {
      for (Index i = 0; i + 1 < perObject / 2; ++i) edges.insert({first + i, first + i + 1});
    }
    for (const auto& [u, v] : edges) {
      addEdge(s.primitives, u, v, Real(radius(random)), o);
      inEdge[u - first] = inEdge[v - first] = true;
    }
    for (Index i = 0; i < perObject; ++i)
      addPoint(s.primitives, first + i, Real(radius(random)), o, !inEdge[i]);
  }
  s.primitives.excludedPairs = {CollisionPrimitives::pairKey(0, 1),
                                CollisionPrimitives::pairKey(2, 2)};
  std::sort(s.primitives.excludedPairs.begin(), s.primitives.excludedPairs.end());
  s.margin = Real(0.005);
  return s;
}

// A 1 m cloth of n × n vertices folded into three layers stacked 3/4 of an edge apart, falling
// by a third of an edge over the substep with a little jitter; radius a quarter of an edge. One
// row is pinned.
Scene foldedCloth(int n, unsigned seed) {
  GridSpec spec;
  spec.resolution = {n, n};
  spec.size = {1, 1};
  spec.center = Vec3(0, 0, 0);
  const ObjectDef cloth = gridCloth(spec);
  const Real edge = Real(1) / Real(n - 1);
  const Real radius = edge / 4, gap = 3 * radius;
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> jitter(-0.05 * edge, 0.05 * edge);
  Scene s;
  for (std::size_t v = 0; v < cloth.vertices.size(); ++v) {
    const Vec3& rest = cloth.vertices[v];
    const Real along = (rest.x() + Real(0.5)) * 3;
    const int layer = std::min(int(along), 2);
    const Real t = along - Real(layer);
    const Real folded = layer % 2 == 0 ? t : 1 - t;
    const Vec3 x(folded / 3, Real(layer) * gap, rest.z());
    s.x.push_back(x);
    s.p.push_back(
        x + Vec3(Real(jitter(random)), -edge / 3 + Real(jitter(random)), Real(jitter(random))));
    s.w.push_back(v < std::size_t(n) ? Real(0) : Real(1));
  }
  std::set<std::pair<Index, Index>> edges;
  for (const auto& t : cloth.triangles) {
    addTriangle(s.primitives, t, radius, 0);
    for (int k = 0; k < 3; ++k)
      edges.insert({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
  }
  for (const auto& [u, v] : edges) addEdge(s.primitives, u, v, radius, 0);
  for (Index v = 0; v < cloth.vertices.size(); ++v) addPoint(s.primitives, v, radius, 0, false);
  s.margin = radius;
  return s;
}

void expectSamePairs(const CandidatePairs& a, const CandidatePairs& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(a.kind == b.kind);
  EXPECT_TRUE(a.first == b.first);
  EXPECT_TRUE(a.second == b.second);
}

std::vector<Index> particlesOf(const CollisionPrimitives& c, PairKind kind, bool first, Index i) {
  const bool point = first ? kind != PairKind::EdgeEdge : kind == PairKind::VertexVertex;
  const bool triangle = !first && kind == PairKind::VertexFace;
  if (point) return {c.pointParticle[i]};
  if (triangle) return {c.triangleParticles[i].begin(), c.triangleParticles[i].end()};
  return {c.edgeParticles[i].begin(), c.edgeParticles[i].end()};
}
std::uint32_t objectOf(const CollisionPrimitives& c, PairKind kind, bool first, Index i) {
  const bool point = first ? kind != PairKind::EdgeEdge : kind == PairKind::VertexVertex;
  if (point) return c.pointObject[i];
  if (!first && kind == PairKind::VertexFace) return c.triangleObject[i];
  return c.edgeObject[i];
}

// The rules of components/candidate_pairs.h, pair by pair.
void expectPairRules(const Scene& s, const CandidatePairs& pairs) {
  const CollisionPrimitives& c = s.primitives;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const PairKind kind = pairs.kind[k];
    const Index a = pairs.first[k], b = pairs.second[k];
    if (k > 0) {
      ASSERT_LT(std::make_tuple(pairs.kind[k - 1], pairs.first[k - 1], pairs.second[k - 1]),
                std::make_tuple(kind, a, b));
    }
    if (kind == PairKind::EdgeEdge || kind == PairKind::VertexVertex) {
      ASSERT_LT(a, b);
    }
    if (kind == PairKind::VertexEdge || kind == PairKind::VertexVertex) {
      ASSERT_TRUE(c.pointIsolated[a]);
    }
    if (kind == PairKind::VertexVertex) {
      ASSERT_TRUE(c.pointIsolated[b]);
    }
    const auto pa = particlesOf(c, kind, true, a), pb = particlesOf(c, kind, false, b);
    bool free = false;
    for (Index i : pa) {
      free |= s.w[i] != 0;
      for (Index j : pb) ASSERT_NE(i, j) << "pair " << k << " shares a particle";
    }
    for (Index j : pb) free |= s.w[j] != 0;
    ASSERT_TRUE(free) << "pair " << k << " has no free particle";
    ASSERT_FALSE(c.excluded(objectOf(c, kind, true, a), objectOf(c, kind, false, b)));
  }
}

std::size_t countKind(const CandidatePairs& pairs, PairKind kind) {
  return std::count(pairs.kind.begin(), pairs.kind.end(), kind);
}

TEST(BroadPhase, SweptBoxContainsTheSweptPrimitiveRoundedOutward) {
  const std::vector<Vec3> x = {Vec3(Real(0.1), Real(0.2), Real(-0.3)), Vec3(1, 2, 3)};
  const std::vector<Vec3> p = {Vec3(Real(0.15), Real(0.1), Real(-0.35)), Vec3(1, Real(2.5), 3)};
  const std::array<Index, 2> edge = {0, 1};
  const Real grow = Real(0.0123);
  const PrimitiveBox box = sweptBox(edge, x, p, grow);
  ASSERT_FALSE(box.isEmpty());
  for (int k = 0; k < 3; ++k) {
    double lo = 1e30, hi = -1e30;
    for (const auto* v : {&x[0], &x[1], &p[0], &p[1]}) {
      lo = std::min(lo, double((*v)[k])), hi = std::max(hi, double((*v)[k]));
    }
    EXPECT_LT(double(box.lower[k]), lo - double(grow));
    EXPECT_GT(double(box.upper[k]), hi + double(grow));
    EXPECT_GT(double(box.lower[k]), lo - double(grow) - 1e-5);
    EXPECT_LT(double(box.upper[k]), hi + double(grow) + 1e-5);
  }
  std::vector<Vec3> bad = x;
  bad[1].y() = std::numeric_limits<Real>::quiet_NaN();
  EXPECT_TRUE(sweptBox(edge, bad, p, grow).isEmpty());
  bad[1].y() = std::numeric_limits<Real>::infinity();
  EXPECT_TRUE(sweptBox(edge, bad, p, grow).isEmpty());
}

TEST(BroadPhase, RandomScenesMatchTheBruteForce) {
  for (unsigned seed : {1u, 2u, 3u, 4u, 5u, 6u}) {
    SCOPED_TRACE(seed);
    const Scene s = randomScene(seed);
    CandidatePairs reference, pairs;
    PrimitiveBvh bvh;
    const BroadPhaseStats expected = s.bruteForce(reference);
    const BroadPhaseStats stats = s.embree(pairs, bvh);
    expectSamePairs(pairs, reference);
    expectPairRules(s, pairs);
    EXPECT_EQ(stats.pairs, expected.pairs);
    EXPECT_EQ(stats.skippedPrimitives, 0u);
    for (PairKind kind :
         {PairKind::VertexFace, PairKind::EdgeEdge, PairKind::VertexEdge, PairKind::VertexVertex}) {
      EXPECT_GT(countKind(pairs, kind), 0u) << "kind " << int(kind);
      EXPECT_EQ(countKind(pairs, kind), stats.pairs[std::size_t(kind)]);
    }
    EXPECT_EQ(bvh.embreeErrors(), 0u);
  }
}

TEST(BroadPhase, ExclusionsAndPinsAreApplied) {
  const Scene s = randomScene(11);
  CandidatePairs pairs;
  PrimitiveBvh bvh;
  s.embree(pairs, bvh);
  // Turning the rules off changes the result, so the scene does exercise them.
  Scene open = s;
  open.primitives.excludedPairs.clear();
  std::fill(open.w.begin(), open.w.end(), Real(1));
  CandidatePairs more;
  open.embree(more, bvh);
  EXPECT_GT(more.size(), pairs.size());
  CandidatePairs reference;
  open.bruteForce(reference);
  expectSamePairs(more, reference);
}

TEST(BroadPhase, FoldedClothMatchesTheBruteForce) {
  const Scene s = foldedCloth(24, 3);
  CandidatePairs reference, pairs;
  PrimitiveBvh bvh;
  s.bruteForce(reference);
  const BroadPhaseStats stats = s.embree(pairs, bvh);
  expectSamePairs(pairs, reference);
  expectPairRules(s, pairs);
  // Layers are within reach of each other: both kinds of cloth pairs are found.
  EXPECT_GT(stats.pairs[std::size_t(PairKind::VertexFace)], 1000u);
  EXPECT_GT(stats.pairs[std::size_t(PairKind::EdgeEdge)], 1000u);
  EXPECT_EQ(stats.pairs[std::size_t(PairKind::VertexEdge)], 0u);
  EXPECT_EQ(stats.pairs[std::size_t(PairKind::VertexVertex)], 0u);
}

TEST(BroadPhase, SamePairsForOneAndTwoThreads) {
  for (const Scene& s : {randomScene(21), foldedCloth(32, 5)}) {
    CandidatePairs one, two;
    PrimitiveBvh bvhOne, bvhTwo;
    tbb::task_arena(1).execute([&] { s.embree(one, bvhOne); });
    tbb::task_arena(2).execute([&] { s.embree(two, bvhTwo); });
    expectSamePairs(one, two);
    // And the same tree queried from the other arena.
    tbb::task_arena(2).execute([&] { s.embree(two, bvhOne); });
    expectSamePairs(one, two);
  }
}

TEST(BroadPhase, RefitsWhileTheCountsStayAndRebuildsWhenTheyChange) {
  Scene s = randomScene(31);
  CandidatePairs pairs, reference;
  PrimitiveBvh bvh;
  EXPECT_TRUE(s.embree(pairs, bvh).rebuilt);
  const std::size_t builds = bvh.builds(), refits = bvh.refits();
  EXPECT_EQ(builds, 4u);  // triangles, edges, isolated points, all points
  EXPECT_EQ(refits, 0u);
  EXPECT_EQ(bvh.builtCount(BvhTree::Triangles), s.primitives.triangles());

  // Second call, same counts: refit only, same pairs.
  CandidatePairs again;
  EXPECT_FALSE(s.embree(again, bvh).rebuilt);
  EXPECT_EQ(bvh.builds(), builds);
  EXPECT_EQ(bvh.refits(), refits + 4);
  expectSamePairs(again, pairs);

  // Positions change a lot (the tree's topology is now poor for them): the refit tree still
  // finds every pair.
  std::mt19937 random(5);
  std::uniform_real_distribution<double> shift(-0.4, 0.4);
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    const Vec3 d(Real(shift(random)), Real(shift(random)), Real(shift(random)));
    s.x[i] += d, s.p[i] += d;
  }
  EXPECT_FALSE(s.embree(pairs, bvh).rebuilt);
  EXPECT_EQ(bvh.builds(), builds);
  s.bruteForce(reference);
  expectSamePairs(pairs, reference);

  // One more triangle: its tree is rebuilt, the others refit.
  addTriangle(s.primitives, {0, 1, 2}, Real(0.02), 0);
  EXPECT_TRUE(s.embree(pairs, bvh).rebuilt);
  EXPECT_EQ(bvh.builds(), builds + 1);
  EXPECT_EQ(bvh.builtCount(BvhTree::Triangles), s.primitives.triangles());
  s.bruteForce(reference);
  expectSamePairs(pairs, reference);
  EXPECT_EQ(bvh.embreeErrors(), 0u);
}

// The incremental re-detection: after some particles leave their bounds, the extended set is the
// brute force's over the new motion boxes, in order and following the pair rules, with each kept
// pair's former index; the same for one and two threads; and it declines, changing nothing, when
// too many particles left their bounds.
TEST(BroadPhase, IncrementalRedetectionCoversTheGrownMotion) {
  for (unsigned seed : {3u, 4u, 5u}) {
    for (Scene s : {randomScene(seed), foldedCloth(24, seed)}) {
      const Real slack = boundSlack(s.primitives, s.margin);
      std::array<CandidatePairs, 2> extended;
      for (int threads : {1, 2}) {
        CandidatePairs& pairs = extended[static_cast<std::size_t>(threads - 1)];
        PrimitiveBvh bvh;
        tbb::task_arena(threads).execute([&] {
          findCandidatePairs(pairs, bvh, s.primitives, s.x, s.p, s.w, s.margin);
          setMotionBounds(pairs, s.x, s.p);
          growParticleBounds(pairs, slack);
        });
        const CandidatePairs before = pairs;
        // A few particles (one in twenty) pushed well off their course.
        std::vector<Vec3> moved = s.p;
        std::mt19937 random(seed);
        std::uniform_real_distribution<double> push(-0.1, 0.1);
        std::size_t off = 0;
        for (std::size_t i = 0; i < moved.size(); i += 20, ++off)
          moved[i] += Vec3(Real(push(random)), Real(0.2), Real(push(random)));
        bool extendedOk = false;
        tbb::task_arena(threads).execute([&] {
          extendedOk = extendCandidatePairs(pairs, bvh, s.primitives, moved, s.x, moved, s.w,
                                            s.margin, slack);
        });
        ASSERT_TRUE(extendedOk);
        expectPairRules(s, pairs);
        // Every particle is now inside its bounds, and the bounds are the motion boxes grown.
        EXPECT_TRUE(withinParticleBounds(pairs, moved));
        // Exactly the pairs of the boxes over the new motion boxes: every pair that may now
        // touch is in (the completeness the fail-safe rests on) and none whose boxes have come
        // apart is left.
        CandidatePairs reference;
        findCandidatePairsBruteForce(reference, s.primitives, pairs.pathStart, pairs.pathEnd, s.w,
                                     s.margin, pairs.pathReach);
        expectSamePairs(pairs, reference);
        // The per-pair data can follow: pairs kept point back to themselves before.
        ASSERT_EQ(pairs.formerIndex.size(), pairs.size());
        for (std::size_t k = 0; k < pairs.size(); ++k) {
          const Index former = pairs.formerIndex[k];
          if (former == CandidatePairs::kNewPair) continue;
          ASSERT_EQ(before.kind[former], pairs.kind[k]);
          ASSERT_EQ(before.first[former], pairs.first[k]);
          ASSERT_EQ(before.second[former], pairs.second[k]);
        }
        EXPECT_GT(pairs.size(), before.size());
        EXPECT_GT(off, 0u);
        EXPECT_EQ(bvh.embreeErrors(), 0u);
      }
      expectSamePairs(extended[0], extended[1]);
    }
  }
  // Every particle off its course: declined, nothing changed.
  Scene s = randomScene(9);
  const Real slack = boundSlack(s.primitives, s.margin);
  CandidatePairs pairs;
  PrimitiveBvh bvh;
  findCandidatePairs(pairs, bvh, s.primitives, s.x, s.p, s.w, s.margin);
  setMotionBounds(pairs, s.x, s.p);
  growParticleBounds(pairs, slack);
  const CandidatePairs before = pairs;
  std::vector<Vec3> moved = s.p;
  for (Vec3& position : moved) position += Vec3(0, 1, 0);
  EXPECT_FALSE(
      extendCandidatePairs(pairs, bvh, s.primitives, moved, s.x, moved, s.w, s.margin, slack));
  expectSamePairs(pairs, before);
  EXPECT_TRUE(pairs.pathStart == before.pathStart && pairs.pathEnd == before.pathEnd);
}

// `from`'s primitives and particles added to `into` as object `object`, moved by `shift`, every
// particle fixed (inverse mass 0) if `fixed`.
void appendObject(Scene& into, const Scene& from, std::uint32_t object, const Vec3& shift,
                  bool fixed) {
  const auto base = static_cast<Index>(into.x.size());
  for (std::size_t i = 0; i < from.x.size(); ++i) {
    into.x.push_back(from.x[i] + shift);
    into.p.push_back(from.p[i] + shift);
    into.w.push_back(fixed ? Real(0) : from.w[i]);
  }
  const CollisionPrimitives& c = from.primitives;
  for (std::size_t t = 0; t < c.triangles(); ++t) {
    const auto& tri = c.triangleParticles[t];
    addTriangle(into.primitives, {tri[0] + base, tri[1] + base, tri[2] + base}, c.triangleRadius[t],
                object);
  }
  for (std::size_t e = 0; e < c.edges(); ++e)
    addEdge(into.primitives, c.edgeParticles[e][0] + base, c.edgeParticles[e][1] + base,
            c.edgeRadius[e], object);
  for (std::size_t i = 0; i < c.points(); ++i)
    addPoint(into.primitives, c.pointParticle[i] + base, c.pointRadius[i], object,
             c.pointIsolated[i] != 0);
  into.margin = from.margin;
}

// Three folded cloths pushed into one another: two without self-collision, the third fixed (a
// static mesh). The traversals pass over the subtrees of one cloth met with themselves and of the
// fixed one met with itself, and the pairs are still exactly the brute force's, in a full search
// and in an incremental re-detection, for one and two threads.
TEST(BroadPhase, SubtreesThatHoldNoPairArePassedOver) {
  const Real edge = Real(1) / Real(19);
  Scene s;
  appendObject(s, foldedCloth(20, 7), 0, Vec3::Zero(), false);
  appendObject(s, foldedCloth(20, 8), 1, Vec3(0.3f * edge, 0.4f * edge, 0.2f * edge), false);
  appendObject(s, foldedCloth(20, 9), 2, Vec3(-0.2f * edge, -0.35f * edge, 0.1f * edge), true);
  s.primitives.excludedPairs = {CollisionPrimitives::pairKey(0, 0),
                                CollisionPrimitives::pairKey(1, 1)};
  std::array<CandidatePairs, 2> found;
  for (int threads : {1, 2}) {
    CandidatePairs& pairs = found[static_cast<std::size_t>(threads - 1)];
    PrimitiveBvh bvh;
    tbb::task_arena(threads).execute([&] { s.embree(pairs, bvh); });
    CandidatePairs reference;
    s.bruteForce(reference);
    expectSamePairs(pairs, reference);
    expectPairRules(s, pairs);
    const std::size_t passedInSearch = bvh.passedOver();
    EXPECT_GT(passedInSearch, 0u);
    // Every pair joins two objects: each of the three meets the others.
    std::set<std::pair<std::uint32_t, std::uint32_t>> objectPairs;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      const std::uint32_t a = objectOf(s.primitives, pairs.kind[k], true, pairs.first[k]),
                          b = objectOf(s.primitives, pairs.kind[k], false, pairs.second[k]);
      ASSERT_NE(a, b);
      objectPairs.insert({std::min(a, b), std::max(a, b)});
    }
    EXPECT_EQ(objectPairs.size(), 3u);

    // Some particles of the free cloths pushed off their course: the re-detection's queries pass
    // over the subtrees their primitives cannot pair with.
    const Real slack = boundSlack(s.primitives, s.margin);
    setMotionBounds(pairs, s.x, s.p);
    growParticleBounds(pairs, slack);
    std::vector<Vec3> moved = s.p;
    for (std::size_t i = 0; i < moved.size(); i += 29)
      if (s.w[i] != 0) moved[i] += Vec3(0.5f * edge, 2 * edge, -0.5f * edge);
    bool extended = false;
    tbb::task_arena(threads).execute([&] {
      extended =
          extendCandidatePairs(pairs, bvh, s.primitives, moved, s.x, moved, s.w, s.margin, slack);
    });
    ASSERT_TRUE(extended);
    EXPECT_GT(bvh.passedOver(), passedInSearch);
    findCandidatePairsBruteForce(reference, s.primitives, pairs.pathStart, pairs.pathEnd, s.w,
                                 s.margin, pairs.pathReach);
    expectSamePairs(pairs, reference);
    expectPairRules(s, pairs);
  }
  expectSamePairs(found[0], found[1]);
}

// Two capsules whose boxes overlap almost entirely but which stay far apart (two parallel
// diagonals) are no pair; moved within reach of each other at the end of the motion, they are.
TEST(BroadPhase, BoxesThatOverlapWhileThePrimitivesStayApartAreNoPair) {
  Scene s;
  s.margin = Real(0.01);
  const Real radius = Real(0.01);
  s.x = {Vec3(0, 0, 0), Vec3(1, 1, 0), Vec3(0.6f, 0, 0), Vec3(1, 0.4f, 0)};
  s.p = s.x;
  s.w = {1, 1, 1, 1};
  addEdge(s.primitives, 0, 1, radius, 0);
  addEdge(s.primitives, 2, 3, radius, 1);
  for (Index i = 0; i < 4; ++i) addPoint(s.primitives, i, radius, i < 2 ? 0 : 1, false);
  CandidatePairs pairs, reference;
  PrimitiveBvh bvh;
  s.embree(pairs, bvh);
  s.bruteForce(reference);
  EXPECT_EQ(pairs.size(), 0u);  // 0.42 apart, reach 0.03
  expectSamePairs(pairs, reference);
  // The second edge slides towards the first: at the end 0.02 apart, within reach.
  const Vec3 toward = Vec3(-0.5f, 0.5f, 0) * (0.6f / 1.41421356f - 0.02f) / 0.70710678f;
  s.p[2] = s.x[2] + toward;
  s.p[3] = s.x[3] + toward;
  s.embree(pairs, bvh);
  s.bruteForce(reference);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs.kind[0], PairKind::EdgeEdge);
  expectSamePairs(pairs, reference);
}

// Every vertex–face and edge–edge pair whose exact distance comes within r_a + r_b + margin at
// some instant of the motion (sampled in double along the straight paths) is a candidate: the
// distance filter drops only pairs that stay out of reach. And it does drop some: pairs whose
// swept boxes overlap outnumber the candidates.
TEST(BroadPhase, PairsThatComeWithinReachAreKept) {
  for (unsigned seed : {2u, 3u}) {
    const Scene s = foldedCloth(14, seed);
    CandidatePairs pairs;
    PrimitiveBvh bvh;
    s.embree(pairs, bvh);
    std::set<std::tuple<PairKind, Index, Index>> set;
    for (std::size_t k = 0; k < pairs.size(); ++k)
      set.insert({pairs.kind[k], pairs.first[k], pairs.second[k]});
    const CollisionPrimitives& c = s.primitives;
    const auto at = [&](Index i, double t) {
      return Vec3d(s.x[i].cast<double>() + t * (s.p[i] - s.x[i]).cast<double>());
    };
    std::size_t withinReach = 0, boxesOverlap = 0;
    for (PairKind kind : {PairKind::VertexFace, PairKind::EdgeEdge}) {
      const bool faces = kind == PairKind::VertexFace;
      const std::size_t firsts = faces ? c.points() : c.edges();
      const std::size_t seconds = faces ? c.triangles() : c.edges();
      for (Index a = 0; a < firsts; ++a)
        for (Index b = faces ? 0 : a + 1; b < seconds; ++b) {
          const auto pa = particlesOf(c, kind, true, a), pb = particlesOf(c, kind, false, b);
          bool shared = false, free = false;
          for (Index i : pa)
            for (Index j : pb) shared |= i == j;
          for (Index i : pa) free |= s.w[i] != 0;
          for (Index j : pb) free |= s.w[j] != 0;
          if (shared || !free) continue;
          const Real radius =
              faces ? c.pointRadius[a] + c.triangleRadius[b] : c.edgeRadius[a] + c.edgeRadius[b];
          const double reach = double(radius) + double(s.margin);
          boxesOverlap += overlaps(sweptBox(pa, s.x, s.p, radius / 2 + s.margin / 2),
                                   sweptBox(pb, s.x, s.p, radius / 2 + s.margin / 2));
          double nearest = 1e30;
          for (int step = 0; step <= 10; ++step) {
            const double t = step / 10.0;
            double d;
            if (faces) {
              const Vec3d q = at(pa[0], t), u = at(pb[0], t), v = at(pb[1], t), w = at(pb[2], t);
              const auto l = closestOnTriangle(q, u, v, w);
              d = (q - (l[0] * u + l[1] * v + l[2] * w)).norm();
            } else {
              const Vec3d p1 = at(pa[0], t), q1 = at(pa[1], t), p2 = at(pb[0], t),
                          q2 = at(pb[1], t);
              const auto st = closestBetweenSegments(p1, q1, p2, q2);
              d = ((p1 + st[0] * (q1 - p1)) - (p2 + st[1] * (q2 - p2))).norm();
            }
            nearest = std::min(nearest, d);
          }
          if (nearest > reach) continue;
          ++withinReach;
          ASSERT_TRUE(set.count({kind, a, b})) << "pair " << int(kind) << " " << a << " " << b
                                               << " comes within " << nearest << " of " << reach;
        }
    }
    EXPECT_GT(withinReach, 1000u);
    EXPECT_LT(double(pairs.size()), 0.8 * double(boxesOverlap));
  }
}

TEST(BroadPhase, NoPairSharesAParticle) {
  // Every cloth vertex is within reach of its own triangles and edges: all of those are dropped.
  const Scene s = foldedCloth(12, 9);
  CandidatePairs pairs;
  PrimitiveBvh bvh;
  s.embree(pairs, bvh);
  expectPairRules(s, pairs);
  Scene flat = s;
  flat.p = flat.x;
  for (std::size_t i = 0; i < flat.x.size(); ++i) flat.x[i].y() = flat.p[i].y() = 0;
  flat.primitives.excludedPairs.clear();
  flat.embree(pairs, bvh);
  expectPairRules(flat, pairs);
}

TEST(BroadPhase, NonFinitePositionsAreSkipped) {
  for (Real bad : {std::numeric_limits<Real>::quiet_NaN(), std::numeric_limits<Real>::infinity(),
                   Real(1e30)}) {
    Scene s = foldedCloth(16, 2);
    const Index particle = 100;
    s.p[particle].x() = bad;
    std::size_t using_ = 1;  // its point
    for (const auto& e : s.primitives.edgeParticles)
      using_ += std::count(e.begin(), e.end(), particle);
    for (const auto& t : s.primitives.triangleParticles)
      using_ += std::count(t.begin(), t.end(), particle);
    CandidatePairs pairs, reference;
    PrimitiveBvh bvh;
    const BroadPhaseStats stats = s.embree(pairs, bvh);
    EXPECT_EQ(stats.skippedPrimitives, using_);
    EXPECT_GT(pairs.size(), 0u);
    for (std::size_t k = 0; k < pairs.size(); ++k)
      for (bool first : {true, false}) {
        const auto particles = particlesOf(s.primitives, pairs.kind[k], first,
                                           first ? pairs.first[k] : pairs.second[k]);
        ASSERT_EQ(std::count(particles.begin(), particles.end(), particle), 0);
      }
    EXPECT_EQ(s.bruteForce(reference).skippedPrimitives, using_);
    expectSamePairs(pairs, reference);
    // The same tree refit with the particle back to normal finds its pairs again.
    s.p[particle] = s.x[particle];
    EXPECT_EQ(s.embree(pairs, bvh).skippedPrimitives, 0u);
    s.bruteForce(reference);
    expectSamePairs(pairs, reference);
    EXPECT_EQ(bvh.embreeErrors(), 0u);
  }
}

TEST(BroadPhase, EmptyAndPartialInput) {
  Scene s;
  CandidatePairs pairs;
  pairs.push_back(PairKind::EdgeEdge, 0, 1);  // stale content is replaced
  PrimitiveBvh bvh;
  const BroadPhaseStats stats = s.embree(pairs, bvh);
  EXPECT_EQ(pairs.size(), 0u);
  EXPECT_EQ(stats.totalPairs(), 0u);
  EXPECT_EQ(bvh.builds(), 0u);

  // Points alone, none isolated: nothing to query. Then isolated: point–point pairs only.
  s.x = {Vec3(0, 0, 0), Vec3(Real(0.01), 0, 0)};
  s.p = s.x;
  s.w = {1, 1};
  addPoint(s.primitives, 0, Real(0.01), 0, false);
  addPoint(s.primitives, 1, Real(0.01), 1, false);
  s.embree(pairs, bvh);
  EXPECT_EQ(pairs.size(), 0u);
  s.primitives.pointIsolated = {1, 1};
  s.embree(pairs, bvh);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs.kind[0], PairKind::VertexVertex);
  // Back to nothing: the trees are dropped.
  s.primitives.clear();
  s.embree(pairs, bvh);
  EXPECT_EQ(pairs.size(), 0u);
  EXPECT_EQ(bvh.builtCount(BvhTree::IsolatedPoints), 0u);
  EXPECT_EQ(bvh.embreeErrors(), 0u);
}

// Pairs found in the frame of the common motion (setMotionFrame) are complete: a folded cloth
// carried 9 edges sideways and down over the substep (with its jitter), every vertex–triangle
// and edge–edge pair that comes within its contact distance at one of 65 instants of the linear
// motion is a candidate (the radii doubled so that the layers are within reach). The pairs are
// those of boxes moving along the paths, which a common translation does not change: in the frame
// the trees' boxes are smaller, and the pairs the same as in the world to within rounding.
TEST(BroadPhase, PairsFoundInTheFrameOfTheCommonMotionAreComplete) {
  for (unsigned seed : {11u, 12u}) {
    Scene s = foldedCloth(16, seed);
    // Radii of half an edge: the layers, 3/4 of an edge apart, are within reach of each other.
    for (auto* radii :
         {&s.primitives.pointRadius, &s.primitives.edgeRadius, &s.primitives.triangleRadius})
      for (Real& r : *radii) r *= 2;
    const Real edge = Real(1) / 15;
    const Vec3 carried = Vec3(6, -5, 4) * edge;
    for (std::size_t i = 0; i < s.p.size(); ++i)
      if (s.w[i] != 0) s.p[i] += carried;
    CandidatePairs world, framed;
    PrimitiveBvh worldBvh, framedBvh;
    s.embree(world, worldBvh);
    setMotionFrame(framed, s.x, s.p, s.w, Vec3::Zero(), Real(0.01), 0, 1);
    // The frame moves as the free particles do, to within the jitter.
    EXPECT_LT((framed.frameAt(1) - (carried + Vec3(0, -edge / 3, 0))).norm(), edge / 10);
    EXPECT_EQ(framed.frameAt(0), Vec3::Zero());
    setMotionBounds(framed, s.x, s.p, Vec3::Zero(), framed.frameAt(1));
    findCandidatePairs(framed, framedBvh, s.primitives, framed.pathStart, framed.pathEnd, s.w,
                       s.margin);
    growParticleBounds(framed, boundSlack(s.primitives, s.margin));
    expectPairRules(s, framed);
    EXPECT_TRUE(withinParticleBounds(framed, s.p));
    EXPECT_NEAR(double(framed.size()), double(world.size()), 0.01 * double(world.size()));

    std::set<std::tuple<PairKind, Index, Index>> found;
    for (std::size_t k = 0; k < framed.size(); ++k)
      found.insert({framed.kind[k], framed.first[k], framed.second[k]});
    const CollisionPrimitives& c = s.primitives;
    const auto at = [&](Index i, double t) {
      return Vec3d((1 - t) * s.x[i].cast<double>() + t * s.p[i].cast<double>());
    };
    const auto shares = [](std::span<const Index> a, std::span<const Index> b) {
      for (Index i : a)
        for (Index j : b)
          if (i == j) return true;
      return false;
    };
    // The gap between the boxes of two sets of particles over the whole motion with the common
    // motion taken away (the distances at each instant are the same): a lower bound on their
    // distance at every instant, which passes over the far pairs without sampling.
    const Vec3d common = carried.cast<double>();
    const auto sweptGap = [&](std::span<const Index> a, std::span<const Index> b) {
      Vec3d lowerA = Vec3d::Constant(1e30), upperA = -lowerA, lowerB = lowerA, upperB = upperA;
      for (Index i : a)
        for (const Vec3d& q : {Vec3d(s.x[i].cast<double>()), Vec3d(s.p[i].cast<double>() - common)})
          lowerA = lowerA.cwiseMin(q), upperA = upperA.cwiseMax(q);
      for (Index i : b)
        for (const Vec3d& q : {Vec3d(s.x[i].cast<double>()), Vec3d(s.p[i].cast<double>() - common)})
          lowerB = lowerB.cwiseMin(q), upperB = upperB.cwiseMax(q);
      return (lowerB - upperA).cwiseMax(lowerA - upperB).cwiseMax(0.0).norm();
    };
    std::size_t touching = 0, missed = 0;
    for (Index v = 0; v < c.points(); ++v)
      for (Index t = 0; t < c.triangles(); ++t) {
        const auto& tri = c.triangleParticles[t];
        const Index point = c.pointParticle[v];
        if (shares({&point, 1}, tri) ||
            (s.w[point] == 0 && s.w[tri[0]] == 0 && s.w[tri[1]] == 0 && s.w[tri[2]] == 0))
          continue;
        const double reach = double(c.pointRadius[v] + c.triangleRadius[t]);
        if (sweptGap({&point, 1}, tri) >= reach) continue;
        for (int k = 0; k <= 64; ++k) {
          const double time = k / 64.0;
          const Vec3d P = at(point, time), A = at(tri[0], time), B = at(tri[1], time),
                      C = at(tri[2], time);
          const auto b = closestOnTriangle(P, A, B, C);
          if ((P - (b[0] * A + b[1] * B + b[2] * C)).norm() < reach) {
            ++touching;
            missed += !found.count({PairKind::VertexFace, v, t});
            break;
          }
        }
      }
    for (Index e = 0; e < c.edges(); ++e)
      for (Index f = e + 1; f < c.edges(); ++f) {
        const auto &a = c.edgeParticles[e], &b = c.edgeParticles[f];
        if (shares(a, b) || (s.w[a[0]] == 0 && s.w[a[1]] == 0 && s.w[b[0]] == 0 && s.w[b[1]] == 0))
          continue;
        const double reach = double(c.edgeRadius[e] + c.edgeRadius[f]);
        if (sweptGap(a, b) >= reach) continue;
        for (int k = 0; k <= 64; ++k) {
          const double time = k / 64.0;
          const Vec3d P = at(a[0], time), Q = at(a[1], time), R = at(b[0], time),
                      S = at(b[1], time);
          const auto u = closestBetweenSegments(P, Q, R, S);
          if (((P + u[0] * (Q - P)) - (R + u[1] * (S - R))).norm() < reach) {
            ++touching;
            missed += !found.count({PairKind::EdgeEdge, e, f});
            break;
          }
        }
      }
    EXPECT_GT(touching, 1000u);  // the layers are within reach of each other
    EXPECT_EQ(missed, 0u);
  }
}

// A position clamped into its bounds in a frame far from the world's origin is inside them when
// tested again, despite the rounding of the offset's subtraction and addition; a position inside
// is returned unchanged.
TEST(BroadPhase, ClampIntoBoundsLandsInsideInAnyFrame) {
  std::mt19937 random(21);
  std::uniform_real_distribution<double> offset(-3000, 3000), spread(-1, 1);
  CandidatePairs pairs;
  const std::size_t n = 4000;
  pairs.pathStart.resize(n);
  pairs.pathEnd.resize(n);
  pairs.pathReach.assign(n, Vec3::Zero());
  pairs.boundSlack = Real(0.01);
  std::vector<Vec3> p(n);
  for (std::size_t i = 0; i < n; ++i) {
    // Paths that move, checked at their middle (frame boundary 1 of 0 … 2).
    const Vec3 centre(Real(spread(random)), Real(spread(random)), Real(spread(random)));
    pairs.pathStart[i] = centre - Vec3(Real(0.05), 0, 0);
    pairs.pathEnd[i] = centre + Vec3(Real(0.05), 0, 0);
  }
  pairs.pathFrom = 0, pairs.pathTo = 2;
  for (int trial = 0; trial < 8; ++trial) {
    const Vec3 held(Real(offset(random)), Real(offset(random)), Real(offset(random)));
    pairs.frameOrigin.assign(3, held);
    pairs.frameSubstep = trial % 2;
    const int boundary = pairs.frameSubstep + 1;
    for (std::size_t i = 0; i < n; ++i)
      p[i] = held + pairs.pathPoint(i, boundary) - Vec3::Constant(pairs.boundSlack) +
             Vec3(Real(spread(random)), Real(spread(random)), Real(spread(random))) / 20;
    const std::size_t outside = countOutsideParticleBounds(pairs, p);
    EXPECT_GT(outside, n / 4);
    for (std::size_t i = 0; i < n; ++i) {
      p[i] = clampIntoBounds(pairs, i, p[i]);
      EXPECT_EQ(clampIntoBounds(pairs, i, p[i]), p[i]);
    }
    EXPECT_EQ(countOutsideParticleBounds(pairs, p), 0u);
  }
}

PrimitiveBox boxAt(float x, float y, float half) {
  return {{x - half, y - half, -half}, {x + half, y + half, half}};
}

// Moving boxes against the instants they are sampled at: whenever two linearly moving boxes
// overlap at one of 1,001 sampled instants, meetInMotion says they meet (it is sound); two boxes
// that move side by side never meet though their swept boxes overlap, and two that pass through
// each other do (it is tighter than the swept boxes).
TEST(BroadPhase, MovingBoxesMeetExactlyWhenTheyOverlapAtSomeInstant) {
  EXPECT_FALSE(meetInMotion(boxAt(0, 0, 0.1f), boxAt(2, 0, 0.1f), boxAt(0.3f, 0, 0.1f),
                            boxAt(2.3f, 0, 0.1f)));
  EXPECT_TRUE(
      meetInMotion(boxAt(0, 0, 0.1f), boxAt(2, 0, 0.1f), boxAt(1, 0, 0.1f), boxAt(1, 0, 0.1f)));
  // Crossing paths at different times: A passes x = 1 at t = 0.5, B is there at t = 0 only.
  EXPECT_FALSE(
      meetInMotion(boxAt(0, 0, 0.1f), boxAt(2, 0, 0.1f), boxAt(1, 0, 0.1f), boxAt(1, 2, 0.1f)));
  std::mt19937 random(5);
  std::uniform_real_distribution<float> place(-1, 1), half(0.01f, 0.3f);
  std::size_t met = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    PrimitiveBox ends[4];
    for (PrimitiveBox& box : ends) box = boxAt(place(random), place(random), half(random));
    const bool meet = meetInMotion(ends[0], ends[1], ends[2], ends[3]);
    bool sampled = false;
    for (int k = 0; k <= 1000 && !sampled; ++k) {
      const float t = float(k) / 1000;
      PrimitiveBox a, b;
      for (int axis = 0; axis < 3; ++axis) {
        a.lower[axis] = (1 - t) * ends[0].lower[axis] + t * ends[1].lower[axis];
        a.upper[axis] = (1 - t) * ends[0].upper[axis] + t * ends[1].upper[axis];
        b.lower[axis] = (1 - t) * ends[2].lower[axis] + t * ends[3].lower[axis];
        b.upper[axis] = (1 - t) * ends[2].upper[axis] + t * ends[3].upper[axis];
      }
      sampled = overlaps(a, b);
    }
    if (sampled) {
      EXPECT_TRUE(meet) << "trial " << trial;
    }
    met += meet;
  }
  EXPECT_GT(met, 200u);
}

// A cloth carried 10 edges in one substep, in the world (no frame), has exactly the pairs it has
// at rest: neighbours that move together are not paired by the distance they travel.
TEST(BroadPhase, ClothCarriedAsAWholeHasThePairsOfTheClothAtRest) {
  Scene s = foldedCloth(16, 3);
  s.p = s.x;
  CandidatePairs rest, carried;
  PrimitiveBvh restBvh, carriedBvh;
  s.embree(rest, restBvh);
  const Vec3 travel = Vec3(10, -4, 3) / 15;
  for (Vec3& position : s.p) position += travel;
  s.embree(carried, carriedBvh);
  expectPairRules(s, carried);
  EXPECT_GT(rest.size(), 1000u);
  // Float rounding of the moved coordinates may add or drop a pair at the very edge of reach.
  EXPECT_NEAR(double(carried.size()), double(rest.size()), 0.005 * double(rest.size()));
}

}  // namespace
}  // namespace nucleon
