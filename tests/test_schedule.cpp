// Schedules: the sweep plan interleaves families evenly in the given order, per-object schedules
// restrict sweeps to their objects, and bad schedules are rejected.
#include <gtest/gtest.h>

#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"
#include "systems/setup/sweep_schedule.h"

using namespace nucleon;

namespace {
std::string sequence(const SweepPlan& plan) {
  std::string out;
  for (const SweepOp& op : plan.ops)  // s, h (shear), b, t, v, p, a, r
    out += op.family == ConstraintFamily::Shear    ? 'h'
           : op.family == ConstraintFamily::Tether ? 'T'
                                                   : toString(op.family)[0];
  return out;
}

Schedule schedule(std::initializer_list<std::pair<ConstraintFamily, int>> entries) {
  Schedule s;
  for (auto [f, n] : entries) s.push_back({f, n});
  return s;
}
}  // namespace

TEST(SweepPlan, DefaultGivesEveryFamilyTheIterationCountInTheDefaultOrder) {
  SolverSettings solver;
  solver.iterations = 2;
  const SweepPlan plan = planSweeps(solver, {});
  // stretch, tether, shear, bend, twist, volume, pressure, attachment, rigidity, density, twice
  EXPECT_EQ(sequence(plan), "sThbtvpardsThbtvpard");
  EXPECT_EQ(plan.rounds, 2);
}

TEST(SweepPlan, FamiliesInterleaveEvenlyInTheGivenOrder) {
  SolverSettings solver;
  solver.schedule = schedule({{ConstraintFamily::Bend, 2}, {ConstraintFamily::Stretch, 4}});
  const SweepPlan plan = planSweeps(solver, {});
  // Four rounds; bend runs in rounds 1 and 3, before stretch as the list says.
  EXPECT_EQ(sequence(plan), "sbssbs");
  EXPECT_EQ(plan.sweepsOfFamily[static_cast<int>(ConstraintFamily::Stretch)], 4);
  EXPECT_EQ(plan.sweepsOfFamily[static_cast<int>(ConstraintFamily::Bend)], 2);

  // The original's "battle of the constraints" counts: every family gets exactly its count and
  // no family runs twice in a row while another still has sweeps to place.
  solver.schedule = schedule(
      {{ConstraintFamily::Stretch, 26}, {ConstraintFamily::Shear, 7}, {ConstraintFamily::Bend, 9}});
  const SweepPlan battle = planSweeps(solver, {});
  EXPECT_EQ(battle.rounds, 26);
  EXPECT_EQ(battle.ops.size(), 26u + 7u + 9u);
  const std::string s = sequence(battle);
  EXPECT_EQ(std::count(s.begin(), s.end(), 'b'), 9);
  EXPECT_EQ(s.find("bb"), std::string::npos);
  EXPECT_EQ(std::count(s.begin(), s.end(), 'h'), 7);
  EXPECT_EQ(s.find("hh"), std::string::npos);
  EXPECT_EQ(s.find("ssss"), std::string::npos);  // bend and shear are spread out, not bunched
}

TEST(SweepPlan, PerObjectSchedulesRestrictSweepsToTheirObjects) {
  std::vector<ObjectRecord> objects(2);
  objects[1].schedule = schedule({{ConstraintFamily::Stretch, 4}});
  SolverSettings solver;
  solver.schedule = schedule({{ConstraintFamily::Stretch, 2}});
  const SweepPlan plan = planSweeps(solver, objects);
  ASSERT_EQ(plan.rounds, 4);
  ASSERT_EQ(plan.ops.size(), 4u);
  int both = 0, onlySecond = 0;
  for (const SweepOp& op : plan.ops) {
    if (op.objectRunsOffset < 0) {
      ++both;
    } else {
      EXPECT_EQ(plan.objectRuns[op.objectRunsOffset], 0);
      EXPECT_EQ(plan.objectRuns[op.objectRunsOffset + 1], 1);
      ++onlySecond;
    }
  }
  EXPECT_EQ(both, 2);
  EXPECT_EQ(onlySecond, 2);
}

TEST(SweepPlan, RescalingKeepsProportions) {
  const Schedule s = rescaleSchedule(schedule({{ConstraintFamily::Stretch, 26},
                                               {ConstraintFamily::Shear, 7},
                                               {ConstraintFamily::Bend, 9},
                                               {ConstraintFamily::Twist, 0}}),
                                     13);
  EXPECT_EQ(s[0].sweeps, 13);
  EXPECT_EQ(s[1].sweeps, 4);                      // 3.5 rounds up
  EXPECT_EQ(s[2].sweeps, 5);                      // 4.5 rounds up
  EXPECT_EQ(s[3].sweeps, 0);                      // a family that was off stays off
  EXPECT_EQ(rescaleSchedule(s, 1)[1].sweeps, 1);  // a family that was on stays on
}

TEST(SweepPlan, BadSchedulesAreRejected) {
  World world;
  SolverSettings solver;
  solver.schedule = schedule({{ConstraintFamily::Stretch, 2}, {ConstraintFamily::Stretch, 3}});
  EXPECT_THROW(world.setSolver(solver), std::invalid_argument);
  solver.schedule = schedule({{ConstraintFamily::Stretch, -1}});
  EXPECT_THROW(world.setSolver(solver), std::invalid_argument);
  ObjectDef rope = polylineRope(Vec3(0, 1, 0), Vec3(1, 1, 0), 4);
  rope.schedule = schedule({{ConstraintFamily::Bend, 1}, {ConstraintFamily::Bend, 1}});
  EXPECT_THROW(world.addRope(rope), std::invalid_argument);
  EXPECT_EQ(world.objectCount(), 0u);
}

// Two identical pendulum ropes; the second's schedule gives stretch no sweeps, so its free end
// falls freely (symplectic Euler: y_n = y_0 − g h² n(n+1)/2) while the first keeps its length.
TEST(Schedule, AnObjectWithoutStretchSweepsFallsFreelyWhileTheOtherHolds) {
  World world;
  for (int i = 0; i < 2; ++i) {
    ObjectDef rope = polylineRope(Vec3(Real(i), 1, 0), Vec3(Real(i) + 1, 1, 0), 1);
    rope.pins = {0};
    if (i == 1) rope.schedule = schedule({{ConstraintFamily::Stretch, 0}});
    world.addRope(rope);
  }
  // The ropes touch where one ends and the other starts; this is about schedules, not contact.
  world.excludeCollisions(world.objectAt(0), world.objectAt(1));
  const int steps = 30;
  const double h = 1.0 / 60;
  test::simulate(world, steps, h);
  const auto held = world.positions(world.objectAt(0));
  const auto loose = world.positions(world.objectAt(1));
  EXPECT_NEAR((held[1] - held[0]).norm(), 1, 1e-4);
  EXPECT_NEAR(loose[1].y(), 1 - 9.81 * h * h * steps * (steps + 1) / 2, 1e-4);
  EXPECT_NEAR(loose[1].x(), 2, 1e-6);
}

TEST(Schedule, ScenesReadSchedulesAndRejectBadOnes) {
  const std::string good = R"({"solver": {"schedule": [{"family": "stretch", "sweeps": 26},
      {"family": "bend", "sweeps": 9}]},
    "objects": [{"type": "rope", "shape": {"polyline": {"points": [[0,0,0],[1,0,0]]}},
                 "schedule": [{"family": "stretch", "sweeps": 3}]}]})";
  const Scene scene = parseScene(good, "good.json", ".");
  ASSERT_EQ(scene.solver.schedule.size(), 2u);
  EXPECT_EQ(scene.solver.schedule[1].family, ConstraintFamily::Bend);
  EXPECT_EQ(scene.solver.schedule[1].sweeps, 9);
  EXPECT_EQ(scene.solver.iterations, 26);  // the rounds of the schedule
  ASSERT_EQ(scene.objects[0].def.schedule.size(), 1u);

  auto errorOf = [](const std::string& solver) {
    try {
      parseScene(R"({"solver": )" + solver +
                     R"(, "objects": [{"type": "particles", "shape": {"points": [[0,0,0]]}}]})",
                 "bad.json", ".");
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(errorOf(R"({"schedule": [{"family": "glue", "sweeps": 2}]})")
                .find("solver.schedule[0].family: expected stretch"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"schedule": [{"family": "bend", "sweeps": 2}, {"family": "bend",
      "sweeps": 1}]})")
                .find("'bend' repeats"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"schedule": [{"family": "bend"}]})").find("missing 'sweeps'"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"iterations": 4, "schedule": []})").find("not both"), std::string::npos);
}
