// Helpers shared by the dynamics tests: small worlds built the way a user would build them.
#pragma once

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

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

// The names (file stems) of every scene in the bundled folder, sorted, so that a new scene is
// covered by the tests over all scenes without a new test.
inline std::vector<std::string> bundledSceneNames() {
  std::vector<std::string> names;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(NUCLEON_ASSETS_DIR) + "/scenes"))
    if (entry.path().extension() == ".json") names.push_back(entry.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

inline void simulate(World& world, int steps, double dt = 1.0 / 60) {
  for (int i = 0; i < steps; ++i) world.step(dt);
}

}  // namespace nucleon::test
