// Helpers shared by the dynamics tests: small worlds built the way a user would build them.
#pragma once

#include <cmath>

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

inline void simulate(World& world, int steps, double dt = 1.0 / 60) {
  for (int i = 0; i < steps; ++i) world.step(dt);
}

}  // namespace nucleon::test
