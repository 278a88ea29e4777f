// The torture scenes (assets/scenes/torture/): cloth on sharp colliders that turn, slide and spin,
// stacks of cloth folding over a box's edges, a tube wrung by its end rings, each at its own
// default settings. Every frame of every one must be clean: no intersecting triangles, no edge
// at 3 times its rest length, no particle behind a collider's surface, no crossing left, no
// repair, no NaN.
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "scene_run.h"
#include "sim_test_context.h"

namespace nucleon {
namespace {

class EveryTortureScene : public testing::TestWithParam<std::string> {};

// The frames a run gets in this build: the float build runs `release`, the double build
// `doublePrecision`, the sanitizer build (which looks for memory and undefined-behaviour errors
// only) `sanitizer`.
std::string framesOfThisBuild([[maybe_unused]] int release, [[maybe_unused]] int doublePrecision,
                              [[maybe_unused]] int sanitizer) {
#if defined(__SANITIZE_ADDRESS__)
  return std::to_string(sanitizer);
#elif defined(NUCLEON_DOUBLE)
  return std::to_string(doublePrecision);
#else
  return std::to_string(release);
#endif
}

// What every frame of a clean run must show: no intersecting triangles, no edge at 3 times its
// rest length, no particle behind a collider's surface, no crossing left, no repair, no NaN.
void expectCleanInEveryFrame(const test::SceneRun& run) {
  const nlohmann::json& j = run.stats;
  const nlohmann::json& failures = j.at("failures");
  EXPECT_EQ(failures.at("frames_with_intersections").get<long long>(), 0);
  EXPECT_EQ(failures.at("overstretched_frames").get<long long>(), 0);
  EXPECT_EQ(failures.at("frames_inside_colliders").get<long long>(), 0);
  EXPECT_EQ(failures.at("unresolved_crossing_pairs").get<long long>(), 0);
  EXPECT_EQ(j.at("recoveries").get<long long>(), 0) << j.at("recoveries_by_kind").dump();
  EXPECT_EQ(j.at("nan_count").get<long long>(), 0);
  EXPECT_TRUE(failures.at("clean").get<bool>()) << run.summary;
}

TEST_P(EveryTortureScene, IsCleanInEveryFrame) {
  std::vector<std::string> args;
#if defined(__SANITIZE_ADDRESS__)
  // The sanitizer build looks for memory and undefined-behaviour errors: the first half second
  // takes every scene through its first contacts with the colliders, the ground and itself.
  args = {"--frames", GetParam() == "liquid_paddle" ? "10" : "30"};
#endif
  const test::SceneRun run = test::runScene(
      std::string(NUCLEON_ASSETS_DIR) + "/scenes/torture/" + GetParam() + ".json", args);
  const nlohmann::json& j = run.stats;
  ASSERT_FALSE(j.is_null());
  expectCleanInEveryFrame(run);
  EXPECT_TRUE(j.at("warnings").empty()) << j.at("warnings").dump();
  const nlohmann::json& failures = j.at("failures");
  // The not-clean threshold is an edge at 3 times its rest length. The worst frames measured
  // here are impacts at 2 substeps (a sheet dropped on a needle or a box's corners, a sheet's
  // halves striking the ground edge first at 3 m/s), where an edge reaches up to 2.6 times its
  // rest length for a frame or two (bench/results/2core-AMD-EPYC/torture.md): 2.75 times flags a
  // regression well before the threshold.
  EXPECT_LT(failures.at("worst_frame_max_strain").get<double>(), 1.75);
  // And it settles: the last frame's edges are within 2 times their rest length. (Not in the
  // sanitizer build, whose half second can end in the middle of an impact.)
#if !defined(__SANITIZE_ADDRESS__)
  EXPECT_LT(j.at("max_strain").get<double>(), 1.0);
#endif
}

// The sheet dropped on a box's corners (box_static) made of cloth that buckles freely: a hard
// stretch compliance and a compression compliance of 1000 m/N. Every frame stays clean, and no
// edge is ever stretched beyond the suite's bound of 2.75 times its length (measured: 1.92 times
// in the worst frame, in the float and the double build). When the projections took the compliance
// by the sign of C alone, edges carrying tension that a sweep took just below rest were thrown back
// out: this run had 50 frames with an edge beyond 3 times its length, the worst at 10.7 times
// (the other torture scenes' sheets likewise, up to 13.8 times;
// bench/results/2core-AMD-EPYC/solver_speed.md §20). Compression is what the cloth is free to
// do here, so only stretch is bounded (the per-frame max_stretch): edges shorten to half their
// length where the sheet gathers.
TEST(BucklingClothTortureScene, BoxStaticIsCleanInEveryFrame) {
  std::vector<std::string> args = {"--set", "objects.1.material.compression_compliance=1000"};
#if defined(__SANITIZE_ADDRESS__)
  args.insert(args.end(), {"--frames", "30"});
#endif
  const test::SceneRun run =
      test::runScene(std::string(NUCLEON_ASSETS_DIR) + "/scenes/torture/box_static.json", args);
  const nlohmann::json& j = run.stats;
  ASSERT_FALSE(j.is_null());
  expectCleanInEveryFrame(run);
  double worstStretch = 0;
  for (const nlohmann::json& frame : j.at("per_frame"))
    worstStretch = std::max(worstStretch, frame.at("max_stretch").get<double>());
  EXPECT_LT(worstStretch, 1.75);
}

// The torture scenes at a substep count other than theirs: wall_slam at 3 instead of 2. Its sheet
// lies crumpled against the wall and on the ground, and the impact zones there would dip into the
// ground when turned: stopped where the substep began, the same zones stopped substep after
// substep, and the edges from them to the sheet around stayed at up to 4.45 times their rest
// length from frame 21 to the end (63 frames not clean). A zone now takes the largest of its whole
// rigid motion, a half, a quarter, … of it that keeps out of the ground. The float build runs the
// whole scene, the double build the first 45 frames, the sanitizer build 30 (memory and
// undefined-behaviour errors only).
TEST(OtherSubsteps, WallSlamAtThreeSubstepsIsCleanInEveryFrame) {
  const std::vector<std::string> args = {"--substeps", "3", "--frames",
                                         framesOfThisBuild(90, 45, 30)};
  const test::SceneRun run =
      test::runScene(std::string(NUCLEON_ASSETS_DIR) + "/scenes/torture/wall_slam.json", args);
  ASSERT_FALSE(run.stats.is_null());
  expectCleanInEveryFrame(run);
  EXPECT_LT(run.stats.at("failures").at("worst_frame_max_strain").get<double>(), 1.75);
}

// flag_whip under the Gauss–Seidel backends instead of the scene's multigrid: the pinned top row,
// whipped at 4 m/s, sweeps through the folds of the flag just below it. A crossing pair of free
// particles and pinned ones that move was held in an impact zone, and a zone that stops where the
// substep began cannot clear it: the pinned row moved on through the stopped particles. Plain
// Gauss–Seidel (the library's default backend) left 3 pairs unresolved from frame 17 on, the flag
// intersected itself from frame 62 and its edges reached 20 times their rest length; colored
// Gauss–Seidel 125 pairs, 90 frames with intersections, 11 times. Once the zones stop, such pairs
// are carried with the pinned row's rigid motion: neither backend leaves a pair unresolved or a
// frame with intersecting triangles. Colored Gauss–Seidel runs clean, its worst frame at strain
// 1.10 over the whole run (float build). Plain Gauss–Seidel has one frame with an edge beyond 3
// times its rest length (strain 2.23 in frame 15, as the row first reverses: its ten sweeps in
// order carry the pull across the flag more slowly than colored ones); bounded at strain 3, 4 times
// the rest length. The float build runs the 90 frames of the whipping, the double build 40, the
// sanitizer build 30 (both failures show by frame 30).
class FlagWhipUnderGaussSeidel : public testing::TestWithParam<std::string> {};

TEST_P(FlagWhipUnderGaussSeidel, NeverIntersectsItself) {
  const test::SceneRun run =
      test::runScene(std::string(NUCLEON_ASSETS_DIR) + "/scenes/torture/flag_whip.json",
                     {"--solver", GetParam(), "--frames", framesOfThisBuild(90, 40, 30)});
  const nlohmann::json& j = run.stats;
  ASSERT_FALSE(j.is_null());
  const nlohmann::json& failures = j.at("failures");
  EXPECT_EQ(failures.at("frames_with_intersections").get<long long>(), 0);
  EXPECT_EQ(failures.at("unresolved_crossing_pairs").get<long long>(), 0);
  EXPECT_EQ(failures.at("frames_inside_colliders").get<long long>(), 0);
  EXPECT_EQ(j.at("recoveries").get<long long>(), 0);
  EXPECT_EQ(j.at("nan_count").get<long long>(), 0);
  if (GetParam() == "colored-gs") {
    expectCleanInEveryFrame(run);
    EXPECT_LT(failures.at("worst_frame_max_strain").get<double>(), 1.75);
  } else {
    EXPECT_LT(failures.at("worst_frame_max_strain").get<double>(), 3.0);
  }
}

INSTANTIATE_TEST_SUITE_P(TortureScenes, FlagWhipUnderGaussSeidel,
                         testing::Values("gauss-seidel", "colored-gs"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param == "gauss-seidel" ? std::string("plain")
                                                               : std::string("colored");
                         });

// curtain_ball under plain Gauss–Seidel: the ball pushes into the curtain, which wraps its front.
// Projected one after another, each cloth particle's contacts with the ball's triangles and
// edges, and their friction, left the patch on the ball's front crumpled, its edges stretched
// from frame 24 on: 31 frames with an edge beyond 3 times its rest length, the worst 6.1 times
// (strain 5.14), where colored Gauss–Seidel's worst frame has strain 0.51. Contacts against a
// body (a collider, a pinned group) are now projected under Gauss–Seidel as under the parallel
// backends, each step from the same positions and a particle moved by the mean of its pressed
// ones: the whole run is clean, its worst frame at strain 0.74 (float build). The float build
// runs the push and the start of the return (45 frames), the double build 40, the sanitizer
// build 30 (the first frame beyond 3 times was frame 30).
TEST(PlainGaussSeidel, CurtainPushedByABallIsCleanInEveryFrame) {
  const test::SceneRun run =
      test::runScene(std::string(NUCLEON_ASSETS_DIR) + "/scenes/torture/curtain_ball.json",
                     {"--solver", "gauss-seidel", "--frames", framesOfThisBuild(45, 40, 30)});
  ASSERT_FALSE(run.stats.is_null());
  expectCleanInEveryFrame(run);
  EXPECT_LT(run.stats.at("failures").at("worst_frame_max_strain").get<double>(), 1.75);
}

// The cases not clean yet (torture/unsolved/), at their default settings, still never crash,
// repair, produce NaN or end a frame with a particle inside the ground; what is not solved is
// theirs to show: intersecting triangles (a cloth wrung between two rollers, from frame 42 on).
// The float build runs the first 40 frames, the double build 15, the sanitizer build 4 (memory
// and undefined-behaviour errors only).
TEST(UnsolvedTortureScenes, NeverCrashRepairOrGoNonFinite) {
  const std::string frames = framesOfThisBuild(40, 15, 4);
  const std::filesystem::path folder =
      std::filesystem::path(NUCLEON_ASSETS_DIR) / "scenes" / "torture" / "unsolved";
  const std::vector<std::string> names = test::sceneNamesIn("torture/unsolved");
  ASSERT_FALSE(names.empty()) << "no scene in " << folder;
  for (const std::string& name : names) {
    const std::vector<std::string> args = {"--frames", frames};
    const nlohmann::json j = test::runScene((folder / (name + ".json")).string(), args).stats;
    ASSERT_FALSE(j.is_null()) << name;
    EXPECT_EQ(j.at("failures").at("frames_inside_colliders").get<long long>(), 0) << name;
    EXPECT_EQ(j.at("recoveries").get<long long>(), 0) << name;
    EXPECT_EQ(j.at("nan_count").get<long long>(), 0) << name;
  }
}

// The 128² drape on a turning box's corners (torture/large/), at its defaults: the skirt hangs
// from the few particles the corners hold, and the supported particles weighed
// (solver.supported_inverse_mass_scale, default 0.1) carry its weight up to them. Its first 40
// frames, the skirt's fall over the corners and the corner's strike on the ground among them,
// stay clean, within the suite's bound of 1.75 (with the weighing off, frame 19 has an edge at
// 3.02 times its rest length). Measured worst frame over the whole run (scripts/torture.sh):
// 1.345 (float). The double build runs 15 frames, the sanitizer build 4.
TEST(LargeTortureScenes, TheFineDrapeOnABoxsCornersIsClean) {
  const test::SceneRun run = test::runScene(
      std::string(NUCLEON_ASSETS_DIR) + "/scenes/torture/large/box_turntable_128.json",
      {"--frames", framesOfThisBuild(40, 15, 4)});
  const nlohmann::json& j = run.stats;
  ASSERT_FALSE(j.is_null());
  expectCleanInEveryFrame(run);
  EXPECT_LT(j.at("failures").at("worst_frame_max_strain").get<double>(), 1.75);
#if !defined(__SANITIZE_ADDRESS__)
  // The sheet reaches the box in frame 8: the sanitizer build's 4 frames end before it.
  EXPECT_GT(j.at("collisions").at("supported_particles").get<long long>(), 0);
#endif
}

// The 128² drape's cloth is finer than its contact distance: the run says so before it starts
// (World::warnings), naming the cloth; the same sheet at 64² (box_turntable) has no warning.
TEST(LargeTortureScenes, TheFineDrapeIsWarnedOf) {
  const nlohmann::json j = test::runScene(std::string(NUCLEON_ASSETS_DIR) +
                                              "/scenes/torture/large/box_turntable_128.json",
                                          {"--frames", "1"})
                               .stats;
  ASSERT_FALSE(j.is_null());
  ASSERT_EQ(j.at("warnings").size(), 1u);
  const std::string line = j.at("warnings")[0].get<std::string>();
  EXPECT_EQ(line.rfind("sheet: contact distance 10 mm exceeds the median edge length 9.45 mm", 0),
            0u)
      << line;
}

// The propeller at a fixed 4 substeps (no substeps added for its blade, which moves 18 mm per
// substep there): the fail-safe carries thousands of particles round with the blade and makes
// impact zones whose roots it later carries too. A zone root without a slot once crashed it in
// frames 90–120 (moveImpactZones read another zone's slot or one past the end); it must run
// through without a crash, repair, NaN, intersection or particle inside the ground. The float
// build runs 120 frames, the double build 60, the sanitizer build 30.
TEST(PropellerWithoutRaisedSubsteps, NeverCrashesRepairsOrIntersects) {
  const std::string frames = framesOfThisBuild(120, 60, 30);
  const std::vector<std::string> args = {
      "--substeps", "4",   "--max-kinematic-travel", "0", "--max-impact-travel", "0",
      "--frames",   frames};
  const nlohmann::json j =
      test::runScene(std::string(NUCLEON_ASSETS_DIR) + "/scenes/torture/propeller.json", args)
          .stats;
  ASSERT_FALSE(j.is_null());
  EXPECT_EQ(j.at("collisions").at("raised_substep_steps").get<long long>(), 0);
  const nlohmann::json& failures = j.at("failures");
  EXPECT_EQ(failures.at("frames_with_intersections").get<long long>(), 0);
  EXPECT_EQ(failures.at("frames_inside_colliders").get<long long>(), 0);
  EXPECT_EQ(j.at("recoveries").get<long long>(), 0);
  EXPECT_EQ(j.at("nan_count").get<long long>(), 0);
}

// The scene a user writes first: a sheet dropped on a ball with no solver and no thickness
// named (tests/data/sheet_on_ball_defaults.json: 64², 10 mm edges under the default 10 mm
// thickness). It runs the scene files' defaults, multigrid at two substeps, and stays whole in
// every frame: no edge at 3 times its length, no intersection, no repair. (Under one substep of
// the serial Gauss–Seidel sweep, the default before, 42 of its 60 frames had an edge beyond 3
// times its length, the worst at 8.1 times, with 2 recoveries; under one of multigrid the worst
// frame is at 2.87 times, under two at 1.85: bench/results/2core-AMD-EPYC/torture.md.) The
// contact distance exceeds the edge length, and the run says so. The float build runs its 60
// frames, the double build 30, the sanitizer build 10.
TEST(SceneDefaults, ASheetLeftAtEveryDefaultStaysWholeOnABall) {
  const std::vector<std::string> args = {"--frames", framesOfThisBuild(60, 30, 10)};
  const test::SceneRun run =
      test::runScene(std::string(NUCLEON_TEST_DATA) + "/sheet_on_ball_defaults.json", args);
  const nlohmann::json& j = run.stats;
  ASSERT_FALSE(j.is_null());
  EXPECT_EQ(j.at("solver").get<std::string>(), "multigrid");
  expectCleanInEveryFrame(run);
  EXPECT_EQ(j.at("warnings").size(), 1u) << j.at("warnings").dump();
}

INSTANTIATE_TEST_SUITE_P(TortureScenes, EveryTortureScene,
                         testing::ValuesIn(test::sceneNamesIn("torture")),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;  // scene names are identifiers: [a-z0-9_]
                         });

}  // namespace
}  // namespace nucleon
