// The parallel backends: coloring validity and balance, the Jacobi incidence table, and
// bitwise-identical results for 1 and 2 threads.
#include <gtest/gtest.h>

#include <algorithm>

#include "engine/src/world_state.h"
#include "sim_test_context.h"
#include "systems/setup/build_constraint_graph.h"

using namespace nucleon;

namespace {
// Test-name suffix for a backend: "colored-gs" → "colored_gs".
std::string backendName(const ::testing::TestParamInfo<SolverKind>& info) {
  std::string name = toString(info.param);
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

std::vector<std::array<Index, 2>> clothEdges(int n) {
  World world = test::hangingCloth(n, 1);
  return world.impl().state.constraints.stretch.particles;
}
}  // namespace

TEST(Coloring, NoTwoConstraintsOfAColorShareAParticleAndColorsAreBalanced) {
  const auto edges = clothEdges(32);
  const std::span<const std::array<Index, 2>> pairs = edges;
  const ConstraintColoring coloring = colorConstraints(pairs, 32 * 32);
  EXPECT_TRUE(validateColoring(coloring, pairs, 32 * 32));
  EXPECT_FALSE(coloring.overflow);
  // A grid vertex has at most 8 edges (alternating diagonals), so greedy needs at most 15 colors.
  EXPECT_LE(coloring.colorCount(), 15u);
  std::size_t smallest = edges.size(), largest = 0;
  for (std::size_t k = 0; k < coloring.colorCount(); ++k) {
    const std::size_t size = coloring.colorOffset[k + 1] - coloring.colorOffset[k];
    smallest = std::min(smallest, size);
    largest = std::max(largest, size);
  }
  // Least-used-first keeps colors within a factor of two of each other on a regular mesh.
  EXPECT_LE(largest, 2 * smallest) << smallest << " .. " << largest;

  // The validator is not vacuous: merging two colors breaks it.
  ConstraintColoring broken = coloring;
  broken.colorOffset.erase(broken.colorOffset.begin() + 1);
  EXPECT_FALSE(validateColoring(broken, pairs, 32 * 32));
}

TEST(Coloring, OverflowRangeCatchesConstraintsBeyondTheColorLimit) {
  // 70 edges sharing particle 0 need 70 colors; the ones past 64 go to the serial range.
  std::vector<std::array<Index, 2>> star;
  for (Index i = 1; i <= 70; ++i) star.push_back({0, i});
  const std::span<const std::array<Index, 2>> pairs = star;
  const ConstraintColoring coloring = colorConstraints(pairs, 71);
  EXPECT_TRUE(coloring.overflow);
  EXPECT_EQ(coloring.colorCount(), 65u);
  EXPECT_EQ(coloring.colorOffset[65] - coloring.colorOffset[64], 6u);
  EXPECT_TRUE(validateColoring(coloring, pairs, 71));
}

TEST(Incidence, ListsEverySlotOnceInIncreasingOrder) {
  const auto edges = clothEdges(8);
  const std::span<const std::array<Index, 2>> pairs = edges;
  const ParticleIncidence incidence = buildIncidence(pairs, 64);
  ASSERT_EQ(incidence.slot.size(), 2 * edges.size());
  std::vector<int> seen(2 * edges.size(), 0);
  for (Index i = 0; i < 64; ++i)
    for (Index s = incidence.offset[i]; s < incidence.offset[i + 1]; ++s) {
      const Index slot = incidence.slot[s];
      EXPECT_EQ(edges[slot / 2][slot % 2], i);
      if (s > incidence.offset[i]) {
        EXPECT_LT(incidence.slot[s - 1], incidence.slot[s]);
      }
      ++seen[incidence.slot[s]];
    }
  EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int n) { return n == 1; }));
}

class Determinism : public ::testing::TestWithParam<SolverKind> {};

TEST_P(Determinism, ClothHangStateHashIsTheSameForOneAndTwoThreads) {
#if defined(__SANITIZE_ADDRESS__)
  // Determinism is a property of the arithmetic, which the Release and double builds check; the
  // sanitizer build runs every backend on hanging cloth in the tests around this one.
  GTEST_SKIP() << "thread-count determinism is checked in the Release and double builds";
#endif
  auto run = [&](int threads) {
    World world = test::hangingCloth(64, 10, 1, threads);
    world.setSolver(test::solverSettings(GetParam(), 10, 1));
    test::simulate(world, 100);
    EXPECT_EQ(world.measure().nanCount, 0u);
    return world.stateHash();
  };
  EXPECT_EQ(run(1), run(2));
}

INSTANTIATE_TEST_SUITE_P(Backends, Determinism,
                         ::testing::Values(SolverKind::GaussSeidel, SolverKind::Jacobi,
                                           SolverKind::ColoredGaussSeidel),
                         backendName);

class VolumeFamily : public ::testing::TestWithParam<SolverKind> {};

// A soft cube of 216 tets hanging from one corner for a second: hard volume constraints keep the
// enclosed volume within 2% for every backend (stretch alone lets it lose more: checked below).
TEST_P(VolumeFamily, HangingSolidKeepsItsVolume) {
  auto run = [&](bool volume) {
    ObjectDef box = tetBox(Vec3(0, 1, 0), Vec3(0.6f, 0.6f, 0.6f), {6, 6, 6});
    box.pins = {0};
    box.material.stretchCompliance = 1e-4f;
    box.material.compressionCompliance = 1e-4f;
    box.material.volumeCompliance = volume ? 0 : 1e6f;
    World world;
    world.setSolver(test::solverSettings(GetParam(), 10, 1));
    world.addSolid(box);
    test::simulate(world, 60);
    EXPECT_EQ(world.measure().nanCount, 0u);
    return world.measure().volumeRatio;
  };
  const double kept = run(true), free = run(false);
  EXPECT_NEAR(kept, 1.0, 0.02);
  EXPECT_GT(std::abs(free - 1.0), std::abs(kept - 1.0));
}

INSTANTIATE_TEST_SUITE_P(Backends, VolumeFamily,
                         ::testing::Values(SolverKind::GaussSeidel, SolverKind::Jacobi,
                                           SolverKind::ColoredGaussSeidel),
                         backendName);
