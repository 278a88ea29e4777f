#include "engine/src/step_graph.h"

#include <chrono>

#include "engine/src/world_state.h"
#include "systems/constraint_sweeps.h"
#include "systems/integrate.h"
#include "systems/stretch_solve.h"

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
                timed(state_.stageTimes.forces,
                      [&] { applyForces(state_.particles, state_.gravity, h_); });
              }),
      predict_(graph_,
               [this](tbb::flow::continue_msg) {
                 timed(state_.stageTimes.predict, [&] { predictPositions(state_.particles, h_); });
               }),
      solve_(graph_,
             [this](tbb::flow::continue_msg) {
               timed(state_.stageTimes.solve, [&] {
                 for (auto* lambda :
                      {&state_.stretch.lambda, &state_.bend.lambda, &state_.volume.lambda})
                   std::fill(lambda->begin(), lambda->end(), Real(0));
                 const SolverSettings& solver = state_.solver;
                 for (int sweep = 0; sweep < solver.iterations; ++sweep) {
                   switch (solver.kind) {
                     case SolverKind::Jacobi:
                       solveStretchJacobi(state_.stretch, state_.particles, h_, solver.relaxation);
                       break;
                     case SolverKind::ColoredGaussSeidel:
                       solveStretchColored(state_.stretch, state_.particles, h_);
                       break;
                     default:
                       solveStretchGaussSeidel(state_.stretch, state_.particles, h_);
                       break;
                   }
                   // Interleaved: every sweep visits each family once, stretch first.
                   solveSweep<DihedralKernel>(solver.kind, state_.bend, state_.particles, h_,
                                              solver.relaxation);
                   solveSweep<VolumeKernel>(solver.kind, state_.volume, state_.particles, h_,
                                            solver.relaxation);
                 }
               });
             }),
      update_(graph_, [this](tbb::flow::continue_msg) {
        timed(state_.stageTimes.update,
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
