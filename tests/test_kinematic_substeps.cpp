// Substeps raised for fast animation (SolverSettings::maxKinematicTravel): how far an animated
// collider or pin group travels over a step (the arc of a turn, the line to a target), how many
// substeps that asks for, and a world that takes them, counts them and leaves slow scenes as they
// were.
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"
#include "systems/dynamics/kinematic_motion.h"

namespace nucleon {
namespace {

constexpr double kPi = std::numbers::pi;

// A 4×4 panel, vertical in the xy plane, its far edge `reach` m from the vertical axis through
// the pivot (0, 1, 0), turning `turns` times about that axis per second from t = 0 to t = 1.
ObjectDef spinningPanel(double reach, double turns) {
  ObjectDef def = test::verticalPanel(Vec3(Real(reach - 0.5), 1, 0));
  def.motion.pivot = Vec3d(0, 1, 0);
  // Keyframes a sixteenth of a turn apart: slerp between them is the uniform turn.
  const int keys = static_cast<int>(std::ceil(16 * turns));
  for (int k = 0; k <= keys; ++k) {
    Keyframe key;
    key.time = double(k) / keys;
    key.axis = Vec3d(0, 1, 0);
    key.angle = 2 * kPi * turns * key.time;
    def.motion.keyframes.push_back(key);
  }
  return def;
}

// A few free particles far from the panel: something that moves, so that a contact distance
// between the collider and a moving primitive exists.
ObjectDef farCloud() {
  ObjectDef cloud;
  for (int i = 0; i < 4; ++i) cloud.vertices.push_back(Vec3(Real(10 + 0.1 * i), 5, 0));
  cloud.material.thickness = Real(0.005);
  return cloud;
}

// A world at 2 substeps of 2 sweeps with a panel whose far edge is 1 m from its axis, turning
// `turns` times a second, and the far cloud unless `alone`; `maxTravel` as
// SolverSettings::maxKinematicTravel.
World spinningWorld(double turns, bool alone = false, Real maxTravel = -1) {
  SolverSettings settings = test::solverSettings(SolverKind::GaussSeidel, 2, 2);
  settings.maxKinematicTravel = maxTravel;
  World world;
  world.setSolver(settings);
  world.addCollider(spinningPanel(1.0, turns));
  if (!alone) world.addParticles(farCloud());
  return world;
}

TEST(KinematicTravel, IsTheArcOfATurnItsFarthestPointSweeps) {
  World world;
  world.addCollider(spinningPanel(1.0, 2));
  const WorldState& s = world.impl().state;
  // Over a sixtieth of a second the far edge (1 m from the axis) sweeps 2·2π/60 rad of arc: the
  // eight chords fall short of it by θ²/(24·64) of it at most (θ the step's turn, 0.21 rad),
  // under 0.01%.
  const double arc = 2 * 2 * kPi / 60;
  EXPECT_NEAR(kinematicTravel(s.kinematics, s.particles, 0.2, 0.2 + 1.0 / 60), arc, 1e-4 * arc);
  // Half a turn in one interval: the chords still give 99.4% of the arc (sinc of π/16).
  const double half = kinematicTravel(s.kinematics, s.particles, 0, 0.25);
  EXPECT_GT(half, 0.99 * kPi);
  EXPECT_LE(half, kPi * (1 + 1e-9));
}

TEST(KinematicTravel, IsTheLineToATargetAndNothingWithout) {
  World world;
  const ObjectId id = world.addCollider(test::verticalPanel(Vec3(0, 1, 0)));
  const WorldState& s = world.impl().state;
  std::vector<Vec3> goal(world.positions(id).begin(), world.positions(id).end());
  EXPECT_EQ(kinematicTravel(s.kinematics, s.particles, 0, 1.0 / 60), 0.0);
  for (Vec3& g : goal) g += Vec3(Real(0.03), 0, Real(0.04));
  world.setColliderTargets(id, goal);
  EXPECT_NEAR(kinematicTravel(s.kinematics, s.particles, 0, 1.0 / 60), 0.05, 1e-6);
}

TEST(SubstepsForTravel, RaisesToTheCeilingWithinTheMaximumAndCountsTheCap) {
  SolverSettings settings;
  settings.substeps = 2;
  bool capped = true;
  // Within the limit per substep: the setting.
  EXPECT_EQ(substepsForTravel(settings, 0.02, 0.01, capped), 2);
  EXPECT_FALSE(capped);
  EXPECT_EQ(substepsForTravel(settings, 0.0201, 0.01, capped), 3);
  EXPECT_EQ(substepsForTravel(settings, 0.1, 0.01, capped), 10);
  EXPECT_FALSE(capped);
  // The default maximum: 8 × substeps, at least 16.
  EXPECT_EQ(substepsForTravel(settings, 1.0, 0.01, capped), 16);
  EXPECT_TRUE(capped);
  settings.maxSubsteps = 40;
  EXPECT_EQ(substepsForTravel(settings, 1.0, 0.01, capped), 40);
  EXPECT_TRUE(capped);
  // Off, and a travel that is not a number: the setting, not capped.
  EXPECT_EQ(substepsForTravel(settings, 1.0, 0, capped), 2);
  EXPECT_FALSE(capped);
  EXPECT_EQ(substepsForTravel(settings, std::numeric_limits<double>::quiet_NaN(), 0.01, capped), 2);
  EXPECT_FALSE(capped);
  // A maximum below the setting never lowers it.
  settings.maxSubsteps = 1;
  EXPECT_EQ(substepsForTravel(settings, 1.0, 0.01, capped), 2);
}

// A panel whose far edge moves 1 m × 2π per second = 0.105 m per step at 60 steps per second,
// against particles of 5 mm thickness: the panel's own thickness (the default 1 cm) plus theirs
// is the contact distance, and each step takes ceil(travel / (0.75 × that)) substeps: 10.
TEST(KinematicSubsteps, AStepTakesWhatItsFastestColliderPointNeeds) {
  World world = spinningWorld(1);
  const ObjectId panel = world.objectAt(0);
  world.step(1.0 / 60);
  const WorldState& s = world.impl().state;
  const double contact = double(world.thickness(panel)) + double(Real(0.005));
  ASSERT_EQ(s.kinematicContactDistance, contact);
  const double travel = kinematicTravel(s.kinematics, s.particles, 0, 1.0 / 60);
  const auto expected = static_cast<std::uint64_t>(std::ceil(travel / (0.75 * contact)));
  ASSERT_GT(expected, 2u);
  ASSERT_LE(expected, 16u);
  EXPECT_EQ(world.profile().substeps, expected);
  EXPECT_EQ(world.collisionReport().raisedSubstepSteps, 1u);
  EXPECT_EQ(world.collisionReport().mostSubsteps, expected);
  EXPECT_EQ(world.collisionReport().cappedSubstepSteps, 0u);
  // The collider lands exactly on its track all the same: at the step's end, the pose of t = 1/60.
  std::vector<Vec3> posed(world.positions(panel).size());
  posePositions(s.kinematics.tracks[0],
                std::span<const Vec3>(s.particles.restPosition).subspan(0, posed.size()), 1.0 / 60,
                posed);
  for (std::size_t i = 0; i < posed.size(); ++i) EXPECT_EQ(world.positions(panel)[i], posed[i]);
}

TEST(KinematicSubsteps, StayAsSetWhenOffSlowOrAlone) {
  // Off: the setting.
  World off = spinningWorld(1, false, 0);
  test::simulate(off, 3, 1.0 / 60);
  EXPECT_EQ(off.profile().substeps, 6u);
  EXPECT_EQ(off.collisionReport().raisedSubstepSteps, 0u);
  // Slow: a twentieth of a turn per second moves the far edge 5 mm per step.
  World slow = spinningWorld(0.05);
  test::simulate(slow, 3, 1.0 / 60);
  EXPECT_EQ(slow.profile().substeps, 6u);
  EXPECT_EQ(slow.collisionReport().mostSubsteps, 2u);
  // A fast collider with nothing that moves: nothing to outrun.
  World alone = spinningWorld(1, true);
  test::simulate(alone, 3, 1.0 / 60);
  EXPECT_EQ(alone.profile().substeps, 6u);
  // A limit set by hand: 1 cm per substep.
  World byHand = spinningWorld(1, false, Real(0.01));
  byHand.step(1.0 / 60);
  const WorldState& s = byHand.impl().state;
  EXPECT_EQ(byHand.profile().substeps,
            static_cast<std::uint64_t>(
                std::ceil(kinematicTravel(s.kinematics, s.particles, 0, 1.0 / 60) / 0.01)));
}

// A pinned edge moved 0.1 m in a step of 1/60 s drags its self-colliding cloth: the contact
// distance is the cloth's thickness twice (its pinned primitives against its own free ones),
// 2 × 5 mm, and the step takes ceil(0.1 / 7.5 mm) = 14 substeps.
TEST(KinematicSubsteps, AFastPinGroupRaisesThemToo) {
  GridSpec spec;
  spec.resolution = {6, 6};
  spec.size = {0.5, 0.5};
  spec.center = Vec3(0, 1, 0);
  spec.vertical = true;
  ObjectDef flag = gridCloth(spec);
  flag.material.thickness = Real(0.005);
  flag.material.selfCollision = true;
  PinGroup edge;
  for (Index i = 0; i < 6; ++i) edge.vertices.push_back(i);
  Keyframe start, end;
  end.time = 1.0;
  end.translation = Vec3d(6, 0, 0);  // 0.1 m per step of 1/60 s
  edge.motion.keyframes = {start, end};
  flag.pinGroups.push_back(edge);
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 2, 2));
  world.addCloth(flag);
  world.step(1.0 / 60);
  const WorldState& s = world.impl().state;
  EXPECT_EQ(s.kinematicContactDistance, 2 * double(Real(0.005)));
  EXPECT_NEAR(kinematicTravel(s.kinematics, s.particles, 0, 1.0 / 60), 0.1, 1e-9);
  EXPECT_EQ(world.profile().substeps, 14u);
  EXPECT_EQ(world.collisionReport().raisedSubstepSteps, 1u);
}

// Colliders moved by a constant velocity or by targets count as well: a panel 0.1 m per step
// against particles of 5 mm thickness (contact distance 1 cm + 5 mm) takes ceil(0.1 / 11.25 mm)
// = 9 substeps either way.
TEST(KinematicSubsteps, AColliderMovedByVelocityOrTargetsRaisesThemToo) {
  {
    ObjectDef panel = test::verticalPanel(Vec3(0, 1, 0));
    panel.velocity = Vec3(6, 0, 0);
    World world;
    world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 2, 2));
    world.addCollider(panel);
    world.addParticles(farCloud());
    world.step(1.0 / 60);
    EXPECT_EQ(world.profile().substeps, 9u);
  }
  {
    World world;
    world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 2, 2));
    const ObjectId panel = world.addCollider(test::verticalPanel(Vec3(0, 1, 0)));
    world.addParticles(farCloud());
    world.step(1.0 / 60);  // still: the setting
    EXPECT_EQ(world.profile().substeps, 2u);
    std::vector<Vec3> goal(world.positions(panel).begin(), world.positions(panel).end());
    for (Vec3& g : goal) g += Vec3(Real(0.1), 0, 0);
    world.setColliderTargets(panel, goal);
    world.step(1.0 / 60);
    EXPECT_EQ(world.profile().substeps, 2u + 9u);
    for (std::size_t i = 0; i < goal.size(); ++i) EXPECT_EQ(world.positions(panel)[i], goal[i]);
  }
}

// A cloth finer than its contact distance is warned of, by name: 1 m at 101 vertices a side is
// 10 mm edges (the median; the diagonals are longer); 5 mm thick with self-collision is a 10 mm
// contact distance, 6 mm thick 12 mm. No warning without anything to collide with.
TEST(ClothWarnings, NameAClothFinerThanItsContactDistance) {
  const auto warningsOf = [](Real thickness, bool self) {
    GridSpec spec;
    spec.resolution = {101, 101};
    spec.size = {1, 1};
    ObjectDef cloth = gridCloth(spec);
    cloth.name = "fine";
    cloth.material.thickness = thickness;
    cloth.material.selfCollision = self;
    World world;
    world.addCloth(cloth);
    return world.warnings();
  };
  EXPECT_TRUE(warningsOf(Real(0.004), true).empty());
  const std::vector<std::string> thick = warningsOf(Real(0.006), true);
  ASSERT_EQ(thick.size(), 1u);
  EXPECT_EQ(thick[0].rfind("fine: contact distance 12 mm exceeds the median edge length 10 mm", 0),
            0u)
      << thick[0];
  EXPECT_TRUE(warningsOf(Real(0.006), false).empty());
}

TEST(KinematicSubsteps, BadSettingsAreRejectedWithAClearMessage) {
  World world;
  SolverSettings settings;
  settings.maxKinematicTravel = std::numeric_limits<Real>::quiet_NaN();
  EXPECT_THROW(world.setSolver(settings), std::invalid_argument);
  settings.maxKinematicTravel = -1;
  settings.maxSubsteps = -3;
  EXPECT_THROW(world.setSolver(settings), std::invalid_argument);
  settings.maxSubsteps = 20000;
  EXPECT_THROW(world.setSolver(settings), std::invalid_argument);
  EXPECT_NE(test::sceneError(R"({"solver": {"max_kinematic_travel": -0.5},
      "objects": [{"type": "particles", "shape": {"points": [[0, 0, 0]]}}]})"),
            "");
  EXPECT_NE(test::sceneError(R"({"solver": {"max_substeps": 1.5},
      "objects": [{"type": "particles", "shape": {"points": [[0, 0, 0]]}}]})"),
            "");
}

}  // namespace
}  // namespace nucleon
