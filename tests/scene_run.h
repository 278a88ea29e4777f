// Runs `nucleon run` the way a script does and hands back its --stats JSON: the scene tests'
// one way of running a scene file through the command line.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/app/cli.h"

namespace nucleon::test {

struct SceneRun {
  nlohmann::json stats;  // null if the run failed (a test failure is recorded)
  std::string summary;   // what the command printed
};

// `nucleon run SCENE --quiet --stats TMP` plus `extra`; the stats file is removed afterwards.
inline SceneRun runScene(const std::string& scene, const std::vector<std::string>& extra = {}) {
  const std::string stats =
      (std::filesystem::temp_directory_path() /
       ("nucleon_run_" + std::filesystem::path(scene).stem().string() + ".json"))
          .string();
  std::vector<std::string> args = {"run", scene, "--quiet", "--stats", stats};
  args.insert(args.end(), extra.begin(), extra.end());
  std::ostringstream out, err;
  SceneRun run;
  const int status = runCommandLine(args, out, err);
  run.summary = out.str();
  if (status != 0) {
    ADD_FAILURE() << scene << ": exit " << status << ": " << err.str();
    return run;
  }
  {
    std::ifstream in(stats);
    run.stats = nlohmann::json::parse(in);
  }
  std::filesystem::remove(stats);
  return run;
}

}  // namespace nucleon::test
