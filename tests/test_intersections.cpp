// The exact triangle–triangle intersection checker: its predicates on inputs where rounding
// decides, hand-made pairs with known answers (crossing, touching, coplanar, degenerate), the
// Guigue–Devillers test against an independent edge-based test, the broad phase against a
// brute-force loop, and the figure in World::measure() and the command line's stats.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/task_arena.h>
#include <nlohmann/json.hpp>

#include "engine/app/cli.h"
#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"
#include "systems/diagnostics/triangle_intersections.h"

namespace nucleon {
namespace {

namespace fs = std::filesystem;
using Tri = std::array<Index, 3>;

Triangle3d tri(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  return {a, b, c};
}

// Both exact tests, which must agree, and the answer.
bool intersect(const Triangle3d& a, const Triangle3d& b) {
  const bool gd = trianglesIntersect(a, b);
  EXPECT_EQ(gd, trianglesIntersectByEdges(a, b));
  EXPECT_EQ(gd, trianglesIntersect(b, a));  // symmetric
  return gd;
}

// Positions and triangles as the counter takes them.
struct Soup {
  std::vector<Vec3> x;
  std::vector<Tri> triangles;
  void add(const Vec3& a, const Vec3& b, const Vec3& c) {
    const Index first = static_cast<Index>(x.size());
    x.insert(x.end(), {a, b, c});
    triangles.push_back({first, first + 1, first + 2});
  }
};

Triangle3d corners(const Soup& s, const Tri& t) {
  return {s.x[t[0]].cast<double>(), s.x[t[1]].cast<double>(), s.x[t[2]].cast<double>()};
}

bool shareVertex(const Tri& a, const Tri& b) {
  for (Index i : a)
    if (std::find(b.begin(), b.end(), i) != b.end()) return true;
  return false;
}

// The definition, pair by pair.
std::size_t bruteForceCount(const std::vector<Tri>& triangles, std::span<const Vec3> x) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < triangles.size(); ++i)
    for (std::size_t j = i + 1; j < triangles.size(); ++j) {
      if (shareVertex(triangles[i], triangles[j])) continue;
      const Triangle3d a = {x[triangles[i][0]].cast<double>(), x[triangles[i][1]].cast<double>(),
                            x[triangles[i][2]].cast<double>()};
      const Triangle3d b = {x[triangles[j][0]].cast<double>(), x[triangles[j][1]].cast<double>(),
                            x[triangles[j][2]].cast<double>()};
      count += trianglesIntersect(a, b) ? 1 : 0;
    }
  return count;
}

std::size_t countWithThreads(int threads, const std::vector<Tri>& triangles,
                             const std::vector<Vec3>& x) {
  tbb::task_arena arena(threads);
  return arena.execute([&] { return countTriangleIntersections(triangles, x); });
}

// ---- Predicates where rounding decides.

// det[b − a; c − a; d − a] evaluated naively in double: what a non-exact test computes.
double naiveOrient3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  return (b - a).cross(c - a).dot(d - a);
}

// a = (1/2 + i u, 1/2 + j u), u = 2^−53, b = (12, 12), c = (24, 24): exactly
// det[b − a; c − a] = 12 u (j − i), so the sign is that of j − i, while rounding the naive
// evaluation gets many of these wrong (Kettner et al. 2008, "Classroom examples of robustness
// problems in geometric computations").
TEST(ExactPredicates, Orient2dNearlyCollinearPointsGetTheExactSign) {
  const double u = std::ldexp(1.0, -53);
  int naiveWrong = 0;
  for (int i = 0; i < 64; ++i)
    for (int j = 0; j < 64; ++j) {
      const double ax = 0.5 + i * u, ay = 0.5 + j * u;
      const int exact = (j > i) - (j < i);
      EXPECT_EQ(orient2d(ax, ay, 12, 12, 24, 24), exact) << i << ' ' << j;
      const double naive = (12 - ax) * (24 - ay) - (12 - ay) * (24 - ax);
      naiveWrong += ((naive > 0) - (naive < 0)) != exact;
      // The same determinant lifted to 3D: d − a has a unit z and no other z component.
      EXPECT_EQ(orient3d(Vec3d(ax, ay, 0), Vec3d(12, 12, 0), Vec3d(24, 24, 0), Vec3d(ax, ay, 1)),
                exact)
          << i << ' ' << j;
    }
  EXPECT_GT(naiveWrong, 100);  // the inputs are ones where rounding decides
}

TEST(ExactPredicates, Orient3dOfAPointJustOffATiltedPlane) {
  // The plane x + y + z = 0 through a triangle whose centroid is the origin; (δ, 0, 0) is δ above
  // it. Rounding 1 + δ to 1 makes the naive determinant exactly zero.
  const Vec3d a(-1, -1, 2), b(2, -1, -1), c(-1, 2, -1);
  for (double delta : {1e-30, -1e-30, 1e-300, -1e-300, 0x1p-1074, 0.0}) {
    const int expected = (delta > 0) - (delta < 0);
    EXPECT_EQ(orient3d(a, b, c, Vec3d(delta, 0, 0)), expected) << delta;
    EXPECT_EQ(orient3d(b, a, c, Vec3d(delta, 0, 0)), -expected) << delta;  // swapped: flipped
    EXPECT_EQ(naiveOrient3d(a, b, c, Vec3d(delta, 0, 0)), 0.0) << delta;
  }
}

TEST(ExactPredicates, ExtremeMagnitudesAreExact) {
  // Coordinates near the largest double and near the smallest subnormal in one predicate, where
  // products underflow or overflow in floating point.
  const double big = 0x1p1000, tiny = 0x1p-1070;
  // Plane z = 0 spanned by huge vectors; the point tiny above, below, on it.
  EXPECT_EQ(orient3d(Vec3d(0, 0, 0), Vec3d(big, 0, 0), Vec3d(0, big, 0), Vec3d(1, 1, tiny)), 1);
  EXPECT_EQ(orient3d(Vec3d(0, 0, 0), Vec3d(big, 0, 0), Vec3d(0, big, 0), Vec3d(1, 1, -tiny)), -1);
  EXPECT_EQ(orient3d(Vec3d(0, 0, 0), Vec3d(big, 0, 0), Vec3d(0, big, 0), Vec3d(1, 1, 0)), 0);
  // det = (big)(big)·tiny − (tiny)(big)·big... : collinear in exact arithmetic only.
  EXPECT_EQ(orient2d(0, 0, big, tiny, 2 * big, 2 * tiny), 0);
  EXPECT_EQ(orient2d(0, 0, big, tiny, 2 * big, 3 * tiny), 1);
  EXPECT_EQ(orient2d(0, 0, big, tiny, 2 * big, tiny), -1);
  // Tiny differences on top of a large offset cancel exactly.
  EXPECT_EQ(orient2d(1e300, 1e300, 1e300 + 0x1p945, 1e300, 1e300, 1e300 + 0x1p945), 1);
}

// ---- Hand-made pairs.

const Triangle3d kUnit = tri(Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0, 1, 0));  // in z = 0

TEST(TrianglePairs, CrossingAndSeparated) {
  // Pierces the unit triangle's interior from below to above.
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0.2, 0.2, -1), Vec3d(0.3, 0.2, 1), Vec3d(0.2, 0.3, 1))));
  // The same, moved beyond the hypotenuse x + y = 1.
  EXPECT_FALSE(intersect(kUnit, tri(Vec3d(0.8, 0.8, -1), Vec3d(0.9, 0.8, 1), Vec3d(0.8, 0.9, 1))));
  // Entirely above.
  EXPECT_FALSE(intersect(kUnit, tri(Vec3d(0, 0, 1), Vec3d(1, 0, 1), Vec3d(0, 1, 2))));
  // Straddles the plane but the crossing segment misses the triangle.
  EXPECT_FALSE(intersect(kUnit, tri(Vec3d(-1, -1, -1), Vec3d(-0.5, -1, 1), Vec3d(-1, -0.5, 1))));
  // Two triangles that interlock like chain links: each crosses the other's plane inside it.
  EXPECT_TRUE(intersect(tri(Vec3d(1, 0, 0), Vec3d(-1, -1, 0), Vec3d(-1, 1, 0)),
                        tri(Vec3d(0, 0, 1), Vec3d(0, -1, -1), Vec3d(0, 1, -1))));
  EXPECT_FALSE(intersect(tri(Vec3d(1, 0, 0), Vec3d(-1, -1, 0), Vec3d(-1, 1, 0)),
                         tri(Vec3d(0, 2, 1), Vec3d(0, 1, -1), Vec3d(0, 3, -1))));
}

TEST(TrianglePairs, TouchingCounts) {
  // A vertex on the face, the rest above.
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0.25, 0.25, 0), Vec3d(1, 1, 1), Vec3d(0, 1, 1))));
  // A vertex on an edge, on a vertex.
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0.5, 0, 0), Vec3d(1, 1, 1), Vec3d(0, 1, 1))));
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(1, 0, 0), Vec3d(2, 1, 1), Vec3d(2, 0, 1))));
  // An edge lying in the face, the third vertex above.
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0.1, 0.1, 0), Vec3d(0.3, 0.2, 0), Vec3d(0.2, 0.2, 1))));
  // Edge against edge: a vertical triangle whose bottom edge crosses the hypotenuse.
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0, 0.2, 0), Vec3d(1, 1.2, 0), Vec3d(0.5, 0.7, 1))));
  // The same edge shifted just past the hypotenuse's end point: no contact.
  EXPECT_FALSE(intersect(kUnit, tri(Vec3d(1.25, 0, 0), Vec3d(2, 0.75, 0), Vec3d(1.5, 0.25, 1))));
  // A vertex just off the face by the smallest amounts: below crosses, above misses.
  for (double d : {1e-30, 0x1p-1074}) {
    EXPECT_FALSE(intersect(kUnit, tri(Vec3d(0.25, 0.25, d), Vec3d(1, 1, 1), Vec3d(0, 1, 1))));
    EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0.25, 0.25, -d), Vec3d(1, 1, 1), Vec3d(0, 1, 1))));
  }
}

TEST(TrianglePairs, VertexJustOffATiltedPlaneWhereRoundingWouldSayTouching) {
  // The tilted triangle has its centroid at the origin; the other triangle's lowest vertex is δ
  // above the plane there, δ below, or on it. Naively rounded, all three touch.
  const Triangle3d tilted = tri(Vec3d(-1, -1, 2), Vec3d(2, -1, -1), Vec3d(-1, 2, -1));
  auto apex = [](double delta) {
    return tri(Vec3d(delta, 0, 0), Vec3d(1, 1, 1), Vec3d(1, 2, 0.5));
  };
  EXPECT_FALSE(intersect(tilted, apex(1e-30)));
  EXPECT_TRUE(intersect(tilted, apex(-1e-30)));
  EXPECT_TRUE(intersect(tilted, apex(0)));
  // Through the counter, in the solver's precision (1e-30 is a normal float).
  for (double delta : {1e-30, -1e-30, 0.0}) {
    Soup s;
    const Triangle3d b = apex(delta);
    s.add(tilted[0].cast<Real>(), tilted[1].cast<Real>(), tilted[2].cast<Real>());
    s.add(b[0].cast<Real>(), b[1].cast<Real>(), b[2].cast<Real>());
    EXPECT_EQ(countTriangleIntersections(s.triangles, s.x), delta > 0 ? 0u : 1u) << delta;
  }
}

TEST(TrianglePairs, Coplanar) {
  // Overlapping, one inside the other, disjoint, touching at a vertex, sharing part of an edge.
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0.5, 0.5, 0), Vec3d(-0.5, 0.5, 0), Vec3d(0.5, -0.5, 0))));
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0.1, 0.1, 0), Vec3d(0.2, 0.1, 0), Vec3d(0.1, 0.2, 0))));
  EXPECT_FALSE(intersect(kUnit, tri(Vec3d(0.6, 0.6, 0), Vec3d(1, 0.6, 0), Vec3d(0.6, 1, 0))));
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(1, 0, 0), Vec3d(2, 0, 0), Vec3d(2, 1, 0))));
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0.5, 0, 0), Vec3d(1.5, 0, 0), Vec3d(1, -1, 0))));
  // A star of David: edges cross, no vertex of either inside the other.
  EXPECT_TRUE(intersect(tri(Vec3d(0, 0, 0), Vec3d(4, 0, 0), Vec3d(2, 3, 0)),
                        tri(Vec3d(0, 2, 0), Vec3d(4, 2, 0), Vec3d(2, -1, 0))));
  // Coplanar in a tilted plane x + y + z = 1 (exact in binary), disjoint and touching.
  const Triangle3d t = tri(Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(0, 0, 1));
  EXPECT_FALSE(intersect(t, tri(Vec3d(1, 1, -1), Vec3d(2, 0, -1), Vec3d(2, 1, -2))));
  EXPECT_TRUE(intersect(t, tri(Vec3d(0.5, 0.5, 0), Vec3d(2, 0, -1), Vec3d(2, 1, -2))));
}

TEST(TrianglePairs, DegenerateTrianglesAreTheirPointSets) {
  const Triangle3d segment = tri(Vec3d(0.2, 0.2, -1), Vec3d(0.2, 0.2, 1), Vec3d(0.2, 0.2, 0.5));
  EXPECT_TRUE(isDegenerate(segment));
  EXPECT_FALSE(isDegenerate(kUnit));
  EXPECT_TRUE(intersect(kUnit, segment));  // a collinear "triangle" piercing the face
  EXPECT_FALSE(intersect(kUnit, tri(Vec3d(0.2, 0.2, 0.1), Vec3d(0.2, 0.2, 1), Vec3d(0.2, 0.2, 2))));
  // The segment's extent is set by its extreme vertices, whatever their order.
  EXPECT_TRUE(intersect(kUnit, tri(Vec3d(0.2, 0.2, 2), Vec3d(0.2, 0.2, 1), Vec3d(0.2, 0.2, -3))));
  // All three vertices at one point: in the face, on an edge, off it.
  const Vec3d in(0.25, 0.25, 0), onEdge(0.5, 0.5, 0), off(0.25, 0.25, 1e-30);
  EXPECT_TRUE(intersect(kUnit, tri(in, in, in)));
  EXPECT_TRUE(intersect(kUnit, tri(onEdge, onEdge, onEdge)));
  EXPECT_FALSE(intersect(kUnit, tri(off, off, off)));
  // Degenerate against degenerate: crossing segments, parallel ones, equal points.
  const Triangle3d alongX = tri(Vec3d(-1, 0, 0), Vec3d(1, 0, 0), Vec3d(0, 0, 0));
  EXPECT_TRUE(intersect(alongX, tri(Vec3d(0, -1, 0), Vec3d(0, 1, 0), Vec3d(0, 1, 0))));
  EXPECT_FALSE(intersect(alongX, tri(Vec3d(0, -1, 1e-30), Vec3d(0, 1, 1e-30), Vec3d(0, 0, 1e-30))));
  EXPECT_FALSE(intersect(alongX, tri(Vec3d(-1, 1, 0), Vec3d(1, 1, 0), Vec3d(0, 1, 0))));
  EXPECT_TRUE(intersect(alongX, tri(Vec3d(1, 0, 0), Vec3d(2, 0, 0), Vec3d(3, 0, 0))));
  EXPECT_FALSE(intersect(alongX, tri(Vec3d(1.5, 0, 0), Vec3d(2, 0, 0), Vec3d(3, 0, 0))));
  EXPECT_TRUE(intersect(tri(in, in, in), tri(in, in, in)));
  EXPECT_FALSE(intersect(tri(in, in, in), tri(off, off, off)));
}

TEST(TrianglePairs, PairsSharingAVertexAreNotCounted) {
  Soup s;
  s.x = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0),  // the unit triangle
         Vec3(Real(0.2), Real(0.2), 1), Vec3(Real(0.3), Real(0.2), -1)};
  s.triangles = {{0, 1, 2}, {0, 3, 4}};  // shares vertex 0, and also pierces the face
  EXPECT_TRUE(trianglesIntersect(corners(s, s.triangles[0]), corners(s, s.triangles[1])));
  EXPECT_EQ(countTriangleIntersections(s.triangles, s.x), 0u);
  // The same second triangle with its own copy of that vertex counts.
  s.x.push_back(Vec3(0, 0, 0));
  s.triangles[1] = {5, 3, 4};
  EXPECT_EQ(countTriangleIntersections(s.triangles, s.x), 1u);
  // Non-finite vertices leave their triangle out.
  s.x[3] = Vec3(std::numeric_limits<Real>::quiet_NaN(), 0, 0);
  EXPECT_EQ(countTriangleIntersections(s.triangles, s.x), 0u);
  s.triangles[1] = {5, 3, 9};
  EXPECT_THROW(countTriangleIntersections(s.triangles, s.x), std::out_of_range);
}

// ---- The Guigue–Devillers path against the edge-based one, on lattice points: small integer
// coordinates make coplanar pairs, shared edges, vertices on faces and degenerate triangles
// common, which is where the case analysis can go wrong.
TEST(TrianglePairs, GuigueDevillersAgreesWithTheEdgeTestOnLatticeTriangles) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> coordinate(0, 3);
  auto point = [&] { return Vec3d(coordinate(rng), coordinate(rng), coordinate(rng)); };
  int intersecting = 0, coplanar = 0, degenerate = 0;
  const int pairs = 200000;
  for (int k = 0; k < pairs; ++k) {
    const Triangle3d a = tri(point(), point(), point()), b = tri(point(), point(), point());
    const bool gd = trianglesIntersect(a, b);
    ASSERT_EQ(gd, trianglesIntersectByEdges(a, b))
        << "a: " << a[0].transpose() << " | " << a[1].transpose() << " | " << a[2].transpose()
        << "\nb: " << b[0].transpose() << " | " << b[1].transpose() << " | " << b[2].transpose();
    intersecting += gd;
    degenerate += isDegenerate(a) || isDegenerate(b);
    coplanar += !isDegenerate(a) && orient3d(a[0], a[1], a[2], b[0]) == 0 &&
                orient3d(a[0], a[1], a[2], b[1]) == 0 && orient3d(a[0], a[1], a[2], b[2]) == 0;
  }
  // Each kind of case is well represented (not a test that passes by never reaching them).
  EXPECT_GT(intersecting, pairs / 10);
  EXPECT_LT(intersecting, pairs * 9 / 10);
  EXPECT_GT(coplanar, 500);
  EXPECT_GT(degenerate, 1000);
}

// ---- The broad phase loses no pair: random soups against the O(n²) definition.

// Triangles of sizes spread over two orders of magnitude (several grid levels) on a lattice of
// 1/16 (exact in float), so boxes touch exactly on cell boundaries, with some triangles sharing
// vertices and some degenerate.
Soup randomSoup(unsigned seed, int count) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> cell(0, 64), sizeClass(0, 3), offset(-1, 1);
  Soup s;
  for (int k = 0; k < count; ++k) {
    const int size = 1 << (2 * sizeClass(rng));  // 1, 4, 16, 64 lattice steps
    const Vec3 a(Real(cell(rng)), Real(cell(rng)), Real(cell(rng)));
    std::uniform_int_distribution<int> step(-size, size);
    auto near = [&] {
      return Vec3(a.x() + Real(step(rng)), a.y() + Real(step(rng)), a.z() + Real(step(rng)));
    };
    s.add(a / 16, near() / 16, near() / 16);
    if (k % 5 == 0 && k > 0) {  // a neighbour sharing an edge with the previous triangle
      const Index last = static_cast<Index>(s.x.size()) - 1;
      s.x.push_back(near() / 16);
      s.triangles.push_back({last, last - 1, static_cast<Index>(s.x.size() - 1)});
    }
    (void)offset;
  }
  return s;
}

TEST(CountTriangleIntersections, BroadPhaseLosesNoPair) {
  for (unsigned seed : {1u, 2u, 3u, 4u}) {
    const Soup s = randomSoup(seed, 1500);
    const std::size_t expected = bruteForceCount(s.triangles, s.x);
    EXPECT_GT(expected, 100u) << seed;
    EXPECT_EQ(countWithThreads(1, s.triangles, s.x), expected) << seed;
    EXPECT_EQ(countWithThreads(2, s.triangles, s.x), expected) << seed;
  }
}

// Two clusters of the random soup a million metres apart (small triangles, so cell keys need
// more bits than they keep and wrap around), one of them below the origin: the count is still
// the brute force's.
TEST(CountTriangleIntersections, FarApartClustersLoseNoPair) {
  Soup s = randomSoup(5, 600);
  const Soup far = randomSoup(6, 600);
  const Index base = static_cast<Index>(s.x.size());
  for (const Vec3& x : far.x) s.x.push_back(x + Vec3(-1e6f, 2.5e5f, -7e5f));
  for (const Tri& t : far.triangles) s.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  const std::size_t expected = bruteForceCount(s.triangles, s.x);
  EXPECT_GT(expected, 50u);
  EXPECT_EQ(countWithThreads(1, s.triangles, s.x), expected);
  EXPECT_EQ(countWithThreads(2, s.triangles, s.x), expected);
}

TEST(CountTriangleIntersections, LargeAndTinyTrianglesTogether) {
  // One large triangle under a field of small ones, some touching it, some crossing, some
  // clear: the large one lives many levels above the others.
  Soup s;
  s.add(Vec3(-100, 0, -100), Vec3(100, 0, -100), Vec3(0, 0, 100));
  int expected = 0;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      const Real x = Real(i) / 4 - 5, z = Real(j) / 4 - 5;
      const int kind = (i + 3 * j) % 3;  // 0 clear above, 1 touching, 2 crossing
      const Real low = kind == 0 ? Real(0.125) : (kind == 1 ? Real(0) : Real(-0.0625));
      s.add(Vec3(x, low, z), Vec3(x + Real(0.125), Real(0.25), z),
            Vec3(x, Real(0.25), z + Real(0.125)));
      expected += kind != 0;
    }
  EXPECT_EQ(countTriangleIntersections(s.triangles, s.x), static_cast<std::size_t>(expected));
  EXPECT_EQ(bruteForceCount(s.triangles, s.x), static_cast<std::size_t>(expected));
}

TEST(CountTriangleIntersections, ManyTrianglesPiledInOnePlace) {
  // 300 copies of the same triangle (distinct vertices): every pair intersects.
  Soup s;
  for (int k = 0; k < 300; ++k) s.add(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0));
  EXPECT_EQ(countTriangleIntersections(s.triangles, s.x), 300u * 299 / 2);
}

// ---- Cloth.

std::vector<Tri> clothTriangles(const ObjectDef& def) {
  return {def.triangles.begin(), def.triangles.end()};
}

TEST(CountTriangleIntersections, FlatClothHasNone) {
  for (bool vertical : {false, true}) {
    GridSpec spec;
    spec.resolution = {48, 40};
    spec.vertical = vertical;
    const ObjectDef cloth = gridCloth(spec);
    EXPECT_EQ(countTriangleIntersections(clothTriangles(cloth), cloth.vertices), 0u);
  }
}

// The cloth's half x > 0 swung by `angle` about the z axis through (0, axisHeight): with the
// axis in the cloth (y = 1) a crease; with it below the cloth, the swung half comes back up
// through the other half.
std::vector<Vec3> folded(const ObjectDef& cloth, double angle, double axisHeight) {
  std::vector<Vec3> x = cloth.vertices;
  const double c = std::cos(angle), s = std::sin(angle);
  for (Vec3& p : x)
    if (p.x() > 0) {
      const double px = p.x(), py = p.y() - axisHeight;
      p.x() = Real(c * px - s * py);
      p.y() = Real(axisHeight + s * px + c * py);
    }
  return x;
}

TEST(CountTriangleIntersections, ClothFoldedThroughItselfIntersects) {
  GridSpec spec;  // 2 m square at y = 1
  spec.resolution = {21, 20};
  const ObjectDef cloth = gridCloth(spec);
  const std::vector<Tri> triangles = clothTriangles(cloth);
  const double degree = std::acos(-1.0) / 180;
  EXPECT_EQ(countTriangleIntersections(triangles, folded(cloth, 90 * degree, 1)), 0u);
  // Swung by 150° about an axis 0.2 m below: the half's points x in (0.75, 1] come back above
  // y = 1, so it crosses the other half along a line near x = −0.75.
  const std::vector<Vec3> through = folded(cloth, 150 * degree, 0.8);
  const std::size_t count = countTriangleIntersections(triangles, through);
  EXPECT_GT(count, 20u);  // at least one crossing per row of cells
  EXPECT_EQ(count, bruteForceCount(triangles, through));
  EXPECT_EQ(countWithThreads(1, triangles, through), count);
}

// ---- The world's measure and the stats.

TEST(Measures, IntersectionsOverAllObjectsInGlobalIndices) {
  World world;
  GridSpec spec;
  spec.resolution = {9, 9};
  world.addCloth(gridCloth(spec));  // horizontal at y = 1
  EXPECT_EQ(world.measure().intersections, 0u);
  spec.vertical = true;  // a second cloth standing across the first
  spec.center = Vec3(Real(0.1), 1, Real(0.05));
  world.addCloth(gridCloth(spec));
  const std::size_t count = world.measure().intersections;
  EXPECT_GT(count, 0u);
  // The same from the surfaces, offset by hand.
  std::vector<Tri> all;
  Index first = 0;
  for (std::size_t i = 0; i < world.objectCount(); ++i) {
    for (const auto& t : world.surfaceTriangles(world.objectAt(i)))
      all.push_back({first + t[0], first + t[1], first + t[2]});
    first += static_cast<Index>(world.positions(world.objectAt(i)).size());
  }
  EXPECT_EQ(count, bruteForceCount(all, world.positions()));
}

TEST(Measures, RunStatsReportIntersectionsEveryFrame) {
  const fs::path folder = fs::temp_directory_path() / "nucleon_intersections_stats";
  fs::remove_all(folder);
  fs::create_directories(folder);
  // Two small cloths, every vertex pinned, one standing through the other: the count is the
  // same every frame and equals the measure of the world the scene builds.
  std::ostringstream pinList;
  for (int i = 0; i < 25; ++i) pinList << (i ? "," : "[") << i;
  pinList << ']';
  const std::string pins = pinList.str();
  const std::string scenePath = (folder / "crossing.json").string();
  std::ofstream(scenePath) << R"({ "name": "crossing", "frames": 3, "fps": 60, "objects": [
      { "type": "cloth", "pins": )"
                           << pins << R"(,
        "shape": { "grid": { "resolution": [5, 5], "size": [1, 1], "center": [0, 1, 0] } } },
      { "type": "cloth", "pins": )"
                           << pins << R"(,
        "shape": { "grid": { "resolution": [5, 5], "size": [1, 1], "center": [0.05, 1, 0.1],
                             "vertical": true } } } ] })";
  const std::string statsPath = (folder / "stats.json").string();
  std::ostringstream out, err;
  ASSERT_EQ(runCommandLine({"run", scenePath, "--quiet", "--stats", statsPath}, out, err), 0)
      << err.str();
  std::ifstream in(statsPath);
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_TRUE(j.at("intersections").is_number_integer());
  const auto total = j.at("intersections").get<std::size_t>();
  EXPECT_GT(total, 0u);
  World world = buildWorld(loadScene(scenePath));
  EXPECT_EQ(total, world.measure().intersections);
  ASSERT_EQ(j.at("per_frame").size(), 3u);
  for (const auto& frame : j.at("per_frame")) {
    ASSERT_TRUE(frame.at("intersections").is_number_integer());
    EXPECT_EQ(frame.at("intersections").get<std::size_t>(), total);
  }
  fs::remove_all(folder);
}

}  // namespace
}  // namespace nucleon
