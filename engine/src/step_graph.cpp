#include "engine/src/step_graph.h"

#include <chrono>

#include "engine/src/world_state.h"
#include "systems/collision/broad_phase.h"
#include "systems/collision/particle_contacts.h"
#include "systems/collision/primitive_contacts.h"
#include "systems/dynamics/integrate.h"
#include "systems/dynamics/kinematic_motion.h"
#include "systems/solver/multigrid_cascade.h"
#include "systems/solver/solve_constraints.h"

namespace nucleon {
namespace {

// The particles' primitive contacts of this substep, as the cascade reads them (empty when there
// are none: the offsets may then be left from an earlier substep).
std::span<const Index> contactOffsetsOf(const PrimitiveContactPool& contacts) {
  return contacts.size() > 0 ? std::span<const Index>(contacts.incidenceOffset)
                             : std::span<const Index>();
}

// The multigrid cascade's hook: contacts are projected between its levels as between sweep
// rounds, so a particle the cascade pulls toward a collider is held by its contact.
void projectAllContacts(void* state) {
  WorldState& w = *static_cast<WorldState*>(state);
  if (w.primitiveContacts.size() > 0)
    projectPrimitiveContacts(w.primitiveContacts, w.particles, SolverKind::ColoredGaussSeidel);
  if (w.contacts.size() > 0)
    projectContacts(w.contacts, w.colliders, w.particles, SolverKind::ColoredGaussSeidel);
}

enum Stage {
  kForces,
  kAnimate,
  kPredict,
  kDetectContacts,
  kDetectCollisions,
  kSolve,
  kUpdate,
  kFinishAnimation,
  kStageCount
};

// Declaration order is execution order wherever two stages conflict.
constexpr std::array<StageDeclaration, kStageCount> kStages = {{
    {"forces", kVelocities | kInverseMass, kVelocities | kStageProfile},
    // Also reads the animated particles' rest positions, which nothing changes during a step.
    {"animate", kPositions | kAnimation, kVelocities | kAnimation | kStageProfile},
    {"predict", kPositions | kVelocities, kPredicted | kStageProfile},
    {"detect contacts", kPositions | kVelocities | kInverseMass | kColliders,
     kContacts | kStageProfile},
    // Broad phase over the predicted motion, then the primitive contacts of its pairs.
    {"detect collisions", kPositions | kVelocities | kPredicted | kInverseMass | kPrimitives,
     kCandidates | kPrimitiveContacts | kStageProfile},
    // Also the primitive contacts' friction and the crossing fail-safe after the sweeps.
    // And finds the candidate pairs again when the solve's motion leaves their bounds.
    {"solve", kPositions | kInverseMass | kColliders | kSweepPlan | kPrimitives,
     kPredicted | kConstraints | kContacts | kCandidates | kPrimitiveContacts | kRecoveries |
         kStageProfile},
    // Also restitution of the primitive contacts, after the velocity update.
    {"update", kPositions | kVelocities | kPredicted | kPrimitiveContacts,
     kPositions | kVelocities | kPredicted | kRecoveries | kStageProfile},
    // Shares `animate`'s profile entry without a race: it reads the targets animate writes, so it
    // always runs after it.
    {"finish animation", kAnimation, kPositions | kPredicted | kStageProfile},
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
    case kAnimate:
      if (s.kinematics.empty()) break;
      profile.animate += timed([&] {
        animateKinematics(s.kinematics, s.particles, s.substep, s.solver.substeps, s.substepEnd,
                          h_);
      });
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
    case kDetectCollisions: {
      CollisionReport& report = s.collisionReport;
      if (s.primitives.total() == 0) {  // nothing collides: no pairs, nothing to time
        s.candidates.clear();
        s.primitiveContacts.resize(0);
        break;
      }
      // Once per step over the step's extrapolated motion, and again for the rest of the step
      // whenever a substep's prediction leaves the particles' bounds (a kinematic track that
      // curves, a particle knocked off its course), so the pair set is always complete.
      profile.broadPhase += timed([&] {
        if (s.substep > 0 && withinParticleBounds(s.candidates, s.particles.p)) return;
        const ParticlePool& particles = s.particles;
        CandidatePairs& pairs = s.candidates;
        predictMotionBounds(pairs, particles.x, particles.p, particles.w, s.gravity, h_,
                            s.solver.substeps - s.substep);
        // A primitive's box is the box of its particles' motion boxes, which are the two corners.
        findCandidatePairs(pairs, s.bvh, s.primitives, pairs.boundLower, pairs.boundUpper,
                           particles.w, kPrimitiveContactMargin);
        growParticleBounds(pairs, boundSlack(s.primitives, kPrimitiveContactMargin));
        ++report.broadPhases;
        if (s.substep > 0) ++report.broadPhaseRefreshes;
      });
      profile.narrowPhase += timed([&] {
        detectPrimitiveContacts(s.primitiveContacts, s.candidates, s.primitives, s.particles);
      });
      report.candidatePairs += s.candidates.size();
      report.contacts += s.primitiveContacts.size();
      break;
    }
    case kSolve: {
      double contactSeconds = 0;
      std::size_t missed = 0, redetections = 0, colliderRedetections = 0, cascadeProjections = 0;
      CrossingReport crossing;
      profile.solve += timed([&] {
        // The multigrid cascade, before the fine sweeps and again between fine rounds when
        // cascade_every asks for it. It moves particles by whole coarse corrections, farther
        // than the collider contacts' reach beyond their predicted motion: where it carried one
        // without a contact toward a collider, the pool is refilled over the motion to where it
        // is now (else the particle would end the solve inside and count as a missed contact).
        // The new pool starts its multipliers at zero, so friction forgets the cascade's normal
        // pushes.
        struct Cascade {
          WorldState& state;
          Real h;
          std::size_t projections = 0;
          std::size_t colliderRedetections = 0;
          void run() {
            WorldState& w = state;
            projections += runMultigridCascade(
                w.hierarchies, w.objects, w.particles, w.cascadeStart, w.solver.sweepsPerLevel,
                projectAllContacts, &w, contactOffsetsOf(w.primitiveContacts));
            if (w.colliders.size() > 0 && contactsMissing(w.contacts, w.colliders, w.particles)) {
              detectContacts(w.contacts, w.colliders, w.particles, h, w.particles.p);
              projectContacts(w.contacts, w.colliders, w.particles, fineSweepKind(w.solver));
              ++colliderRedetections;
            }
          }
        } cascade{s, h_};
        if (s.solver.kind == SolverKind::Multigrid) cascade.run();
        auto repeatCascade = [](void* context, int roundsDone) {
          Cascade& c = *static_cast<Cascade*>(context);
          const int every = c.state.solver.cascadeEvery;
          if (every > 0 && roundsDone % every == 0) c.run();
        };
        const bool repeats = s.solver.kind == SolverKind::Multigrid && s.solver.cascadeEvery > 0;
        SolveSettings settings = solveSettingsOf(s.solver);
        settings.betweenRounds = repeats ? +repeatCascade : nullptr;
        settings.hookContext = &cascade;
        contactSeconds = solveConstraints(s.constraints, s.particles, s.plan, s.contacts,
                                          s.colliders, s.primitiveContacts, h_, settings);
        cascadeProjections = cascade.projections;
        colliderRedetections = cascade.colliderRedetections;
        if (s.colliders.size() > 0)
          contactSeconds +=
              timed([&] { missed = resolveMissedContacts(s.contacts, s.colliders, s.particles); });
        if (s.primitives.total() > 0)
          contactSeconds += timed([&] {
            applyPrimitiveFriction(s.primitiveContacts, s.particles, s.solver.kind);
            // Contacts and collider responses move particles off their predicted course; where
            // one leaves its bounds, the pairs of the actual motion x → p are found, rather than
            // the motion cut back to the bounds (a clamp would hold a particle against the
            // contact that pushed it, and stretch the cloth around it).
            if (!withinParticleBounds(s.candidates, s.particles.p)) {
              findCandidatePairs(s.candidates, s.bvh, s.primitives, s.particles.x, s.particles.p,
                                 s.particles.w, kPrimitiveContactMargin);
              setMotionBounds(s.candidates, s.particles.x, s.particles.p);
              growParticleBounds(s.candidates, boundSlack(s.primitives, kPrimitiveContactMargin));
              measureStartDistances(s.primitiveContacts, s.candidates, s.primitives, s.particles);
              ++redetections;
            }
            crossing =
                resolveCrossings(s.primitiveContacts, s.candidates, s.primitives, s.particles);
          });
      });
      CollisionReport& report = s.collisionReport;
      report.clampedParticles += crossing.clamped;
      report.broadPhases += redetections;
      report.solveRedetections += redetections;
      report.colliderRedetections += colliderRedetections;
      report.crossings += crossing.crossings;
      report.stoppedParticles += crossing.stopped;
      report.unresolvedPairs += crossing.unresolved;
      if (crossing.crossings > 0 && report.firstCrossingStep == 0) report.firstCrossingStep = step_;
      // Contacts are projected between sweep rounds: book them as collisions.
      profile.solve -= contactSeconds;
      profile.collisions += contactSeconds;
      profile.projections += s.plan.projectionsPerSubstep + cascadeProjections;
      ++profile.substeps;
      logRepairs(s.recoveries, missed, s.recoveries.missedContacts, step_);
      break;
    }
    case kUpdate: {
      std::size_t bad = 0;
      profile.update += timed([&] { bad = updateState(s.particles, h_); });
      if (s.primitiveContacts.size() > 0)
        profile.collisions += timed([&] { applyRestitution(s.primitiveContacts, s.particles); });
      logRepairs(s.recoveries, bad, s.recoveries.nonFinite, step_);
      break;
    }
    case kFinishAnimation:
      if (s.kinematics.empty()) break;
      profile.animate += timed([&] { finishKinematics(s.kinematics, s.particles); });
      break;
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
