// The level hierarchy of the multigrid backend (components/level_hierarchy.h) against its
// definition (Müller 2008, "Hierarchical Position Based Dynamics", §4): nested levels that keep
// every pin, prolongation weights that are a partition of unity over parents on the next level,
// coarse edges that follow the neighbour-or-shared-fine-neighbour rule, valid edge colorings, and
// the same tables on every build. Checked on a grid cloth (free, two pinned corners, a pinned
// row), a rope, a tet solid, several objects in one world and degenerate objects.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <utility>

#include <gtest/gtest.h>

#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"
#include "sim_test_context.h"
#include "systems/setup/build_hierarchy.h"

namespace nucleon {
namespace {

using Pair = std::pair<Index, Index>;

LevelHierarchies build(const World& world, const HierarchySettings& settings = {}) {
  LevelHierarchies out;
  buildLevelHierarchies(out, world.impl().state.objects, world.impl().state.particles, settings);
  return out;
}

ObjectDef grid(int n) {
  GridSpec spec;
  spec.resolution = {n, n};
  return gridCloth(spec);
}

std::vector<std::size_t> levelSizes(const ObjectHierarchy& h) {
  std::vector<std::size_t> sizes;
  for (const HierarchyLevel& level : h.levels) sizes.push_back(level.particles.size());
  return sizes;
}

void print(const char* what, const ObjectHierarchy& h) {
  std::printf("%s:", what);
  for (const HierarchyLevel& level : h.levels)
    std::printf(" %zu (%zu edges, %zu colors)", level.particles.size(), level.edges.size(),
                level.colorCount());
  std::printf("\n");
}

bool contains(const std::vector<Index>& sorted, Index i) {
  return std::binary_search(sorted.begin(), sorted.end(), i);
}

Pair ordered(Index a, Index b) {
  return a < b ? Pair{a, b} : Pair{b, a};
}

// The connected pieces of a level's graph (union–find over its particles), counting the
// particles of inverse mass 0 as one: they are held by the world, and coarse levels drop the
// limits between two of them.
std::size_t componentCount(const HierarchyLevel& level, const ParticlePool& particles) {
  std::map<Index, Index> root;
  for (Index i : level.particles) root[i] = i;
  auto find = [&](Index i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  for (const auto& e : level.edges) root[find(e[0])] = find(e[1]);
  Index held = static_cast<Index>(-1);
  for (Index i : level.particles)
    if (particles.w[i] == 0) {
      if (held != static_cast<Index>(-1)) root[find(i)] = find(held);
      held = i;
    }
  std::size_t pieces = 0;
  for (Index i : level.particles) pieces += find(i) == i;
  return pieces;
}

// Every invariant the header promises, for one object's hierarchy. The edges of level l + 1 are
// recomputed from level l by the rule itself (sets of pairs), independently of the builder's
// row-by-row construction. With the link through fine edges, every level has as many connected
// pieces as the object (the objects here are connected: one).
void checkInvariants(const ObjectHierarchy& h, const ObjectRecord& object,
                     const ParticlePool& particles, const HierarchySettings& settings = {}) {
  const Index first = object.firstParticle;
  ASSERT_EQ(h.firstParticle, first);
  ASSERT_EQ(h.particleCount, object.particleCount);
  ASSERT_FALSE(h.levels.empty());

  // Level 0: every particle of the object, and its graph is the object's edges.
  std::vector<Index> all(object.particleCount);
  for (Index i = 0; i < object.particleCount; ++i) all[i] = first + i;
  EXPECT_EQ(h.levels[0].particles, all);
  std::set<Pair> objectEdges;
  for (const auto& e : object.complex.edges.vertices)
    objectEdges.insert(ordered(first + e[0], first + e[1]));
  std::set<Pair> levelZeroEdges;
  for (const auto& e : h.levels[0].edges) levelZeroEdges.insert({e[0], e[1]});
  EXPECT_EQ(levelZeroEdges, objectEdges);

  const std::size_t pieces = componentCount(h.levels[0], particles);
  for (std::size_t l = 0; l < h.levels.size(); ++l) {
    SCOPED_TRACE("level " + std::to_string(l));
    const HierarchyLevel& level = h.levels[l];
    const bool coarsest = l + 1 == h.levels.size();
    if (settings.linkThroughFineEdges) {
      EXPECT_EQ(componentCount(level, particles), pieces);
    }
    ASSERT_TRUE(std::is_sorted(level.particles.begin(), level.particles.end()));
    ASSERT_TRUE(std::adjacent_find(level.particles.begin(), level.particles.end()) ==
                level.particles.end());
    if (l > 0) {
      const auto& previous = h.levels[l - 1].particles;
      EXPECT_TRUE(std::includes(previous.begin(), previous.end(), level.particles.begin(),
                                level.particles.end()))
          << "not nested";
    }
    // Pins and animated pins (inverse mass 0) are on every level.
    for (Index i = first; i < first + object.particleCount; ++i)
      if (particles.w[i] == 0) {
        EXPECT_TRUE(contains(level.particles, i)) << "pin " << i;
      }

    // Edges: ends on the level, ascending, no duplicates, rest-pose lengths. The length is the
    // distance computed in double and rounded once to Real, so it agrees with the float distance
    // to a few ulps: relative 1e-6.
    ASSERT_EQ(level.restLength.size(), level.edges.size());
    std::set<Pair> levelEdges;
    for (std::size_t e = 0; e < level.edges.size(); ++e) {
      const auto [a, b] = level.edges[e];
      EXPECT_LT(a, b);
      EXPECT_TRUE(contains(level.particles, a) && contains(level.particles, b))
          << "edge " << a << "-" << b << " leaves its level";
      EXPECT_TRUE(levelEdges.insert({a, b}).second) << "duplicate edge " << a << "-" << b;
      if (l > 0) {
        EXPECT_FALSE(particles.w[a] == 0 && particles.w[b] == 0) << "limit between two pins";
      }
      const double distance =
          (particles.restPosition[a].cast<double>() - particles.restPosition[b].cast<double>())
              .norm();
      EXPECT_NEAR(level.restLength[e], distance, 1e-6 * distance);
    }

    // Paths (coarse levels): from the edge's first particle to its second along one to three
    // edges of the finer level (the first particle repeated in front of a shorter path), their
    // rest lengths summed; never shorter than the straight rest distance (to float rounding).
    if (l == 0) {
      EXPECT_TRUE(level.path.empty());
    } else {
      const HierarchyLevel& finer = h.levels[l - 1];
      std::map<Pair, Real> finerRest;
      for (std::size_t e = 0; e < finer.edges.size(); ++e)
        finerRest[{finer.edges[e][0], finer.edges[e][1]}] = finer.restLength[e];
      ASSERT_EQ(level.path.size(), level.edges.size());
      ASSERT_EQ(level.pathRest.size(), level.edges.size());
      for (std::size_t e = 0; e < level.edges.size(); ++e) {
        const auto& path = level.path[e];
        EXPECT_EQ(path[0], level.edges[e][0]);
        EXPECT_EQ(path[3], level.edges[e][1]);
        double rest = 0;
        int steps = 0;
        for (std::size_t k = 0; k < 3; ++k) {
          if (path[k] == path[k + 1]) {
            EXPECT_EQ(path[k], path[0]) << "path of edge " << e << " pauses past its start";
            continue;
          }
          const auto found = finerRest.find(ordered(path[k], path[k + 1]));
          ASSERT_TRUE(found != finerRest.end()) << "path of edge " << e << " leaves the level";
          rest += found->second;
          ++steps;
        }
        EXPECT_GE(steps, 1);
        EXPECT_NEAR(level.pathRest[e], rest, 1e-6 * rest);
        EXPECT_GE(level.pathRest[e], level.restLength[e] * (1 - 1e-6));
      }
    }

    // Coloring: offsets cover the edges, and no particle appears twice in one color.
    ASSERT_GE(level.colorOffset.size(), 1u);
    EXPECT_EQ(level.colorOffset.front(), 0u);
    EXPECT_EQ(level.colorOffset.back(), level.edges.size());
    EXPECT_EQ(level.colorCount(), level.colorOffset.size() - 1);
    for (std::size_t c = 0; c < level.colorCount(); ++c) {
      EXPECT_LT(level.colorOffset[c], level.colorOffset[c + 1]) << "empty color " << c;
      std::set<Index> touched;
      for (Index e = level.colorOffset[c]; e < level.colorOffset[c + 1]; ++e)
        for (Index i : level.edges[e])
          EXPECT_TRUE(touched.insert(i).second) << "color " << c << " shares particle " << i;
    }

    // Prolongation: fine ∪ next level = this level, disjoint; each fine particle has at least k
    // parents (every fine particle keeps k coarse neighbours, Müller 2008 §4.1), all on the next
    // level and neighbours of it at this level, with positive weights summing to 1. The weights
    // are normalised in double and rounded once to float: the sum is within a few parents × one
    // ulp of 1 (6e-8 each), far inside 1e-6.
    ASSERT_EQ(level.parentOffset.size(), level.fine.size() + 1);
    EXPECT_EQ(level.parentOffset.front(), 0u);
    EXPECT_EQ(level.parentOffset.back(), level.parent.size());
    EXPECT_EQ(level.weight.size(), level.parent.size());
    if (coarsest) {
      EXPECT_TRUE(level.fine.empty());
      continue;
    }
    const auto& next = h.levels[l + 1].particles;
    std::vector<Index> merged;
    std::merge(level.fine.begin(), level.fine.end(), next.begin(), next.end(),
               std::back_inserter(merged));
    EXPECT_EQ(merged, level.particles) << "fine and next level do not partition the level";
    EXPECT_FALSE(level.fine.empty());
    for (std::size_t k = 0; k < level.fine.size(); ++k) {
      const Index f = level.fine[k];
      EXPECT_FALSE(contains(next, f));
      EXPECT_NE(particles.w[f], 0) << "pin " << f << " is fine";
      const auto parents = level.parentsOf(k);
      const auto weights = level.weightsOf(k);
      EXPECT_GE(parents.size(), static_cast<std::size_t>(settings.coarseNeighbours))
          << "fine particle " << f;
      double sum = 0;
      for (std::size_t j = 0; j < parents.size(); ++j) {
        EXPECT_TRUE(contains(next, parents[j])) << "parent " << parents[j] << " of " << f;
        EXPECT_TRUE(levelEdges.count(ordered(f, parents[j])))
            << "parent " << parents[j] << " is not a neighbour of " << f;
        EXPECT_GT(weights[j], 0);
        sum += weights[j];
      }
      EXPECT_NEAR(sum, 1, 1e-6) << "fine particle " << f;
    }

    // The next level's edges, by the rule: two next-level particles that are neighbours here,
    // share a neighbour that is fine here, or (link through fine edges) have fine neighbours
    // that are neighbours of each other.
    std::set<Pair> expected;
    for (const Pair& e : levelEdges)
      if (contains(next, e.first) && contains(next, e.second)) expected.insert(e);
    std::vector<std::vector<Index>> coarseAround(object.particleCount);
    for (const Pair& e : levelEdges) {
      if (contains(level.fine, e.first) && contains(next, e.second))
        coarseAround[e.first - first].push_back(e.second);
      if (contains(level.fine, e.second) && contains(next, e.first))
        coarseAround[e.second - first].push_back(e.first);
    }
    for (const auto& around : coarseAround)
      for (Index a : around)
        for (Index b : around)
          if (a < b) expected.insert({a, b});
    if (settings.linkThroughFineEdges)
      for (const Pair& e : levelEdges)
        if (contains(level.fine, e.first) && contains(level.fine, e.second))
          for (Index a : coarseAround[e.first - first])
            for (Index b : coarseAround[e.second - first])
              if (a != b) expected.insert(ordered(a, b));
    std::erase_if(expected, [&](const Pair& e) {
      return particles.w[e.first] == 0 && particles.w[e.second] == 0;
    });
    std::set<Pair> nextEdges;
    for (const auto& e : h.levels[l + 1].edges) nextEdges.insert({e[0], e[1]});
    EXPECT_EQ(nextEdges, expected);
  }
}

void expectIdentical(const LevelHierarchies& a, const LevelHierarchies& b) {
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (std::size_t o = 0; o < a.objects.size(); ++o) {
    const ObjectHierarchy &x = a.objects[o], &y = b.objects[o];
    EXPECT_EQ(x.object, y.object);
    ASSERT_EQ(x.levels.size(), y.levels.size());
    for (std::size_t l = 0; l < x.levels.size(); ++l) {
      const HierarchyLevel &p = x.levels[l], &q = y.levels[l];
      EXPECT_EQ(p.particles, q.particles);
      EXPECT_EQ(p.edges, q.edges);
      EXPECT_EQ(p.restLength, q.restLength);  // bitwise: the same operations on the same input
      EXPECT_EQ(p.colorOffset, q.colorOffset);
      EXPECT_EQ(p.fine, q.fine);
      EXPECT_EQ(p.parentOffset, q.parentOffset);
      EXPECT_EQ(p.parent, q.parent);
      EXPECT_EQ(p.weight, q.weight);
      EXPECT_EQ(p.path, q.path);
      EXPECT_EQ(p.pathRest, q.pathRest);
      EXPECT_EQ(p.scratchBase, q.scratchBase);
    }
  }
  EXPECT_EQ(a.coarseEdges, b.coarseEdges);
}

TEST(Hierarchy, GridCloth256LevelSizes) {
  World world;
  world.addCloth(grid(256));
  const auto start = std::chrono::steady_clock::now();
  const LevelHierarchies hierarchies = build(world);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(hierarchies.objects.size(), 1u);
  const ObjectHierarchy& h = hierarchies.objects[0];
  print("256x256 cloth", h);
  std::printf("built in %.1f ms\n", 1e3 * seconds);
  checkInvariants(h, world.impl().state.objects[0], world.impl().state.particles);

  // Decimation two to one along each axis keeping the last row and column: a side of m vertices
  // becomes ⌈m/2⌉ + (m even), 256 → 129 → 65 → 33 → 17 → 9 → 5, until 25 ≤ 32. Each level is a
  // little over a quarter of the one before (the kept last row and column), at most (5/9)² ≈ 0.31.
  const auto sizes = levelSizes(h);
  EXPECT_EQ(sizes, (std::vector<std::size_t>{65536, 16641, 4225, 1089, 289, 81, 25}));
  for (std::size_t l = 1; l < sizes.size(); ++l) {
    const double ratio = double(sizes[l]) / double(sizes[l - 1]);
    EXPECT_GT(ratio, 0.25) << "level " << l;
    EXPECT_LT(ratio, 0.32) << "level " << l;
  }
  // Every coarse level is the grid of its kept rows and columns with both diagonals of each
  // cell: (s − 1)² cells of 2 diagonals and 2 s (s − 1) axis edges, s the side.
  // Level 1 lacks one diagonal: its last row and column are neighbours at level 0 too, and their
  // corner cell is a level-0 cell with its single diagonal.
  for (std::size_t l = 1; l < h.levels.size(); ++l) {
    const std::size_t side = static_cast<std::size_t>(std::lround(std::sqrt(sizes[l])));
    EXPECT_EQ(h.levels[l].edges.size(),
              2 * (side - 1) * (side - 1) + 2 * side * (side - 1) - (l == 1 ? 1 : 0));
    // An axis edge's path is the straight one through the finer level's particle between its
    // ends: rest length along it equals the rest distance.
    const auto& rest = world.impl().state.particles.restPosition;
    for (std::size_t e = 0; e < h.levels[l].edges.size(); ++e) {
      const auto [a, b] = h.levels[l].edges[e];
      const Vec3 d = rest[b] - rest[a];
      const int axes = (d.x() != 0) + (d.y() != 0) + (d.z() != 0);
      if (axes == 1) {
        EXPECT_NEAR(h.levels[l].pathRest[e], h.levels[l].restLength[e], 1e-5);
      }
    }
  }
#if !defined(__SANITIZE_ADDRESS__) && defined(NDEBUG)
  EXPECT_LT(seconds, 1.0);
#endif
}

// The greedy selection on the same grid (decimation off), which is what irregular meshes get:
// measured 65,536, 16,513, 3,804, 544, 76, 14 particles. Its levels shrink faster than the
// grid's, 0.14 to 0.25 of the one before (bounds 1/10 and 1/3 with room), and, with the link
// through fine edges, each stays connected.
TEST(Hierarchy, GridCloth256GreedySelection) {
  World world;
  world.addCloth(grid(256));
  HierarchySettings settings;
  settings.decimateGrids = false;
  const LevelHierarchies hierarchies = build(world, settings);
  ASSERT_EQ(hierarchies.objects.size(), 1u);
  const ObjectHierarchy& h = hierarchies.objects[0];
  print("256x256 cloth, greedy selection", h);
  checkInvariants(h, world.impl().state.objects[0], world.impl().state.particles, settings);
  const auto sizes = levelSizes(h);
  EXPECT_LE(sizes.back(), 32u);
  for (std::size_t l = 1; l < sizes.size(); ++l) {
    const double ratio = double(sizes[l]) / double(sizes[l - 1]);
    EXPECT_GT(ratio, 0.1) << "level " << l;
    EXPECT_LT(ratio, 1.0 / 3) << "level " << l;
  }
}

TEST(Hierarchy, ClothPinnedAtTwoCorners) {
  ObjectDef cloth = grid(64);
  cloth.pins = {0, 63};
  World world;
  world.addCloth(cloth);
  const LevelHierarchies hierarchies = build(world);
  ASSERT_EQ(hierarchies.objects.size(), 1u);
  print("64x64 cloth, two pinned corners", hierarchies.objects[0]);
  checkInvariants(hierarchies.objects[0], world.impl().state.objects[0],
                  world.impl().state.particles);
}

TEST(Hierarchy, ClothWithPinnedRow) {
  ObjectDef cloth = grid(64);
  for (Index i = 0; i < 64; ++i) cloth.pins.push_back(i);
  World world;
  world.addCloth(cloth);
  const LevelHierarchies hierarchies = build(world);
  ASSERT_EQ(hierarchies.objects.size(), 1u);
  const ObjectHierarchy& h = hierarchies.objects[0];
  print("64x64 cloth, pinned row", h);
  checkInvariants(h, world.impl().state.objects[0], world.impl().state.particles);
  // The 64 pins stay on every level, so the levels cannot reach 32 particles: the hierarchy ends
  // where a level would drop fewer than a tenth of its particles, with more than the pins left.
  EXPECT_GT(h.levels.back().particles.size(), 64u);
  EXPECT_GT(h.levels.size(), 2u);
}

// Each coarse level carries the tethers of its particles, the pool's own (pin and limit), so the
// cascade holds a coarse particle as the fine tether sweep holds it; the fine level carries none.
TEST(Hierarchy, CoarseLevelsCarryTheirParticlesTethers) {
  ObjectDef cloth = grid(64);
  cloth.pins = {0, 63};
  World world;
  world.setSolver(test::solverSettings(SolverKind::Multigrid, 4, 1));
  world.addCloth(cloth);
  world.step(1.0 / 60);  // builds the derived tables, the hierarchies and their tethers
  const WorldState& state = world.impl().state;
  const TetherConstraints& pool = state.constraints.tether;
  std::map<Index, std::set<std::pair<Index, Real>>> expected;
  for (std::size_t c = 0; c < pool.size(); ++c)
    expected[pool.particles[c][0]].insert({pool.particles[c][1], pool.rest[c]});
  ASSERT_EQ(state.hierarchies.objects.size(), 1u);
  const ObjectHierarchy& h = state.hierarchies.objects[0];
  ASSERT_GE(h.levels.size(), 3u);
  EXPECT_TRUE(h.levels[0].tetherOffset.empty());
  std::size_t checked = 0;
  for (std::size_t l = 1; l < h.levels.size(); ++l) {
    const HierarchyLevel& level = h.levels[l];
    ASSERT_EQ(level.tetherOffset.size(), level.particles.size() + 1) << "level " << l;
    for (std::size_t k = 0; k < level.particles.size(); ++k) {
      std::set<std::pair<Index, Real>> got;
      for (Index t = level.tetherOffset[k]; t < level.tetherOffset[k + 1]; ++t)
        got.insert({level.tetherPin[t], level.tetherLimit[t]});
      const auto it = expected.find(level.particles[k]);
      using Tethers = std::set<std::pair<Index, Real>>;
      EXPECT_EQ(got, it == expected.end() ? Tethers{} : it->second)
          << "level " << l << " particle " << level.particles[k];
      checked += got.size();
    }
  }
  EXPECT_GT(checked, 0u);
}

// A strain limit ε (Material::stretchLimit) makes every coarse limit, and the rest length of the
// path it is compared with, 1 + ε times the rest distance (to the rounding of one float product,
// 1e-6 relative), and leaves the levels, their edges and the fine level's lengths as they are.
TEST(Hierarchy, AStrainLimitScalesTheCoarseLimits) {
  ObjectDef cloth = grid(32);
  cloth.pins = {0, 31};
  cloth.material.stretchCompliance = Real(1e-4);
  World plain;
  plain.addCloth(cloth);
  const Real limit = Real(0.05);
  cloth.material.stretchLimit = limit;
  World limited;
  limited.addCloth(cloth);
  const LevelHierarchies a = build(plain), b = build(limited);
  ASSERT_EQ(a.objects.size(), 1u);
  ASSERT_EQ(b.objects.size(), 1u);
  const ObjectHierarchy &ha = a.objects[0], &hb = b.objects[0];
  ASSERT_EQ(levelSizes(ha), levelSizes(hb));
  ASSERT_GE(ha.levels.size(), 2u);
  EXPECT_EQ(ha.levels[0].restLength, hb.levels[0].restLength);
  std::size_t checked = 0;
  for (std::size_t l = 1; l < ha.levels.size(); ++l) {
    const HierarchyLevel &la = ha.levels[l], &lb = hb.levels[l];
    ASSERT_EQ(la.edges, lb.edges) << "level " << l;
    ASSERT_EQ(la.pathRest.size(), la.edges.size());
    ASSERT_EQ(lb.pathRest.size(), lb.edges.size());
    for (std::size_t e = 0; e < la.edges.size(); ++e, ++checked) {
      EXPECT_NEAR(lb.restLength[e], (1 + limit) * la.restLength[e], 1e-6 * lb.restLength[e]);
      EXPECT_NEAR(lb.pathRest[e], (1 + limit) * la.pathRest[e], 1e-6 * lb.pathRest[e]);
    }
  }
  EXPECT_GT(checked, 0u);
}

// A straight rope of 200 segments: the ends have one neighbour and stay coarse, and in index order
// every odd particle has two coarse neighbours and becomes fine, every even one is left with one.
// Each level halves the chain, (n + 1) / 2, until 26 ≤ 32; each fine particle sits midway between
// its two parents, which weigh ½ each.
TEST(Hierarchy, Rope) {
  World world;
  world.addRope(polylineRope(Vec3(0, 1, 0), Vec3(2, 1, 0), 200));
  const LevelHierarchies hierarchies = build(world);
  ASSERT_EQ(hierarchies.objects.size(), 1u);
  const ObjectHierarchy& h = hierarchies.objects[0];
  print("rope of 200 segments", h);
  checkInvariants(h, world.impl().state.objects[0], world.impl().state.particles);
  EXPECT_EQ(levelSizes(h), (std::vector<std::size_t>{201, 101, 51, 26}));
  for (std::size_t l = 0; l < h.levels.size(); ++l) {
    EXPECT_EQ(h.levels[l].colorCount(), 2u) << "a chain needs two colors";
    // The rest positions are floats spaced 1 cm apart near x = 1, so the two rest distances of a
    // midpoint differ by up to two ulps of 1 (2.4e-7) relative to 1 cm, δ ≈ 2.4e-5, and the
    // weights by about δ/4 from ½ (ŵ ∝ 1/(d/max d + ε)): 1e-5 covers it.
    for (Real weight : h.levels[l].weight) EXPECT_NEAR(weight, 0.5, 1e-5);
  }
}

TEST(Hierarchy, TetSolid) {
  World world;
  world.addSolid(tetBox(Vec3(0, 1, 0), Vec3(1, 1, 1), {8, 8, 8}));
  const LevelHierarchies hierarchies = build(world);
  ASSERT_EQ(hierarchies.objects.size(), 1u);
  const ObjectHierarchy& h = hierarchies.objects[0];
  print("tet box of 8x8x8 cubes", h);
  checkInvariants(h, world.impl().state.objects[0], world.impl().state.particles);
  EXPECT_EQ(h.levels.front().particles.size(), 9u * 9u * 9u);
  EXPECT_GT(h.levels.size(), 1u);
}

// Several objects: one hierarchy per object with edges, in object order, with the particle
// offsets of each object (global indices), and nothing for particle clouds or colliders.
TEST(Hierarchy, SeveralObjectsUseGlobalIndices) {
  World world;
  ObjectDef cloud;
  cloud.vertices = {Vec3(0, 3, 0), Vec3(0.1f, 3, 0), Vec3(0.2f, 3, 0)};
  world.addParticles(cloud);
  world.addRope(polylineRope(Vec3(0, 1, 0), Vec3(2, 1, 0), 50));
  ObjectDef collider = grid(8);
  world.addCollider(collider);
  ObjectDef cloth = grid(40);
  cloth.pins = {0, 39};
  world.addCloth(cloth);
  const LevelHierarchies hierarchies = build(world);
  const WorldState& state = world.impl().state;
  ASSERT_EQ(hierarchies.objects.size(), 2u);
  EXPECT_EQ(hierarchies.objects[0].object, 1u);
  EXPECT_EQ(hierarchies.objects[1].object, 3u);
  EXPECT_EQ(hierarchies.objects[0].firstParticle, 3u);
  for (const ObjectHierarchy& h : hierarchies.objects)
    checkInvariants(h, state.objects[h.object], state.particles);
}

TEST(Hierarchy, Deterministic) {
  World world;
  ObjectDef cloth = grid(64);
  cloth.pins = {0, 63};
  world.addCloth(cloth);
  world.addRope(polylineRope(Vec3(0, 1, 0), Vec3(2, 1, 0), 100));
  world.addSolid(tetBox(Vec3(0, 1, 0), Vec3(1, 1, 1), {5, 5, 5}));
  const LevelHierarchies first = build(world), second = build(world);
  expectIdentical(first, second);
  // Rebuilding into a used table replaces it.
  LevelHierarchies reused = first;
  buildLevelHierarchies(reused, world.impl().state.objects, world.impl().state.particles);
  expectIdentical(first, reused);
}

// A smaller smallest level and k = 3 with the greedy selection keep the invariants (every fine
// particle keeps 3 parents).
TEST(Hierarchy, Settings) {
  World world;
  world.addCloth(grid(64));
  HierarchySettings settings;
  settings.coarseNeighbours = 3;
  settings.smallestLevel = 8;
  settings.decimateGrids = false;
  const LevelHierarchies hierarchies = build(world, settings);
  ASSERT_EQ(hierarchies.objects.size(), 1u);
  print("64x64 cloth, k = 3, smallest level 8", hierarchies.objects[0]);
  checkInvariants(hierarchies.objects[0], world.impl().state.objects[0],
                  world.impl().state.particles, settings);
}

// Degenerate objects: a two-particle rope is one level of one edge; a rope record without edges
// and a single particle get no hierarchy; none of them crashes.
TEST(Hierarchy, DegenerateObjects) {
  World world;
  world.addRope(polylineRope(Vec3(0, 1, 0), Vec3(1, 1, 0), 1));
  const LevelHierarchies two = build(world);
  ASSERT_EQ(two.objects.size(), 1u);
  const ObjectHierarchy& h = two.objects[0];
  ASSERT_EQ(h.levels.size(), 1u);
  EXPECT_EQ(h.levels[0].particles, (std::vector<Index>{0, 1}));
  EXPECT_EQ(h.levels[0].edges.size(), 1u);
  EXPECT_EQ(h.levels[0].colorCount(), 1u);
  EXPECT_NEAR(h.levels[0].restLength[0], 1, 1e-6);
  checkInvariants(h, world.impl().state.objects[0], world.impl().state.particles);

  std::vector<ObjectRecord> objects(2);
  ParticlePool particles;
  objects[0].kind = ObjectKind::Rope;
  objects[0].firstParticle = particles.append(3);
  objects[0].particleCount = 3;
  objects[0].complex = buildFromPoints(3);
  objects[1].kind = ObjectKind::Cloth;
  objects[1].firstParticle = particles.append(1);
  objects[1].particleCount = 1;
  objects[1].complex = buildFromPoints(1);
  LevelHierarchies none;
  buildLevelHierarchies(none, objects, particles, {});
  EXPECT_TRUE(none.objects.empty());
}

}  // namespace
}  // namespace nucleon
