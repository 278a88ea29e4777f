// Helpers shared by the dynamics tests: small worlds built the way a user would build them.
#pragma once

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"

namespace nucleon::test {

inline SolverSettings solverSettings(SolverKind kind, int iterations, int substeps) {
  SolverSettings s;
  s.kind = kind;
  s.iterations = iterations;
  s.substeps = substeps;
  return s;
}

// A 4×4 grid panel 1 m square, vertical in the xy plane, centred at `center`: an open mesh for
// colliders and small cloths.
inline ObjectDef verticalPanel(const Vec3& center) {
  GridSpec spec;
  spec.resolution = {4, 4};
  spec.size = {1, 1};
  spec.center = center;
  spec.vertical = true;
  ObjectDef def = gridCloth(spec);
  def.name = "panel";
  return def;
}

// A square cloth of n×n vertices, 2 m wide, horizontal at 1 m, pinned at two adjacent corners.
inline World hangingCloth(int n, int iterations, int substeps = 1, int threads = 0,
                          Real stretchCompliance = 0) {
  GridSpec spec;
  spec.resolution = {n, n};
  ObjectDef cloth = gridCloth(spec);
  cloth.pins = {0, static_cast<Index>(n - 1)};
  cloth.material.stretchCompliance = stretchCompliance;
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, iterations, substeps));
  world.setThreads(threads);
  world.addCloth(cloth);
  return world;
}

// The names (file stems) of every scene in a folder of assets/scenes ("" for the bundled
// scenes themselves), sorted, so that a new scene is covered by the tests over all scenes
// without a new test.
inline std::vector<std::string> sceneNamesIn(const std::string& folder) {
  std::vector<std::string> names;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(NUCLEON_ASSETS_DIR) + "/scenes/" + folder))
    if (entry.path().extension() == ".json") names.push_back(entry.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

inline std::vector<std::string> bundledSceneNames() {
  return sceneNamesIn("");
}

// The message of the SceneError that building a world from this scene text raises; empty if none.
inline std::string sceneError(const std::string& json) {
  try {
    buildWorld(parseScene(json, "test.json", "."));
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

// `text` with the first occurrence of `from` replaced by `to` (a failure if there is none).
inline std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

inline void simulate(World& world, int steps, double dt = 1.0 / 60) {
  for (int i = 0; i < steps; ++i) world.step(dt);
}

}  // namespace nucleon::test
