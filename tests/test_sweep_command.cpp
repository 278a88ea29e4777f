// `nucleon run --set`, and the input checks of `nucleon sweep` and `nucleon view`. The sweep's runs themselves (separate
// processes, GNU parallel) are tested by tests/scripts/sweep_parallel.sh.
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "nucleon/scene.h"

#include "engine/app/cli.h"
#include "tests/scene_run.h"

namespace nucleon {
namespace {

namespace fs = std::filesystem;

std::string hangScene() {
  return (fs::path(NUCLEON_ASSETS_DIR) / "scenes" / "cloth_hang.json").string();
}

int command(const std::vector<std::string>& args, std::string& error) {
  std::ostringstream out, err;
  const int code = runCommandLine(args, out, err);
  error = err.str();
  return code;
}

TEST(RunSet, ChangesTheSettingsAsTheFileWould) {
  // A setting changed from the command line gives the state of a file that says it.
  const test::SceneRun set = test::runScene(
      hangScene(),
      {"--frames", "3", "--set", "solver.iterations=3", "--set", "solver.type=jacobi"});
  ASSERT_FALSE(set.stats.is_null());
  EXPECT_EQ(set.stats.at("iterations").get<int>(), 3);
  EXPECT_EQ(set.stats.at("solver").get<std::string>(), "jacobi");
  const test::SceneRun flags =
      test::runScene(hangScene(), {"--frames", "3", "--iterations", "3", "--solver", "jacobi"});
  ASSERT_FALSE(flags.stats.is_null());
  EXPECT_EQ(set.stats.at("state_hash"), flags.stats.at("state_hash"));
  const test::SceneRun plain = test::runScene(hangScene(), {"--frames", "3"});
  ASSERT_FALSE(plain.stats.is_null());
  EXPECT_NE(set.stats.at("state_hash"), plain.stats.at("state_hash"));
}

TEST(RunSet, RefusesWhatCannotBeSet) {
  std::string error;
  for (const std::string& bad :
       {std::string("solver.iterations"), std::string("=3"), std::string("solver..type=jacobi"),
        std::string("objects.7.name=x"), std::string("frames.count=3")}) {
    EXPECT_EQ(command({"run", hangScene(), "--quiet", "--set", bad}, error), 2) << bad;
    EXPECT_NE(error.find("setting '" + bad + "'"), std::string::npos) << error;
  }
  // A key the parser does not know is refused by it, with its JSON path.
  EXPECT_EQ(command({"run", hangScene(), "--quiet", "--set", "solver.sweeps=3"}, error), 2);
  EXPECT_NE(error.find("sweeps"), std::string::npos) << error;
  // A value of the wrong type likewise.
  EXPECT_EQ(command({"run", hangScene(), "--quiet", "--set", "solver.iterations=many"}, error), 2);
  EXPECT_NE(error.find("iterations"), std::string::npos) << error;
}

TEST(SweepCommand, RefusesBadInputBeforeWritingAnything) {
  const fs::path dir = fs::temp_directory_path() / "nucleon_sweep_refused";
  fs::remove_all(dir);
  std::string error;
  EXPECT_EQ(command({"sweep", hangScene(), "--out", dir.string()}, error), 2);
  EXPECT_NE(error.find("--set"), std::string::npos) << error;
  EXPECT_EQ(
      command({"sweep", hangScene(), "--set", "solver.iterations=", "--out", dir.string()}, error),
      2);
  EXPECT_EQ(command({"sweep", hangScene(), "--set", "solver.iterations=2,4", "--set",
                     "solver.iterations=8", "--out", dir.string()},
                    error),
            2);
  EXPECT_NE(error.find("set twice"), std::string::npos) << error;
  // One bad point of the grid fails the whole sweep up front.
  EXPECT_EQ(
      command({"sweep", hangScene(), "--set", "solver.iterations=2,-1", "--out", dir.string()},
              error),
      2);
  EXPECT_NE(error.find("iterations"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(dir));
  EXPECT_EQ(command({"sweep", "--gather", dir.string()}, error), 2);
  EXPECT_NE(error.find("runs.csv"), std::string::npos) << error;
  EXPECT_EQ(command({"sweep", "--gather", dir.string(), hangScene()}, error), 2);
}

// `nucleon view` checks its input before it opens a window (the window itself is tested under
// Xvfb by tests/scripts/viewer_screenshot.sh).
TEST(ViewCommand, RefusesBadInputBeforeOpeningAWindow) {
  std::string error;
  EXPECT_EQ(command({"view"}, error), 2);
  EXPECT_NE(error.find("scene"), std::string::npos) << error;
  EXPECT_EQ(command({"view", hangScene(), "--screenshot", "x.png"}, error), 2);
  EXPECT_NE(error.find("--frames"), std::string::npos) << error;
  EXPECT_EQ(command({"view", hangScene(), "--size", "big"}, error), 2);
  EXPECT_EQ(command({"view", hangScene(), "--frames", "3", "--screenshot", "/no/such/dir/x.png"},
                    error),
            2);
  EXPECT_NE(error.find("does not exist"), std::string::npos) << error;
  EXPECT_EQ(command({"view", "/no/such/scene.json"}, error), 2);
  EXPECT_EQ(command({"view", hangScene(), "--set", "solver.sweeps=3"}, error), 2);
}

}  // namespace
}  // namespace nucleon
