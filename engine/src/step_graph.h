// The substep as a oneTBB flow graph of systems.
//
//   forces ──► predict ──► constraint sweeps ──► update
//   (v += h g)  (p = x+hv)  (move p; GS / parallel)  (v += Δp/h, x = p)
//
// Each node runs one system over the pools in World::Impl; loops inside a node are parallel_for.
// The graph is built once per world and reused for every substep, so a step allocates nothing.
// Broad phase and collision nodes attach between "constraint sweeps" and "update".
#pragma once

#include <tbb/flow_graph.h>

#include "nucleon/types.h"

namespace nucleon {

struct WorldState;

class StepGraph {
 public:
  explicit StepGraph(WorldState& state);
  StepGraph(const StepGraph&) = delete;
  StepGraph& operator=(const StepGraph&) = delete;
  // Runs one substep of length h; call inside the world's task arena.
  void runSubstep(Real h);

 private:
  using Node = tbb::flow::continue_node<tbb::flow::continue_msg>;
  WorldState& state_;
  Real h_ = 0;
  tbb::flow::graph graph_;
  Node forces_, predict_, solve_, update_;
};

}  // namespace nucleon
