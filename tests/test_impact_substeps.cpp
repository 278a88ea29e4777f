// Substeps raised for fast impacts (SolverSettings::maxImpactTravel): each object's median edge
// length, how far its free particles go in a step when any of them may strike a collider, how
// many substeps that asks for, and the worlds that take them or, with nothing near, do not.
#include <algorithm>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"
#include "systems/diagnostics/measures.h"
#include "systems/dynamics/impact_travel.h"

namespace nucleon {
namespace {

constexpr double kStep = 1.0 / 60;

// An 11×11 sheet 1 m square (0.1 m edges, a grid's diagonals 0.141 m) lying flat at `height`,
// moving at `velocity`, without gravity so that its speed is the one given.
ObjectDef sheetAt(Real height, const Vec3& velocity) {
  GridSpec spec;
  spec.resolution = {11, 11};
  spec.size = {1, 1};
  spec.center = Vec3(0, height, 0);
  ObjectDef sheet = gridCloth(spec);
  sheet.name = "sheet";
  sheet.material.thickness = Real(0.005);
  sheet.velocity = velocity;
  return sheet;
}

// A world at 2 substeps of 2 sweeps, no gravity, with the sheet and `maxImpactTravel`.
World worldWith(const ObjectDef& sheet, Real maxImpactTravel = -1) {
  SolverSettings settings = test::solverSettings(SolverKind::GaussSeidel, 2, 2);
  settings.maxImpactTravel = maxImpactTravel;
  World world;
  world.setSolver(settings);
  world.setGravity(Vec3::Zero());
  world.addCloth(sheet);
  return world;
}

TEST(ImpactTravel, MedianEdgeLengthIsTheGridSpacingAndNoneForAColliderOrAPointCloud) {
  World world = worldWith(sheetAt(1, Vec3::Zero()));
  world.addCollider(test::verticalPanel(Vec3(5, 1, 0)));
  ObjectDef cloud;
  cloud.vertices = {Vec3(9, 1, 0), Vec3(9, 2, 0)};
  world.addParticles(cloud);
  world.step(kStep);
  const std::vector<double>& lengths = world.impl().state.objectEdgeLength;
  ASSERT_EQ(lengths.size(), 3u);
  // 220 edges of 0.1 m against 100 diagonals: the median is the spacing (to float rounding).
  EXPECT_NEAR(lengths[0], 0.1, 1e-6);
  EXPECT_EQ(lengths[1], 0.0);
  EXPECT_EQ(lengths[2], 0.0);
}

// Falling at 30 m/s the sheet goes 0.5 m in a step of 1/60 s: 3.33 of its limits of 1.5 × 0.1 m,
// so a step near the ground takes 4 substeps; 5 with a limit of 0.1 m set by hand.
TEST(ImpactSubsteps, AFastSheetNearTheGroundTakesWhatItsTravelNeeds) {
  World world = worldWith(sheetAt(Real(0.4), Vec3(0, -30, 0)));
  world.setGround(GroundPlane{true, 0, Real(0.005)});
  const WorldState& s = world.impl().state;
  ImpactTravelScratch scratch;
  EXPECT_NEAR(impactTravelRatio(s.objects, medianEdgeLengths(s.objects, s.particles), s.particles,
                                s.colliders, -1, kImpactTravelShare, kStep, 0, 0, scratch),
              0.5 / 0.15, 1e-4);
  // Below the caller's floor a ratio is not computed: the floor comes back.
  EXPECT_EQ(impactTravelRatio(s.objects, medianEdgeLengths(s.objects, s.particles), s.particles,
                              s.colliders, -1, kImpactTravelShare, kStep, 0, 5, scratch),
            5.0);
  world.step(kStep);
  EXPECT_EQ(world.profile().substeps, 4u);
  EXPECT_EQ(world.collisionReport().raisedSubstepSteps, 1u);
  EXPECT_EQ(world.collisionReport().impactRaisedSteps, 1u);
  EXPECT_EQ(world.collisionReport().mostSubsteps, 4u);

  World byHand = worldWith(sheetAt(Real(0.4), Vec3(0, -30, 0)), Real(0.1));
  byHand.setGround(GroundPlane{true, 0, Real(0.005)});
  byHand.step(kStep);
  EXPECT_EQ(byHand.profile().substeps, 5u);
}

TEST(ImpactSubsteps, StayAsSetWithNothingNearOrWhenOff) {
  // 5 m above the ground, 0.5 m a step: a free fall with nothing to strike this step.
  World high = worldWith(sheetAt(5, Vec3(0, -30, 0)));
  high.setGround(GroundPlane{true, 0, Real(0.005)});
  high.step(kStep);
  EXPECT_EQ(high.profile().substeps, 2u);
  EXPECT_EQ(high.collisionReport().raisedSubstepSteps, 0u);
  // Near, but moving away from nothing faster than its limit allows: 6 m/s is 0.1 m a step.
  World slow = worldWith(sheetAt(Real(0.05), Vec3(0, -6, 0)));
  slow.setGround(GroundPlane{true, 0, Real(0.005)});
  slow.step(kStep);
  EXPECT_EQ(slow.profile().substeps, 2u);
  // Off.
  World off = worldWith(sheetAt(Real(0.4), Vec3(0, -30, 0)), 0);
  off.setGround(GroundPlane{true, 0, Real(0.005)});
  off.step(kStep);
  EXPECT_EQ(off.profile().substeps, 2u);
  EXPECT_EQ(off.collisionReport().impactRaisedSteps, 0u);
}

// One corner within reach of a collider brings in the whole sheet: the stretch comes from the
// rest of it going on while a collider holds part of it. A sphere of 5 cm under the corner at
// (0.5, 0, 0.5), and the same sphere 2 m to the side; a mesh panel likewise, through its box.
TEST(ImpactSubsteps, ACornerNearAColliderBringsInTheWholeObject) {
  const ObjectDef sheet = sheetAt(Real(0.4), Vec3(0, -30, 0));
  World nearSphere = worldWith(sheet);
  nearSphere.addSphereCollider(SphereCollider{Vec3(Real(0.5), 0, Real(0.5)), Real(0.05)});
  nearSphere.step(kStep);
  EXPECT_EQ(nearSphere.profile().substeps, 4u);

  World farSphere = worldWith(sheet);
  farSphere.addSphereCollider(SphereCollider{Vec3(Real(2.5), 0, Real(0.5)), Real(0.05)});
  farSphere.step(kStep);
  EXPECT_EQ(farSphere.profile().substeps, 2u);

  // A vertical panel 1 m square whose top edge is at 0.1 m, beside the sheet's corner.
  World nearPanel = worldWith(sheet);
  nearPanel.addCollider(test::verticalPanel(Vec3(Real(0.9), Real(-0.4), Real(0.5))));
  nearPanel.step(kStep);
  EXPECT_EQ(nearPanel.profile().substeps, 4u);

  World farPanel = worldWith(sheet);
  farPanel.addCollider(test::verticalPanel(Vec3(Real(3), Real(-0.4), Real(0.5))));
  farPanel.step(kStep);
  EXPECT_EQ(farPanel.profile().substeps, 2u);
}

// The median, not the fastest: the sheet resting on a small sphere under one corner (9 mm
// below the corner's surface, within the 10 mm of the two thicknesses), with its particles
// moving at 30 m/s from the far side up to the one before the middle (60 of 121), then up to
// the middle one (61: the median's). Only the second raises the substeps; whipping corners do
// not stretch the edges between them.
TEST(ImpactSubsteps, TheBulkOfTheObjectCountsNotItsFastestParticles) {
  for (const std::size_t fast : {std::size_t{60}, std::size_t{61}}) {
    World world = worldWith(sheetAt(Real(0.4), Vec3::Zero()));
    const Vec3 centre(Real(0.5), Real(0.4 - 0.05 - 0.009), Real(0.5));
    world.addSphereCollider(SphereCollider{centre, Real(0.05)});
    WorldState& s = world.impl().state;
    std::vector<std::size_t> order(s.particles.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return (s.particles.x[a] - centre).norm() > (s.particles.x[b] - centre).norm();
    });
    for (std::size_t k = 0; k < fast; ++k) s.particles.v[order[k]] = Vec3(0, -30, 0);
    world.step(kStep);
    EXPECT_EQ(world.profile().substeps, fast == 61 ? 4u : 2u) << fast << " fast particles";
  }
}

// After a strike the count is held while the world stays stretched, for at most
// kImpactHoldSteps steps after the last raise for travel. The sheet of the first test strikes
// the ground (4 substeps); with an edge at its corner held at 1.5 times its length from the start
// (both ends pinned), the world stays stretched beyond kImpactHoldStrain: the next
// kImpactHoldSteps steps hold 4 substeps and the one after takes the setting again. Without the
// held edge nothing is held.
TEST(ImpactSubsteps, AStrikeStillStretchedHoldsItsCountForABoundedTime) {
  for (const bool stretched : {true, false}) {
    ObjectDef sheet = sheetAt(Real(0.4), Vec3(0, -30, 0));
    World world = worldWith(sheet);
    world.setGround(GroundPlane{true, 0, Real(0.005)});
    WorldState& s = world.impl().state;
    if (stretched) {
      // Corner 0 and its neighbour 1 along x, 0.1 m apart, held 0.15 m apart: strain 0.5.
      s.particles.x[1] = s.particles.x[0] + Vec3(Real(0.15), 0, 0);
      for (const Index i : {Index{0}, Index{1}})
        s.particles.v[i] = Vec3::Zero(), s.particles.w[i] = 0;
    }
    world.step(kStep);
    ASSERT_EQ(world.profile().substeps, 4u);
    std::uint64_t before = world.profile().substeps;
    for (int k = 0; k < kImpactHoldSteps + 1; ++k) {
      world.step(kStep);
      const std::uint64_t taken = world.profile().substeps - before;
      before = world.profile().substeps;
      EXPECT_EQ(taken, stretched && k < kImpactHoldSteps ? 4u : 2u)
          << (stretched ? "stretched" : "relaxed") << ", step " << k + 2 << " strain "
          << measureStrain(s.constraints.stretch, s.particles.x).max << " hold "
          << s.impactHold.substeps << " left " << s.impactHold.stepsLeft;
    }
    EXPECT_EQ(world.collisionReport().impactHeldSteps,
              stretched ? std::uint64_t(kImpactHoldSteps) : 0u);
  }
}

TEST(ImpactSubsteps, NonFiniteVelocitiesRaiseNothing) {
  World world = worldWith(sheetAt(Real(0.4), Vec3::Zero()));
  world.setGround(GroundPlane{true, 0, Real(0.005)});
  world.step(kStep);
  WorldState& s = world.impl().state;
  s.particles.v[3] = Vec3::Constant(std::numeric_limits<Real>::quiet_NaN());
  s.particles.v[4] = Vec3::Constant(std::numeric_limits<Real>::infinity());
  ImpactTravelScratch scratch;
  EXPECT_EQ(impactTravelRatio(s.objects, s.objectEdgeLength, s.particles, s.colliders, -1,
                              kImpactTravelShare, kStep, 0, 0, scratch),
            0.0);
}

TEST(ImpactSubsteps, BadSettingsAreRejectedWithAClearMessage) {
  World world;
  SolverSettings settings;
  settings.maxImpactTravel = std::numeric_limits<Real>::quiet_NaN();
  EXPECT_THROW(world.setSolver(settings), std::invalid_argument);
  settings.maxImpactTravel = std::numeric_limits<Real>::infinity();
  EXPECT_THROW(world.setSolver(settings), std::invalid_argument);
  EXPECT_NE(test::sceneError(R"({"solver": {"max_impact_travel": -0.5},
      "objects": [{"type": "particles", "shape": {"points": [[0, 0, 0]]}}]})"),
            "");
  EXPECT_NE(test::sceneError(R"({"solver": {"max_impact_travel": "far"},
      "objects": [{"type": "particles", "shape": {"points": [[0, 0, 0]]}}]})"),
            "");
  EXPECT_EQ(test::sceneError(R"({"solver": {"max_impact_travel": 0.02},
      "objects": [{"type": "particles", "shape": {"points": [[0, 0, 0]]}}]})"),
            "");
}

}  // namespace
}  // namespace nucleon
