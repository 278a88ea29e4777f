// Everything a World owns: the component pools and the settings the systems read.
// Internal to the library (the public World hides it behind a pointer); tests and benchmarks in
// this tree include it to reach the pools directly.
#pragma once

#include <memory>
#include <vector>

#include <tbb/task_arena.h>

#include "components/constraint_pools.h"
#include "components/objects.h"
#include "components/particles.h"
#include "components/sweep_plan.h"
#include "nucleon/world.h"

namespace nucleon {

class StepGraph;

struct WorldState {
  ParticlePool particles;
  ConstraintPools constraints;
  std::vector<ObjectRecord> objects;
  Vec3 gravity = Vec3(0, Real(-9.81), 0);
  SolverSettings solver;
  GroundPlane ground;
  std::vector<SphereCollider> spheres;
  SweepPlan plan;                       // from solver.schedule and the objects' schedules
  bool topologyDirty = true;            // incidence, coloring and plan need rebuilding
  std::size_t nonFiniteRecoveries = 0;  // particles reset by updateState since creation
  StepProfile profile;                  // the engine's own per-stage timing
};

struct World::Impl {
  WorldState state;
  int threads = 0;
  std::unique_ptr<tbb::task_arena> arena;
  std::unique_ptr<StepGraph> graph;
  ~Impl();
};

}  // namespace nucleon
