// Long-range attachments (Kim, Chentanez and Müller 2012): which pins a free vertex is tethered
// to, that every limit is the geodesic distance in the rest shape (never shorter than the straight
// one), and that
// a cloth hung from two corners does not split along the line where its nearest pin changes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <queue>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "components/constraint_pools.h"
#include "components/simplicial_complex.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"
#include "sim_test_context.h"
#include "systems/setup/build_constraint_graph.h"
#include "systems/setup/build_constraints.h"
#include "systems/solver/tether_projection.h"
#include "systems/solver/tether_sweep.h"

using namespace nucleon;

namespace {

// A grid cloth of n×n vertices, 2 m square, horizontal at 1 m, with the given pins.
ObjectDef gridWithPins(int n, std::vector<Index> pins) {
  GridSpec spec;
  spec.resolution = {n, n};
  ObjectDef cloth = gridCloth(spec);
  cloth.pins = std::move(pins);
  return cloth;
}

SimplicialComplex complexOf(const ObjectDef& cloth) {
  return buildFromTriangles(cloth.vertices.size(), cloth.triangles);
}

// The tethers World::addCloth gives the cloth (its particles starting at 0).
TetherConstraints tethersOf(const ObjectDef& cloth) {
  ConstraintPools pools;
  appendObjectConstraints(pools, ObjectKind::Cloth, complexOf(cloth), cloth.vertices, cloth.pins, 0,
                          cloth.material);
  return pools.tether;
}

// Shortest path lengths along the edges from one vertex (plain Dijkstra), as the reference.
std::vector<double> pathLengthsFrom(const ObjectDef& cloth, Index source) {
  const SimplicialComplex c = complexOf(cloth);
  std::vector<std::vector<std::pair<Index, double>>> adjacent(cloth.vertices.size());
  for (const auto& [a, b] : c.edges.vertices) {
    const double l = (cloth.vertices[a] - cloth.vertices[b]).cast<double>().norm();
    adjacent[a].push_back({b, l});
    adjacent[b].push_back({a, l});
  }
  std::vector<double> d(cloth.vertices.size(), std::numeric_limits<double>::infinity());
  using Entry = std::pair<double, Index>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  d[source] = 0;
  queue.push({0, source});
  while (!queue.empty()) {
    const auto [dv, v] = queue.top();
    queue.pop();
    if (dv > d[v]) continue;
    for (const auto& [u, l] : adjacent[v])
      if (dv + l < d[u]) {
        d[u] = dv + l;
        queue.push({d[u], u});
      }
  }
  return d;
}

// Tethers per free vertex: pin → limit.
std::map<Index, std::map<Index, double>> byVertex(const TetherConstraints& tethers) {
  std::map<Index, std::map<Index, double>> out;
  for (std::size_t k = 0; k < tethers.size(); ++k) {
    const auto [free, pin] = tethers.particles[k];
    EXPECT_TRUE(out[free].emplace(pin, tethers.rest[k]).second) << "two tethers " << free << pin;
  }
  return out;
}

}  // namespace

// A cloth held at its four corners has four pin clusters that all meet in its middle: every
// free vertex is tethered to each corner. The limit is the geodesic distance, which on this flat
// square is the straight one (to float rounding of the stored limit, 1e-6 relative), while the
// path along the edges is up to 41% longer toward the corners whose diagonal the grid's
// alternating triangles miss: the test can tell the two apart.
TEST(Tethers, EveryFreeVertexIsTetheredToEachOfFourCornersAtTheStraightDistance) {
  const int n = 16;
  const ObjectDef cloth = gridWithPins(n, {0, n - 1, n * (n - 1), n * n - 1});
  const auto tethers = byVertex(tethersOf(cloth));
  ASSERT_EQ(tethers.size(), std::size_t(n * n - 4));
  double longestPath = 0;
  for (Index corner : cloth.pins) {
    const std::vector<double> path = pathLengthsFrom(cloth, corner);
    for (const auto& [free, limits] : tethers) {
      ASSERT_EQ(limits.count(corner), 1u) << free;
      const double straight = (cloth.vertices[free] - cloth.vertices[corner]).cast<double>().norm();
      EXPECT_NEAR(limits.at(corner), straight, 1e-6 * straight) << free << " to " << corner;
      longestPath = std::max(longestPath, path[free] / straight);
    }
  }
  EXPECT_GT(longestPath, 1.4);
}

// On a curved rest shape the straight line cuts through the material: a tube's limits follow
// its surface. A 64×33 open cylinder of radius 0.25 m held at one vertex of its bottom ring:
// the geodesic to a point Δθ around and Δz up is √((RΔθ)² + Δz²) on the smooth cylinder; the
// polygonal one (64 flat facets) is shorter by at most the chord's 1 − sin(π/64)/(π/64) =
// 0.04%. The limits land within 1% of it and never below the straight distance.
TEST(Tethers, LimitsFollowACurvedRestShape) {
  TubeSpec spec;
  spec.resolution = {64, 33};
  ObjectDef cloth = tube(spec);
  cloth.pins = {0};
  const TetherConstraints tethers = tethersOf(cloth);
  ASSERT_EQ(tethers.size(), cloth.vertices.size() - 1);
  const Vec3 pin = cloth.vertices[0];
  double worst = 0, cutThrough = 0;
  for (std::size_t k = 0; k < tethers.size(); ++k) {
    const Vec3 x = cloth.vertices[tethers.particles[k][0]];
    const double straight = (x - pin).cast<double>().norm();
    const Vec3 rel = x - pin;
    // The tube's axis and angle from the layout: y along the axis, the ring in x–z about it.
    const double angleFree = std::atan2(double(x.z()), double(x.x()));
    const double anglePin = std::atan2(double(pin.z()), double(pin.x()));
    double dTheta = std::abs(angleFree - anglePin);
    dTheta = std::min(dTheta, 2 * M_PI - dTheta);
    const double geodesic = std::hypot(0.25 * dTheta, double(rel.y()));
    EXPECT_GE(double(tethers.rest[k]), straight * (1 - 1e-6));
    worst = std::max(worst, std::abs(tethers.rest[k] / geodesic - 1));
    cutThrough = std::max(cutThrough, geodesic / straight);
  }
  EXPECT_LT(worst, 0.01);
  EXPECT_GT(cutThrough, 1.5);  // across the tube the surface is π/2 times the straight line
}

// The count per vertex is bounded by the clusters of pins, not by the pins: a whole pinned row
// is one cluster and gives one tether per free vertex (to the nearest pin of the row); a row of
// separate pins, every third vertex (eleven clusters), gives at most four per vertex, each to a
// different pin.
TEST(Tethers, CountIsBoundedForManyPins) {
  const int n = 32;
  std::vector<Index> row, sparse;
  for (int i = 0; i < n; ++i) row.push_back(i);
  for (int i = 0; i < n; i += 3) sparse.push_back(i);
  const auto rowTethers = tethersOf(gridWithPins(n, row));
  EXPECT_EQ(rowTethers.size(), std::size_t(n * (n - 1)));
  for (std::size_t k = 0; k < rowTethers.size(); ++k) {
    const auto [free, pin] = rowTethers.particles[k];
    EXPECT_EQ(pin, free % n) << free;  // the pin straight above: the nearest one
  }
  const auto sparseTethers = byVertex(tethersOf(gridWithPins(n, sparse)));
  EXPECT_EQ(sparseTethers.size(), std::size_t(n * n) - sparse.size());
  for (const auto& [free, limits] : sparseTethers) {
    EXPECT_GE(limits.size(), 1u);
    EXPECT_LE(limits.size(), 4u) << free;
  }
}

// The cascade's shortcut: where surelyInsideTether holds, the projections return x bit for bit,
// so skipping them changes nothing. Points at random distances near the limit (within ±1e-5
// relative, where rounding decides), 20,000 of them, about half inside.
TEST(Tethers, SurelyInsideMeansEveryProjectionLeavesThePoint) {
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(-1, 1), positive(0.2, 1.5), near(-1e-5, 1e-5);
  auto point = [&] { return Vec3(Real(unit(random)), Real(unit(random)), Real(unit(random))); };
  int inside = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const Vec3 a = point(), b = point();
    const Real ra = Real(positive(random));
    const Real scale = Real(trial % 2 == 0 ? 1 + near(random) : std::abs(unit(random)));
    const Vec3 x = a + ra * scale * point().normalized();
    const Real rb = Real((x - b).norm() * (1 + 4e-5 + 0.1 * std::abs(unit(random))));
    if (!surelyInsideTether(x, a, ra)) continue;
    ++inside;
    ASSERT_TRUE(projectOntoTether(x, a, ra) == x) << trial;
    ASSERT_TRUE(surelyInsideTether(x, b, rb)) << trial;
    ASSERT_TRUE(projectOntoTetherPair(x, a, ra, b, rb) == x) << trial;
  }
  EXPECT_GT(inside, 5000);
}

// Two tethers at once: the result is the closest point of the intersection of the two balls. For
// 2,000 random cases it lies in both balls (to float rounding, 1e-5 m on these metre-sized
// cases) and no point of the intersection, sampled 400 times per case, is closer. Balls that
// touch in one point, as on the taut top edge of a cloth hung from two corners its width apart,
// send the vertex to that point in one projection, where alternating projections only creep.
TEST(Tethers, PairProjectionIsTheClosestPointOfBothLimits) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(-1, 1), positive(0.2, 1.5);
  auto point = [&] { return Vec3(Real(unit(random)), Real(unit(random)), Real(unit(random))); };
  int circleCases = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Vec3 a = point(), b = point(), x = 2 * point();
    const Real ra = Real(positive(random)), rb = Real(positive(random));
    if ((a - b).norm() > ra + rb) continue;  // disjoint limits: no feasible point
    const Vec3 q = projectOntoTetherPair(x, a, ra, b, rb);
    ASSERT_LE((q - a).norm(), ra + 1e-5) << trial;
    ASSERT_LE((q - b).norm(), rb + 1e-5) << trial;
    const bool onCircle = (q - a).norm() > ra - 1e-5 && (q - b).norm() > rb - 1e-5;
    circleCases += onCircle && (x - a).norm() > ra && (x - b).norm() > rb;
    const double best = (q - x).norm();
    for (int k = 0; k < 400; ++k) {
      const Vec3 y = a + ra * Real(std::cbrt(0.5 * (unit(random) + 1))) * point().normalized();
      if ((y - b).norm() > rb) continue;
      ASSERT_GE((y - x).norm(), best - 1e-5) << trial;
    }
  }
  EXPECT_GT(circleCases, 50);  // the circle branch was exercised, not only single projections
  // Touching limits: pins 2 m apart, limits 0.7 and 1.3 m; the only feasible point is 0.7 m
  // along the axis, reached from below in one call. Sequential projection leaves it far off.
  const Vec3 a(0, 0, 0), b(2, 0, 0), x(0.7, -0.3, 0);
  const Vec3 q = projectOntoTetherPair(x, a, Real(0.7), b, Real(1.3));
  EXPECT_LT((q - Vec3(0.7, 0, 0)).norm(), 1e-4);
  const Vec3 sequential = projectOntoTether(projectOntoTether(x, a, 0.7), b, 1.3);
  EXPECT_GT((sequential - Vec3(0.7, 0, 0)).norm(), 1e-2);
}

// A limit is never shorter than the straight line between its ends: in the rest shape no tether
// is stretched, so a cloth without gravity does not move.
TEST(Tethers, LimitsAreNeverShorterThanTheRestShape) {
  const int n = 24;
  std::vector<Index> row;
  for (int i = 0; i < n; ++i) row.push_back(i);
  for (const std::vector<Index>& pins :
       {std::vector<Index>{0, n - 1}, std::vector<Index>{0, n - 1, n * (n - 1), n * n - 1},
        std::vector<Index>{0, n / 2, n * n - 1}, row}) {
    const ObjectDef cloth = gridWithPins(n, pins);
    const TetherConstraints tethers = tethersOf(cloth);
    ASSERT_GT(tethers.size(), 0u);
    for (std::size_t k = 0; k < tethers.size(); ++k) {
      const auto [free, pin] = tethers.particles[k];
      const double straight = (cloth.vertices[free] - cloth.vertices[pin]).cast<double>().norm();
      EXPECT_GE(double(tethers.rest[k]), straight * (1 - 1e-6)) << free << " to " << pin;
    }
    World world;
    world.setGravity(Vec3::Zero());
    world.setSolver(test::solverSettings(SolverKind::ColoredGaussSeidel, 4, 1));
    const ObjectId id = world.addCloth(cloth);
    test::simulate(world, 10);
    const auto x = world.positions(id);
    double moved = 0;
    for (std::size_t v = 0; v < x.size(); ++v)
      moved = std::max(moved, double((x[v] - cloth.vertices[v]).norm()));
    EXPECT_LT(moved, 1e-6) << pins.size() << " pins";
  }
}

// Compliant stretch has no tethers by default (its stretch under a load has no bound known in
// advance); with a strain limit ε it gets the inextensible cloth's tethers, each limit times
// 1 + ε (to float rounding of the stored limits, 1e-6 relative).
TEST(Tethers, ACompliantClothIsTetheredOnlyWithAStrainLimitAndAtItsFactor) {
  const int n = 16;
  ObjectDef cloth = gridWithPins(n, {0, n - 1});
  const TetherConstraints hard = tethersOf(cloth);
  ASSERT_GT(hard.size(), 0u);
  cloth.material.stretchCompliance = Real(1e-4);
  EXPECT_EQ(tethersOf(cloth).size(), 0u);
  const double limit = 0.07;
  cloth.material.stretchLimit = Real(limit);
  const TetherConstraints limited = tethersOf(cloth);
  ASSERT_EQ(limited.size(), hard.size());
  for (std::size_t k = 0; k < hard.size(); ++k) {
    EXPECT_EQ(limited.particles[k], hard.particles[k]);
    EXPECT_NEAR(limited.rest[k], (1 + limit) * hard.rest[k], 1e-6 * limited.rest[k]) << k;
  }
}

// A 48² cloth hung from two adjacent corners by 4 sweeps of each backend. With a tether to the
// nearest pin only, the halves hang from different pins and part along the mid-line where the
// nearest pin changes: measured, the edges across it averaged 2.9–4.1 times the strain of the
// others, and the worst, in the middle of the top edge, was stretched to 2.6–3.1 times its
// length (strain 1.6–2.1). Tethered to both pins, the mid-line edges average 0.9–1.2 times the
// others, the most strained edge anywhere is not on the mid-line, and the max strain is
// 0.41–0.68. The bounds leave room for rounding between machines, not for a seam.
TEST(Tethers, ClothHungFromTwoCornersHasNoSeam) {
  const int n = 48;
  const ObjectDef cloth = gridWithPins(n, {0, n - 1});
  const SimplicialComplex complex = complexOf(cloth);
  for (SolverKind kind :
       {SolverKind::GaussSeidel, SolverKind::ColoredGaussSeidel, SolverKind::Jacobi}) {
    World world;
    world.setSolver(test::solverSettings(kind, 4, 1));
    const ObjectId id = world.addCloth(cloth);
    test::simulate(world, 120);
    const auto x = world.positions(id);
    double seamSum = 0, seamMax = 0, otherSum = 0, otherMax = 0;
    std::size_t seamCount = 0, otherCount = 0;
    for (const auto& [a, b] : complex.edges.vertices) {
      const double rest = (cloth.vertices[a] - cloth.vertices[b]).cast<double>().norm();
      const double strain = std::abs((x[a] - x[b]).cast<double>().norm() / rest - 1);
      // The grid is centred on x = 0 with the pins at its ends: the nearest pin changes there.
      if ((cloth.vertices[a].x() < 0) != (cloth.vertices[b].x() < 0)) {
        seamSum += strain;
        seamMax = std::max(seamMax, strain);
        ++seamCount;
      } else {
        otherSum += strain;
        otherMax = std::max(otherMax, strain);
        ++otherCount;
      }
    }
    ASSERT_EQ(seamCount, std::size_t(2 * n - 1));  // n horizontal edges, n − 1 diagonals
    const double seamMean = seamSum / double(seamCount), otherMean = otherSum / double(otherCount);
    EXPECT_LT(seamMean, 1.5 * otherMean)
        << toString(kind) << ": " << seamMean << " vs " << otherMean;
    EXPECT_LT(seamMax, otherMax) << toString(kind) << ": " << seamMax << " vs " << otherMax;
    EXPECT_LT(std::max(seamMax, otherMax), 0.8) << toString(kind);
  }
}

namespace nucleon {
namespace {

// The layered layout the tether sweep relies on: every tether once, layer k holding one tether
// of each of the first size_k ranked vertices, and rank r the same vertex in every layer.
TEST(TetherSweep, LayersAlignEveryVertexAcrossLayers) {
  const ObjectDef cloth = gridWithPins(24, {0, 11, 23, 24 * 23});  // clusters of one pin each
  TetherConstraints pool = tethersOf(cloth);
  const std::size_t count = pool.size();
  std::multiset<std::pair<Index, Index>> before;
  for (const auto& t : pool.particles) before.insert({t[0], t[1]});
  layerTethers(pool);
  std::multiset<std::pair<Index, Index>> after;
  for (const auto& t : pool.particles) after.insert({t[0], t[1]});
  EXPECT_EQ(before, after);
  ASSERT_EQ(pool.size(), count);
  const auto& layers = pool.coloring.colorOffset;
  ASSERT_GE(pool.coloring.colorCount(), 2u);
  for (std::size_t k = 0; k + 1 < pool.coloring.colorCount(); ++k) {
    const Index size = layers[k + 1] - layers[k], next = layers[k + 2] - layers[k + 1];
    EXPECT_GE(size, next);  // ranks by decreasing tether count
    for (Index r = 0; r < next; ++r)
      EXPECT_EQ(pool.particles[layers[k + 1] + r][0], pool.particles[layers[0] + r][0]);
  }
  std::vector<Real> w(24 * 24, 1);
  for (Index pin : {0u, 11u, 23u, 24u * 23u}) w[pin] = 0;
  const std::span<const std::array<Index, 2>> tuples = pool.particles;
  EXPECT_TRUE(validateColoring(pool.coloring, tuples, w.size(), w));
}

// The tether sweep goes eight vertices at a time on the parallel backends and one at a time on
// Gauss–Seidel; the two apply the same projections in the same order per vertex, so a cloth hung
// from four pins ends within float rounding of each other.
TEST(TetherSweep, BatchedAndSequentialSweepsAgree) {
  std::vector<Vec3> ends[2];
  for (int run = 0; run < 2; ++run) {
    ObjectDef cloth = gridWithPins(33, {0, 16, 32, 33 * 32});
    World world;
    SolverSettings solver = test::solverSettings(
        run == 0 ? SolverKind::GaussSeidel : SolverKind::ColoredGaussSeidel, 4, 1);
    solver.schedule = {{ConstraintFamily::Tether, 1}};  // tethers alone: no other family
    world.setSolver(solver);
    world.addCloth(cloth);
    test::simulate(world, 30);
    ends[run].assign(world.positions().begin(), world.positions().end());
  }
  double worst = 0;
  for (std::size_t i = 0; i < ends[0].size(); ++i)
    worst = std::max(worst, double((ends[0][i] - ends[1][i]).norm()));
  // Free fall of 0.5 s is 1.2 m; the tethers catch it. Float rounding of positions near 1 m,
  // compounded over 30 steps, stays far below a millimetre, except where it is amplified: on the
  // top row between two pins whose limits add up to their distance, the two limits meet on a
  // circle of radius √(2 r g) for a gap g between them, and the gap is only known to float
  // rounding (1e-7 m), which moves the vertex by up to √(2 · 1 m · 1e-7 m) ≈ 0.45 mm (measured
  // 0.49 mm after 30 steps). The eight-wide path uses fused multiply-adds, the scalar one not.
  EXPECT_LT(worst, 2e-3);
  // And the tethers did act: free fall over 30 steps of symplectic Euler drops a vertex by
  // g h² (1 + … + 30) = 1.26 m; many vertices near the pins are held well above that.
  const double freeFall = 9.81 / 3600 * 30 * 31 / 2;
  int held = 0;
  for (const Vec3& x : ends[1]) held += x.y() > 1 - freeFall + 0.05;
  EXPECT_GT(held, 100);
}

}  // namespace
}  // namespace nucleon
