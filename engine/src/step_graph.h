// The substep as a oneTBB flow graph of systems, built from what each system reads and writes:
// "forces", "animate", "predict", "detect contacts", "detect collisions", "solve", "update",
// "finish animation". The diagram with each stage's reads and writes is ARCHITECTURE.md §5, "Step
// graph" (a test checks it names every stage). Every stage receives the substep's
// SubstepContext; the "solve" stage is one call to the solve orchestrator
// (systems/solver/solve_constraints.h), which never calls back into the graph.
//
// Every stage declares the pools it reads and writes (kStages in step_graph.cpp); the
// constructor adds an edge from an earlier stage to a later one wherever the two conflict (one
// writes what the other reads or writes), so stages that touch disjoint pools, such as predict
// and contact detection, run side by side. A stage's loops are parallel_for inside it. The
// graph is built once per world and reused for every substep, so a step allocates nothing.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <tbb/flow_graph.h>

#include "nucleon/types.h"
#include "systems/substep_context.h"

namespace nucleon {

struct WorldState;

// The pools and tables a stage may touch, as bits.
enum PoolAccess : std::uint32_t {
  kPositions = 1u << 0,     // particles.x
  kVelocities = 1u << 1,    // particles.v
  kPredicted = 1u << 2,     // particles.p
  kInverseMass = 1u << 3,   // particles.w
  kConstraints = 1u << 4,   // the static constraint pools (their λ and scratch)
  kContacts = 1u << 5,      // the per-substep contact pool
  kColliders = 1u << 6,     // the collider list
  kRecoveries = 1u << 7,    // the repair counters
  kSweepPlan = 1u << 8,     // the sweep plan
  kStageProfile = 1u << 9,  // a stage's own profile entry (each stage has its own, no conflict)
  kAnimation = 1u << 10,    // the kinematic tracks, their substep targets and the world's clock
  kPrimitives = 1u << 11,   // the collision primitive lists (static)
  kCandidates = 1u << 12,   // the broad phase's BVH and candidate pairs (per substep)
  kPrimitiveContacts = 1u << 13,  // the primitive contact pool and the collision report
};

struct StageDeclaration {
  const char* name;
  std::uint32_t reads;
  std::uint32_t writes;
};

// True if stage `later` must wait for stage `earlier`.
constexpr bool conflicts(const StageDeclaration& earlier, const StageDeclaration& later) {
  return (earlier.writes & (later.reads | later.writes)) != 0 ||
         (earlier.reads & later.writes) != 0;
}

class StepGraph {
 public:
  explicit StepGraph(WorldState& state);
  StepGraph(const StepGraph&) = delete;
  StepGraph& operator=(const StepGraph&) = delete;
  // Runs one substep; call inside the world's task arena. Every stage receives `context`.
  void runSubstep(const SubstepContext& context);

  // The stages in declaration order and the edges the constructor derived, for tests and docs.
  static std::span<const StageDeclaration> stages();
  const std::vector<std::array<int, 2>>& edges() const { return edges_; }

 private:
  using Node = tbb::flow::continue_node<tbb::flow::continue_msg>;
  void runStage(int stage);
  WorldState& state_;
  SubstepContext context_;
  tbb::flow::graph graph_;
  tbb::flow::broadcast_node<tbb::flow::continue_msg> start_;
  std::vector<std::unique_ptr<Node>> nodes_;
  std::vector<std::array<int, 2>> edges_;
};

}  // namespace nucleon
