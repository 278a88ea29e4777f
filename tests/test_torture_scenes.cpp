// The torture scenes (assets/scenes/torture/): cloth on sharp colliders that turn, slide and spin,
// stacks of cloth folding over a box's edges, a tube wrung by its end rings, each at its own
// default settings. Every frame of every one must be clean: no intersecting triangles, no edge
// at 3 times its rest length, no particle behind a collider's surface, no crossing left, no
// repair, no NaN.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/app/cli.h"

namespace nucleon {
namespace {

std::vector<std::string> tortureSceneNames() {
  std::vector<std::string> names;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(NUCLEON_ASSETS_DIR) + "/scenes/torture"))
    if (entry.path().extension() == ".json") names.push_back(entry.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

class EveryTortureScene : public testing::TestWithParam<std::string> {};

TEST_P(EveryTortureScene, IsCleanInEveryFrame) {
  const std::string scene =
      std::string(NUCLEON_ASSETS_DIR) + "/scenes/torture/" + GetParam() + ".json";
  const std::string stats =
      (std::filesystem::temp_directory_path() / ("nucleon_torture_" + GetParam() + ".json"))
          .string();
  std::ostringstream out, err;
  std::vector<std::string> args = {"run", scene, "--quiet", "--stats", stats};
#if defined(__SANITIZE_ADDRESS__)
  // The sanitizer build looks for memory and undefined-behaviour errors: the first half second
  // takes every scene through its first contacts with the colliders, the ground and itself.
  args.insert(args.end(), {"--frames", "30"});
#endif
  ASSERT_EQ(runCommandLine(args, out, err), 0) << err.str();
  std::ifstream in(stats);
  const nlohmann::json j = nlohmann::json::parse(in);
  in.close();
  std::filesystem::remove(stats);
  const nlohmann::json& failures = j.at("failures");
  EXPECT_EQ(failures.at("frames_with_intersections").get<long long>(), 0);
  EXPECT_EQ(failures.at("overstretched_frames").get<long long>(), 0);
  EXPECT_EQ(failures.at("frames_inside_colliders").get<long long>(), 0);
  EXPECT_EQ(failures.at("unresolved_crossing_pairs").get<long long>(), 0);
  EXPECT_EQ(j.at("recoveries").get<long long>(), 0) << j.at("recoveries_by_kind").dump();
  EXPECT_EQ(j.at("nan_count").get<long long>(), 0);
  EXPECT_TRUE(failures.at("clean").get<bool>()) << out.str();
  // The not-clean threshold is an edge at 3 times its rest length. The worst frames measured
  // here are impacts at 2 substeps (a sheet dropped on a box's corners, a sheet's halves striking
  // the ground edge first at 3 m/s), where an edge reaches up to 2.5 times its rest length for a
  // frame or two (bench/results/2core-AMD-EPYC/torture.md): 2.75 times flags a regression well
  // before the threshold.
  EXPECT_LT(failures.at("worst_frame_max_strain").get<double>(), 1.75);
  // And it settles: the last frame's edges are within 2 times their rest length.
  EXPECT_LT(j.at("max_strain").get<double>(), 1.0);
}

// The cases not clean yet (torture/unsolved/) still never crash, repair, produce NaN or end a
// frame with intersecting triangles or a particle inside the ground; pairs the fail-safe could
// not resolve are reported, not required to be 0 (a propeller's blades leave some in the double
// build). At 4 substeps a cloth thrown about by a propeller once made an impact zone whose root
// the fail-safe had since carried with the blade, which had no slot: a crash in frames 90–120 of
// the float build, which runs them all; the double build runs 60 frames, the sanitizer build 30.
TEST(UnsolvedTortureScenes, NeverCrashRepairOrIntersect) {
  for (const auto& entry : std::filesystem::directory_iterator(std::string(NUCLEON_ASSETS_DIR) +
                                                               "/scenes/torture/unsolved")) {
    if (entry.path().extension() != ".json") continue;
    const std::string stats = (std::filesystem::temp_directory_path() /
                               ("nucleon_unsolved_" + entry.path().stem().string() + ".json"))
                                  .string();
    std::ostringstream out, err;
#if defined(__SANITIZE_ADDRESS__)
    const char* frames = "30";
#elif defined(NUCLEON_DOUBLE)
    const char* frames = "60";
#else
    const char* frames = "120";
#endif
    ASSERT_EQ(runCommandLine({"run", entry.path().string(), "--quiet", "--substeps", "4",
                              "--frames", frames, "--stats", stats},
                             out, err),
              0)
        << err.str();
    std::ifstream in(stats);
    const nlohmann::json j = nlohmann::json::parse(in);
    in.close();
    std::filesystem::remove(stats);
    const nlohmann::json& failures = j.at("failures");
    EXPECT_EQ(failures.at("frames_with_intersections").get<long long>(), 0) << entry.path();
    EXPECT_EQ(failures.at("frames_inside_colliders").get<long long>(), 0) << entry.path();
    EXPECT_EQ(j.at("recoveries").get<long long>(), 0) << entry.path();
    EXPECT_EQ(j.at("nan_count").get<long long>(), 0) << entry.path();
  }
}

INSTANTIATE_TEST_SUITE_P(TortureScenes, EveryTortureScene, testing::ValuesIn(tortureSceneNames()),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;  // scene names are identifiers: [a-z0-9_]
                         });

}  // namespace
}  // namespace nucleon
