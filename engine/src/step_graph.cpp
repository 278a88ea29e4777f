#include "engine/src/step_graph.h"

#include <chrono>

#include "engine/src/world_state.h"
#include "systems/integrate.h"
#include "systems/solve_constraints.h"

namespace nucleon {
namespace {

template <typename F>
void timed(double& seconds, F&& body) {
  const auto start = std::chrono::steady_clock::now();
  body();
  seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

StepGraph::StepGraph(WorldState& state)
    : state_(state),
      forces_(graph_,
              [this](tbb::flow::continue_msg) {
                timed(state_.profile.forces,
                      [&] { applyForces(state_.particles, state_.gravity, h_); });
              }),
      predict_(graph_,
               [this](tbb::flow::continue_msg) {
                 timed(state_.profile.predict, [&] { predictPositions(state_.particles, h_); });
               }),
      solve_(graph_,
             [this](tbb::flow::continue_msg) {
               double contactSeconds = 0;
               timed(state_.profile.solve, [&] {
                 contactSeconds =
                     solveConstraints(state_.constraints, state_.particles, state_.plan,
                                      ContactSurfaces{state_.ground, state_.spheres},
                                      state_.solver.kind, h_, state_.solver.relaxation);
               });
               // Contacts are projected between sweep rounds: book them as collisions.
               state_.profile.solve -= contactSeconds;
               state_.profile.collisions += contactSeconds;
               state_.profile.projections += state_.plan.projectionsPerSubstep;
               ++state_.profile.substeps;
             }),
      update_(graph_, [this](tbb::flow::continue_msg) {
        timed(state_.profile.update,
              [&] { state_.nonFiniteRecoveries += updateState(state_.particles, h_); });
      }) {
  tbb::flow::make_edge(forces_, predict_);
  tbb::flow::make_edge(predict_, solve_);
  tbb::flow::make_edge(solve_, update_);
}

void StepGraph::runSubstep(Real h) {
  h_ = h;
  forces_.try_put(tbb::flow::continue_msg());
  graph_.wait_for_all();
}

}  // namespace nucleon
