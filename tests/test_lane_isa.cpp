// The instruction sets of the batched kernels (nucleon/lanes.h): the AVX2 and AVX-512 compiles of
// the same kernels must give the same bits, step after step, on every path that uses them
// (colored Gauss–Seidel's distance and angular batches, Jacobi's slot path, the vertex-centric
// Jacobi sweep, the multigrid cascade); a set the CPU lacks is refused; the scalar paths ('none')
// round differently but solve the same constraints.
#include <cstdint>
#include <functional>
#include <vector>

#include <gtest/gtest.h>

#include "nucleon/lanes.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"
#include "systems/solver/angular_batch.h"
#include "systems/solver/distance_batch.h"

namespace nucleon {
namespace {

// Restores the best set however the test ends.
struct BestLanesAfterwards {
  ~BestLanesAfterwards() { selectLaneIsa(bestLaneIsa()); }
};

struct Outcome {
  std::uint64_t hash = 0;
  double meanStrain = 0;
};

// A 48² cloth with shear and bending, pinned at two corners, 20 steps of `settings`;
// `beforeStep(i)`, if given, runs before step i.
Outcome hangingCloth(const SolverSettings& settings,
                     const std::function<void(int)>& beforeStep = nullptr) {
  GridSpec spec;
  spec.resolution = {48, 48};
  ObjectDef cloth = gridCloth(spec);
  cloth.pins = {0, 47};
  cloth.material.shear = cloth.material.bending = true;
  World world;
  world.setSolver(settings);
  world.setThreads(2);
  world.addCloth(cloth);
  for (int i = 0; i < 20; ++i) {
    if (beforeStep) beforeStep(i);
    world.step(1.0 / 60);
  }
  return {world.stateHash(), world.measure().meanStrain};
}

std::vector<SolverSettings> everyBatchedPath() {
  std::vector<SolverSettings> paths;
  for (SolverKind kind : {SolverKind::ColoredGaussSeidel, SolverKind::Jacobi}) {
    SolverSettings s;
    s.kind = kind;
    s.iterations = 8;
    paths.push_back(s);
  }
  for (SolverKind smoother : {SolverKind::ColoredGaussSeidel, SolverKind::Jacobi}) {
    SolverSettings s;
    s.kind = SolverKind::Multigrid;
    s.smoother = smoother;
    s.iterations = 8;
    paths.push_back(s);
  }
  return paths;
}

TEST(LaneIsa, NamesAndSelection) {
  BestLanesAfterwards restore;
  for (LaneIsa isa : {LaneIsa::None, LaneIsa::Avx2, LaneIsa::Avx512}) {
    LaneIsa parsed = LaneIsa::None;
    ASSERT_TRUE(parseLaneIsa(laneIsaName(isa), parsed));
    EXPECT_EQ(parsed, isa);
    const bool runnable = static_cast<int>(isa) <= static_cast<int>(bestLaneIsa());
    EXPECT_EQ(selectLaneIsa(isa), runnable) << laneIsaName(isa);
    EXPECT_EQ(laneIsa(), runnable ? isa : LaneIsa::None) << laneIsaName(isa);
    // A refused set leaves the set before it; go back to none for the next round.
    selectLaneIsa(LaneIsa::None);
  }
  LaneIsa parsed = LaneIsa::Avx2;
  EXPECT_FALSE(parseLaneIsa("sse4", parsed));
  EXPECT_EQ(parsed, LaneIsa::Avx2);
  ASSERT_TRUE(selectLaneIsa(LaneIsa::None));
  EXPECT_FALSE(distanceBatchesAvailable());
  EXPECT_FALSE(angularBatchesAvailable());
  EXPECT_EQ(projectDistanceBatches(DistanceBatch{}, 3, 40), 3u);  // nothing batched: all left
}

TEST(LaneIsa, Avx2AndAvx512GiveTheSameBits) {
  if (bestLaneIsa() != LaneIsa::Avx512) GTEST_SKIP() << "this CPU has no AVX-512 (F and VL)";
  BestLanesAfterwards restore;
  for (const SolverSettings& settings : everyBatchedPath()) {
    ASSERT_TRUE(selectLaneIsa(LaneIsa::Avx2));
    const Outcome avx2 = hangingCloth(settings);
    ASSERT_TRUE(selectLaneIsa(LaneIsa::Avx512));
    const Outcome avx512 = hangingCloth(settings);
    EXPECT_EQ(avx2.hash, avx512.hash)
        << toString(settings.kind) << " / " << toString(settings.smoother);
  }
}

// A switch between the two sets between steps (or, by the same argument, between sweeps) leaves
// the state as if one set had run throughout.
TEST(LaneIsa, SwitchingSetsBetweenStepsKeepsTheState) {
  if (bestLaneIsa() != LaneIsa::Avx512) GTEST_SKIP() << "this CPU has no AVX-512 (F and VL)";
  BestLanesAfterwards restore;
  SolverSettings settings;
  settings.kind = SolverKind::Multigrid;
  settings.smoother = SolverKind::Jacobi;
  settings.iterations = 8;
  ASSERT_TRUE(selectLaneIsa(LaneIsa::Avx512));
  const Outcome throughout = hangingCloth(settings);
  const Outcome alternating = hangingCloth(
      settings, [](int step) { selectLaneIsa(step % 2 == 0 ? LaneIsa::Avx2 : LaneIsa::Avx512); });
  EXPECT_EQ(alternating.hash, throughout.hash);
  EXPECT_EQ(laneIsa(), LaneIsa::Avx512);  // the last step's set: the switches took effect
}

// The scalar paths solve the same constraints: after 20 steps the mean strain agrees within 2%
// (the batches differ from the scalar kernels by rounding, about 1e-7 relative per projection,
// which the cloth's motion spreads over the steps; measured here: within 0.2% on every path).
TEST(LaneIsa, ScalarPathsSolveTheSameConstraints) {
  if (bestLaneIsa() == LaneIsa::None) GTEST_SKIP() << "no batched kernels in this build or CPU";
  BestLanesAfterwards restore;
  for (const SolverSettings& settings : everyBatchedPath()) {
    ASSERT_TRUE(selectLaneIsa(bestLaneIsa()));
    const Outcome lanes = hangingCloth(settings);
    ASSERT_TRUE(selectLaneIsa(LaneIsa::None));
    const Outcome scalar = hangingCloth(settings);
    EXPECT_NE(lanes.hash, scalar.hash);  // the switch took effect
    EXPECT_NEAR(scalar.meanStrain, lanes.meanStrain, 0.02 * lanes.meanStrain)
        << toString(settings.kind) << " / " << toString(settings.smoother);
  }
}

}  // namespace
}  // namespace nucleon
