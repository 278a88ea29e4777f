#include "engine/src/step_graph.h"

#include <chrono>

#include "engine/src/world_state.h"
#include "systems/collision/broad_phase.h"
#include "systems/collision/particle_contacts.h"
#include "systems/collision/primitive_contacts.h"
#include "systems/dynamics/integrate.h"
#include "systems/dynamics/kinematic_motion.h"
#include "systems/liquid/liquid_velocities.h"
#include "systems/solver/solve_constraints.h"

namespace nucleon {
namespace {

enum Stage {
  kForces,
  kAnimate,
  kPredict,
  kDetectContacts,
  kDetectCollisions,
  kSolve,
  kUpdate,
  kLiquidVelocities,
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
    // Viscosity, vorticity and surface tension of the liquids, over the solve's neighbour lists;
    // booked as solve time.
    {"liquid velocities", kPositions | kVelocities | kInverseMass | kConstraints,
     kVelocities | kConstraints | kStageProfile},
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
  const SubstepContext& c = context_;
  StepProfile& profile = s.profile;
  switch (stage) {
    case kForces:
      profile.forces += timed([&] { applyForces(s.particles, s.gravity, c.h); });
      break;
    case kAnimate:
      if (s.kinematics.empty()) break;
      profile.animate += timed([&] {
        animateKinematics(s.kinematics, s.particles, c.substep, c.substeps, c.endTime, c.h);
      });
      break;
    case kPredict:
      profile.predict += timed([&] { predictPositions(s.particles, c.h); });
      break;
    case kDetectContacts:
      if (s.colliders.size() == 0) {  // nothing to collide with: no contacts, nothing to time
        s.contacts.resize(0);
        break;
      }
      profile.collisions +=
          timed([&] { detectContacts(s.contacts, s.colliders, s.particles, c.h); });
      break;
    case kDetectCollisions: {
      CollisionReport& report = s.collisionReport;
      if (s.primitives.total() == 0) {  // nothing collides: no pairs, nothing to time
        s.candidates.clear();
        s.primitiveContacts.resize(0);
        break;
      }
      // At most once per step over the step's extrapolated motion, and again for the rest of the
      // step whenever a substep's prediction leaves the particles' bounds (a kinematic track that
      // curves, a particle knocked off its course), so the pair set is always complete. A step
      // starts from the last step's pairs while they stay complete and tight: a cloth at rest
      // keeps its pairs for as long as it rests.
      profile.broadPhase += timed([&] {
        CandidatePairs& pairs = s.candidates;
        const ParticlePool& particles = s.particles;
        const Real slack = boundSlack(s.primitives, kPrimitiveContactMargin);
        pairs.frameSubstep = c.substep;
        std::size_t outsideAtStart = 0;
        const bool carried =
            c.substep > 0 || carryPairsIntoStep(pairs, s.bvh, particles.x, particles.p, particles.w,
                                                s.gravity, c.h, c.substeps, slack, outsideAtStart);
        if (carried && outsideAtStart == 0 && withinParticleBounds(pairs, particles.p)) {
          if (c.substep == 0) ++report.keptPairSets;
          return;
        }
        predictMotionEnd(pairs.motionEnd, particles.x, particles.p, particles.w, s.gravity, c.h,
                         c.substeps - c.substep);
        ++report.broadPhases;
        if (carried) {
          if (c.substep > 0) ++report.broadPhaseRefreshes;
          // Few particles off their course: only theirs are found again.
          if (extendCandidatePairs(
                  pairs, s.bvh, s.primitives, particles.p, particles.x, pairs.motionEnd,
                  particles.w, kPrimitiveContactMargin, slack,
                  {pairs.endOffset(), pairs.startOffset(), pairs.frameAt(c.substeps), c.substep + 1,
                   c.substep, c.substeps})) {
            ++report.incrementalBroadPhases;
            return;
          }
        }
        // A new frame from this substep on: the substep's start is at offset zero.
        setMotionFrame(pairs, particles.x, particles.p, particles.w, s.gravity, c.h, c.substep,
                       c.substeps);
        setMotionBounds(pairs, particles.x, pairs.motionEnd, Vec3::Zero(),
                        pairs.frameAt(c.substeps), c.substep, c.substeps);
        findCandidatePairs(pairs, s.bvh, s.primitives, pairs.pathStart, pairs.pathEnd, particles.w,
                           kPrimitiveContactMargin);
        growParticleBounds(pairs, slack);
      });
      profile.narrowPhase += timed([&] {
        detectPrimitiveContacts(s.primitiveContacts, s.candidates, s.primitives, s.particles);
      });
      report.candidatePairs += s.candidates.size();
      report.contacts += s.primitiveContacts.size();
      break;
    }
    case kSolve: {
      SolvePools pools{s.constraints, s.particles,         s.plan,       s.contacts,
                       s.colliders,   s.primitiveContacts, s.candidates, s.primitives,
                       s.bvh,         s.hierarchies,       s.objects,    s.cascade};
      SolveReport solve;
      profile.solve +=
          timed([&] { solve = solveConstraints(pools, solveSettingsOf(s.solver), c); });
      CollisionReport& report = s.collisionReport;
      const CrossingReport& crossing = solve.crossing;
      report.clampedParticles += crossing.clamped;
      report.broadPhases += solve.redetections;
      report.solveRedetections += solve.redetections;
      report.incrementalBroadPhases += solve.incrementalRedetections;
      report.colliderRedetections += solve.colliderRedetections;
      report.supportedParticles += solve.supportedParticles;
      report.crossings += crossing.crossings;
      report.stoppedParticles += crossing.stopped;
      report.carriedParticles += crossing.carried;
      report.squeezes += crossing.squeezed;
      report.impactZones += crossing.zones;
      report.stoppedImpactZones += crossing.stoppedZones;
      report.impactZoneTurnsDropped += crossing.turnsDropped;
      report.carryRelaxations += crossing.relaxations;
      report.unresolvedPairs += crossing.unresolved;
      if (crossing.crossings > 0 && report.firstCrossingStep == 0)
        report.firstCrossingStep = c.step;
      // Contacts are projected between sweep rounds: book them as collisions.
      profile.solve -= solve.contactSeconds;
      profile.collisions += solve.contactSeconds;
      profile.projections += s.plan.projectionsPerSubstep + solve.cascadeProjections;
      profile.cascade += solve.cascadeSeconds;
      ++profile.substeps;
      logRepairs(s.recoveries, solve.missedContacts, s.recoveries.missedContacts, c.step);
      logRepairs(s.recoveries, solve.collapsedPressureProjections,
                 s.recoveries.collapsedPressureVolumes, c.step);
      logRepairs(s.recoveries, solve.limitedPressureSteps, s.recoveries.limitedPressureSteps,
                 c.step);
      logRepairs(s.recoveries, solve.limitedDensityMoves, s.recoveries.limitedDensityMoves, c.step);
      break;
    }
    case kUpdate: {
      std::size_t bad = 0;
      profile.update += timed([&] { bad = updateState(s.particles, c.h); });
      if (s.primitiveContacts.size() > 0)
        profile.collisions += timed([&] { applyRestitution(s.primitiveContacts, s.particles); });
      logRepairs(s.recoveries, bad, s.recoveries.nonFinite, c.step);
      break;
    }
    case kLiquidVelocities: {
      LiquidPool& liquid = s.constraints.liquid;
      if (liquid.size() == 0) break;
      profile.solve += timed([&] { applyLiquidVelocities(liquid, s.particles, c.h); });
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

void StepGraph::runSubstep(const SubstepContext& context) {
  context_ = context;
  start_.try_put(tbb::flow::continue_msg());
  graph_.wait_for_all();
}

}  // namespace nucleon
