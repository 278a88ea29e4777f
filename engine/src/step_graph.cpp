#include "engine/src/step_graph.h"

#include <chrono>

#include "engine/src/world_state.h"
#include "systems/integrate.h"
#include "systems/particle_contacts.h"
#include "systems/solve_constraints.h"

namespace nucleon {
namespace {

enum Stage { kForces, kPredict, kDetectContacts, kSolve, kUpdate, kStageCount };

// Declaration order is execution order wherever two stages conflict.
constexpr std::array<StageDeclaration, kStageCount> kStages = {{
    {"forces", kVelocities | kInverseMass, kVelocities | kStageProfile},
    {"predict", kPositions | kVelocities, kPredicted | kStageProfile},
    {"detect contacts", kPositions | kVelocities | kInverseMass | kColliders,
     kContacts | kStageProfile},
    {"solve", kPositions | kInverseMass | kColliders | kSweepPlan,
     kPredicted | kConstraints | kContacts | kRecoveries | kStageProfile},
    {"update", kPositions | kVelocities | kPredicted,
     kPositions | kVelocities | kPredicted | kRecoveries | kStageProfile},
}};

template <typename F>
double timed(F&& body) {
  const auto start = std::chrono::steady_clock::now();
  body();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void logRepairs(Recoveries& log, std::size_t repaired, std::uint64_t& counter, std::uint64_t step) {
  if (repaired == 0) return;
  counter += repaired;
  if (log.firstStep == 0) log.firstStep = step;
}

}  // namespace

std::span<const StageDeclaration> StepGraph::stages() {
  return kStages;
}

StepGraph::StepGraph(WorldState& state) : state_(state), start_(graph_) {
  for (int s = 0; s < kStageCount; ++s)
    nodes_.push_back(
        std::make_unique<Node>(graph_, [this, s](tbb::flow::continue_msg) { runStage(s); }));
  for (int later = 0; later < kStageCount; ++later) {
    bool root = true;
    for (int earlier = 0; earlier < later; ++earlier) {
      // Own profile entries never conflict: compare without them.
      StageDeclaration a = kStages[earlier], b = kStages[later];
      a.writes &= ~kStageProfile, b.writes &= ~kStageProfile;
      if (!conflicts(a, b)) continue;
      tbb::flow::make_edge(*nodes_[earlier], *nodes_[later]);
      edges_.push_back({earlier, later});
      root = false;
    }
    if (root) tbb::flow::make_edge(start_, *nodes_[later]);
  }
}

void StepGraph::runStage(int stage) {
  WorldState& s = state_;
  StepProfile& profile = s.profile;
  switch (stage) {
    case kForces:
      profile.forces += timed([&] { applyForces(s.particles, s.gravity, h_); });
      break;
    case kPredict:
      profile.predict += timed([&] { predictPositions(s.particles, h_); });
      break;
    case kDetectContacts:
      if (s.colliders.size() == 0) {  // nothing to collide with: no contacts, nothing to time
        s.contacts.resize(0);
        break;
      }
      profile.collisions +=
          timed([&] { detectContacts(s.contacts, s.colliders, s.particles, h_); });
      break;
    case kSolve: {
      double contactSeconds = 0;
      std::size_t missed = 0;
      profile.solve += timed([&] {
        contactSeconds = solveConstraints(s.constraints, s.particles, s.plan, s.contacts,
                                          s.colliders, s.solver.kind, h_, s.solver.relaxation);
        if (s.colliders.size() > 0)
          contactSeconds +=
              timed([&] { missed = resolveMissedContacts(s.contacts, s.colliders, s.particles); });
      });
      // Contacts are projected between sweep rounds: book them as collisions.
      profile.solve -= contactSeconds;
      profile.collisions += contactSeconds;
      profile.projections += s.plan.projectionsPerSubstep;
      ++profile.substeps;
      logRepairs(s.recoveries, missed, s.recoveries.missedContacts, step_);
      break;
    }
    case kUpdate: {
      std::size_t bad = 0;
      profile.update += timed([&] { bad = updateState(s.particles, h_); });
      logRepairs(s.recoveries, bad, s.recoveries.nonFinite, step_);
      break;
    }
    default:
      break;
  }
}

void StepGraph::runSubstep(Real h, std::uint64_t step) {
  h_ = h;
  step_ = step;
  start_.try_put(tbb::flow::continue_msg());
  graph_.wait_for_all();
}

}  // namespace nucleon
