#include "systems/solver/solve_constraints.h"

#include <algorithm>
#include <chrono>
#include <type_traits>

#include "systems/collision/broad_phase.h"
#include "systems/collision/particle_contacts.h"
#include "systems/collision/primitive_contacts.h"
#include "systems/liquid/density_constraints.h"
#include "systems/solver/attachments.h"
#include "systems/solver/constraint_sweeps.h"
#include "systems/solver/family_pools.h"
#include "systems/solver/multigrid_cascade.h"
#include "systems/solver/pressure.h"
#include "systems/solver/shape_matching.h"
#include "systems/solver/supported_particles.h"
#include "systems/solver/tether_sweep.h"

namespace nucleon {

SolveSettings solveSettingsOf(const SolverSettings& solver) {
  SolveSettings settings;
  settings.sweepKind = fineSweepKind(solver);
  settings.relaxation = solver.relaxation;
  settings.chebyshevRho = solver.chebyshevRho;
  settings.sheetRelaxation = solver.sheetRelaxation;
  settings.supportedInverseMassScale = solver.supportedInverseMassScale;
  settings.optimizedPaths = solver.optimizedPaths;
  settings.cascade =
      solver.kind == SolverKind::Multigrid && sweepsOfLevel(solver.sweepsPerLevel, 1) > 0;
  settings.cascadeEvery = solver.cascadeEvery;
  settings.sweepsPerLevel = solver.sweepsPerLevel;
  settings.cascadeRelaxation = solver.cascadeRelaxation;
  return settings;
}

namespace {

template <typename F>
double timed(F&& body) {
  const auto start = std::chrono::steady_clock::now();
  body();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// How many times the fail-safe may find the pairs of the motion it left and check them again.
constexpr int kCrossingPasses = 4;

// Collider contacts last: a stack of layers pressed onto the ground ends the round on it.
void projectAllContacts(SolvePools& pools, SolverKind kind) {
  if (pools.primitiveContacts.size() > 0)
    projectPrimitiveContacts(pools.primitiveContacts, pools.particles, kind);
  if (pools.contacts.size() > 0)
    projectContacts(pools.contacts, pools.colliders, pools.particles, kind);
}

// The multigrid cascade. Contacts are projected between its levels as between sweep rounds, so a
// particle the cascade pulls toward a collider is held by its contact; particles with primitive
// contacts keep the place their contacts gave them. The cascade moves particles by whole coarse
// corrections, farther than the collider contacts' reach beyond their predicted motion: where it
// carried one without a contact toward a collider, that particle's contacts over the motion to
// where it is now are added to the pool (else it would end the solve inside and count as a
// missed contact; a particle that has contacts keeps just those). Every multiplier then starts
// again at zero, so friction forgets the cascade's normal pushes.
void runCascade(SolvePools& pools, const SolveSettings& settings, const SubstepContext& context,
                SolveReport& report) {
  const auto start = std::chrono::steady_clock::now();
  report.cascadeProjections += runMultigridCascade(
      pools.hierarchies, pools.objects, pools.particles, pools.cascade, settings.sweepsPerLevel,
      [](void* p, std::span<const Index> moved, CascadeMoment moment) {
        SolvePools& solvePools = *static_cast<SolvePools*>(p);
        CascadeScratch& scratch = solvePools.cascade;
        // Between two sweeps of a level: the collider contacts of its particles on a sphere, with
        // their friction, as between fine sweep rounds (the primitive contacts, whose projection
        // moves particles of any level, would cost a full projection per coarse sweep); from a
        // compact copy, taken before the sweeps and returned after them.
        if (moment == CascadeMoment::BeforeSweeps) {
          copyContactsOf(solvePools.contacts, moved, scratch.levelContacts,
                         scratch.levelContactSource);
          return;
        }
        if (moment == CascadeMoment::BetweenSweeps) {
          projectCopiedContacts(scratch.levelContacts, solvePools.colliders, solvePools.particles);
          return;
        }
        if (scratch.levelContacts.size() > 0) {
          returnCopiedContacts(scratch.levelContacts, scratch.levelContactSource,
                               solvePools.contacts);
          scratch.levelContacts.resize(0);
        }
        // The primitive contacts move particles of any level, which the collider contacts
        // projected after them must then settle: all of them, as after a sweep round.
        if (moment == CascadeMoment::AfterCascade || solvePools.primitiveContacts.size() > 0) {
          projectAllContacts(solvePools, SolverKind::ColoredGaussSeidel);
          return;
        }
        projectContactsOf(solvePools.contacts, solvePools.colliders, solvePools.particles, moved);
      },
      &pools, {&pools.contacts, &pools.colliders, &pools.primitiveContacts},
      settings.cascadeRelaxation);
  if (addReachedContacts(pools.contacts, pools.colliders, pools.particles, context.h) > 0) {
    projectContacts(pools.contacts, pools.colliders, pools.particles, settings.sweepKind);
    ++report.colliderRedetections;
  }
  report.cascadeSeconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The candidate pairs of the actual motion x → p where contacts and collider responses moved a
// particle off its predicted course and out of its bounds.
void redetectFromSolve(SolvePools& pools, SolveReport& report) {
  ParticlePool& particles = pools.particles;
  const Real slack = boundSlack(pools.primitives, kPrimitiveContactMargin);
  // Few particles off their course: only theirs are found again.
  CandidatePairs& pairs = pools.candidates;
  // In the step's frame: the positions at the substep's start and end at their offsets.
  const Vec3 start = pairs.startOffset(), end = pairs.endOffset();
  const int substep = pairs.frameSubstep, last = pairs.lastBoundary();
  if (extendCandidatePairs(pairs, pools.bvh, pools.primitives, particles.p, particles.x,
                           particles.p, particles.w, kPrimitiveContactMargin, slack,
                           {end, start, end, substep + 1, substep, substep + 1})) {
    ++report.incrementalRedetections;
  } else {
    // The substep's motion, on in a straight line to the step's end.
    setMotionBounds(pairs, particles.x, particles.p, start, end, substep, last,
                    Real(last - substep));
    findCandidatePairs(pairs, pools.bvh, pools.primitives, pairs.pathStart, pairs.pathEnd,
                       particles.w, kPrimitiveContactMargin);
    growParticleBounds(pairs, slack);
  }
  ++report.redetections;
}

// One op of the sweep plan: a family's sweep over its pools, restricted to the op's objects.
void runSweepOp(const SweepOp& op, const SweepPlan& plan, ConstraintPools& constraints,
                SweepContext& sweep, SolverKind kind) {
  sweep.objectRuns =
      op.objectRunsOffset < 0 ? nullptr : plan.objectRuns.data() + op.objectRunsOffset;
  // The families whose constraints span many particles, each projected by its own system.
  switch (op.family) {
    case ConstraintFamily::Pressure:
      if (constraints.pressure.size() > 0)
        projectPressure(constraints.pressure, sweep.particles, sweep.h, sweep.objectRuns);
      return;
    case ConstraintFamily::Attachment:
      if (constraints.attachments.size() > 0)
        projectAttachments(constraints.attachments, sweep.particles, sweep.h, sweep.objectRuns);
      return;
    case ConstraintFamily::Rigidity:
      if (constraints.shapeMatching.size() > 0)
        projectShapeMatching(constraints.shapeMatching, sweep.particles,
                             plan.sweepsOfFamily[familyIndex(ConstraintFamily::Rigidity)],
                             sweep.objectRuns);
      return;
    case ConstraintFamily::Density:
      if (constraints.liquid.size() > 0)
        projectDensity(
            constraints.liquid, sweep.particles,
            kLiquidContactReach * constraints.liquid.kernels.radius /
                Real(std::max(1, plan.sweepsOfFamily[familyIndex(ConstraintFamily::Density)])),
            sweep.objectRuns);
      return;
    default:
      break;
  }
  forEachPoolOf(op.family, constraints, [&](auto& pool, auto tag) {
    using Tag = decltype(tag);
    if constexpr ((Tag::kPaths & kTetherLayers) != 0)
      solveTethers(kind, pool, sweep);
    else
      solveSweep<typename Tag::Kernel, Tag::kPaths>(kind, pool, sweep);
  });
}

// Runs the substep's sweep plan, contacts last in each round, with the plain generic kernels
// (optimizedPaths off: they read each particle's inverse mass from the pool, not a batch's copy,
// so that a particle at w = 0 stays put) in place and without Jacobi's acceleration.
void sweepPinned(SolvePools& pools, const SolveSettings& settings, const SubstepContext& context) {
  SweepContext sweep{pools.particles, context.h, settings.relaxation, nullptr};
  sweep.chebyshevRho = 0;
  sweep.optimizedPaths = false;
  for (const SweepOp& op : pools.plan.ops) {
    runSweepOp(op, pools.plan, pools.constraints, sweep, SolverKind::ColoredGaussSeidel);
    if (op.endsRound) projectAllContacts(pools, SolverKind::ColoredGaussSeidel);
  }
  pools.constraints.forEach([](auto& pool) { bookVertexMultipliers(pool); });
}

// The fail-safe holds the free particles of a pair crossing a body without free particles (a
// collider, a pinned group) to that body's rigid motion, but leaves their neighbours where the
// sweeps put them, which assumed the held ones would move too: their edges stretch. Where the
// same hold comes back substep after substep (a cloth sliding down off a needle's tip, held at
// the tip), the stretch grows with every one: edges at five times their rest length within a few
// frames. The substep's sweeps run once more with those particles pinned to where the body took
// them and pull the neighbours back towards them (four rounds instead of the scene's ten left a
// cloth on a needle at 3.6 times); the next fail-safe pass checks the motion they leave. The
// particles of impact zones are not pinned: a zone keeps its momentum, and pinning it would
// hand its neighbours' momentum to nothing. Returns whether any particle was pinned.
bool relaxAroundHeldParticles(SolvePools& pools, const SolveSettings& settings,
                              const SubstepContext& context) {
  PrimitiveContactPool& contacts = pools.primitiveContacts;
  ParticlePool& particles = pools.particles;
  contacts.held.clear();
  contacts.heldInverseMass.clear();
  for (std::size_t i = 0; i < contacts.carryPrecedence.size(); ++i)
    if (contacts.carryPrecedence[i] > PrimitiveContactPool::kImpactZonePrecedence &&
        particles.w[i] > 0) {
      contacts.held.push_back(static_cast<Index>(i));
      contacts.heldInverseMass.push_back(particles.w[i]);
      particles.w[i] = 0;
    }
  if (contacts.held.empty()) return false;
  sweepPinned(pools, settings, context);
  for (std::size_t k = 0; k < contacts.held.size(); ++k)
    particles.w[contacts.held[k]] = contacts.heldInverseMass[k];
  return true;
}

// After the sweeps: friction of the primitive contacts; the candidate pairs of the actual motion
// x → p where contacts and collider responses moved a particle off its predicted course and out
// of its bounds (rather than the motion cut back to the bounds: a clamp would hold a particle
// against the contact that pushed it, and stretch the cloth around it); then the fail-safe.
void finishPrimitiveContacts(SolvePools& pools, const SolveSettings& settings,
                             const SubstepContext& context, SolveReport& report) {
  const SolverKind kind = settings.sweepKind;
  applyPrimitiveFriction(pools.primitiveContacts, pools.particles, kind);
  // Friction between two movable primitives can drag a particle into a collider it rests on (a
  // layer of a pile sliding down over the bottom one on the ground, which then ends the substep
  // below the ground): the collider contacts are projected once more, last, as in every round.
  // Their own friction is bounded over the whole substep, so this adds none.
  if (pools.contacts.size() > 0)
    projectContacts(pools.contacts, pools.colliders, pools.particles, kind);
  ParticlePool& particles = pools.particles;
  // The fail-safe may carry particles with a kinematic body beyond their bounds, where pairs
  // outside the candidate set could cross: the pairs of the new motion are found and checked
  // again. Particles still outside after the last pass are counted with the unresolved pairs
  // (on the turning-box torture scene two passes were the most any substep needed).
  std::size_t outside = countOutsideParticleBounds(pools.candidates, particles.p);
  bool relaxed = false;
  for (int pass = 0; pass < kCrossingPasses && (pass == 0 || outside > 0 || relaxed); ++pass) {
    if (outside > 0) {
      redetectFromSolve(pools, report);
      measureStartDistances(pools.primitiveContacts, pools.candidates, pools.primitives, particles);
    }
    const CrossingReport crossing = resolveCrossings(pools.primitiveContacts, pools.candidates,
                                                     pools.primitives, pools.colliders, particles);
    report.crossing.clamped += crossing.clamped;
    report.crossing.crossings += crossing.crossings;
    report.crossing.stopped += crossing.stopped;
    report.crossing.carried += crossing.carried;
    report.crossing.squeezed += crossing.squeezed;
    report.crossing.zones += crossing.zones;
    report.crossing.stoppedZones += crossing.stoppedZones;
    report.crossing.turnsDropped += crossing.turnsDropped;
    report.crossing.rounds += crossing.rounds;
    // A later pass checks the earlier one's leftovers again: only the last one's count.
    report.crossing.unresolved = crossing.unresolved;
    // After the first pass only, and only where it carried particles with a body (impact zones
    // alone pin nothing): the later passes check what it and the sweeps left.
    relaxed =
        crossing.carried > 0 && pass == 0 && relaxAroundHeldParticles(pools, settings, context);
    if (relaxed) ++report.crossing.relaxations;
    outside = countOutsideParticleBounds(pools.candidates, particles.p);
  }
  report.crossing.unresolved += outside;
}

}  // namespace

SolveReport solveConstraints(SolvePools& pools, const SolveSettings& settings,
                             const SubstepContext& context) {
  SolveReport report;
  if (settings.cascade) runCascade(pools, settings, context, report);
  // Sweeps of `multigrid` itself take its default smoother, colored Gauss–Seidel.
  const SolverKind kind = settings.sweepKind == SolverKind::Multigrid
                              ? SolverKind::ColoredGaussSeidel
                              : settings.sweepKind;
  ConstraintPools& constraints = pools.constraints;
  ParticlePool& particles = pools.particles;
  const SweepPlan& plan = pools.plan;
  const bool anyContacts = pools.contacts.size() > 0 || pools.primitiveContacts.size() > 0;
  constraints.forEach([](auto& pool) { resetMultipliers(pool); });
  PressurePool& pressure = constraints.pressure;
  AttachmentPool& attachments = constraints.attachments;
  if (attachments.size() > 0) startAttachmentSubstep(attachments, context.endTime);
  if (pressure.size() > 0) startPressureSubstep(pressure, context.time, context.h);
  if (constraints.liquid.size() > 0) startLiquidSubstep(constraints.liquid, particles);
  SweepContext sweep{particles, context.h, settings.relaxation, nullptr};
  sweep.chebyshevRho = settings.chebyshevRho;
  // A registered family that did not opt into Jacobi's acceleration turns it off for every
  // family: extrapolated stretch against a hard, unaccelerated constraint on the same particles
  // was seen to diverge (a cloth corner held on a plane, double build), and plain Jacobi
  // converges, only more slowly.
  for (const UserConstraintPool& pool : constraints.user)
    if (pool.size() > 0 && !pool.family.jacobiAcceleration) sweep.chebyshevRho = 0;
  sweep.sheetRelaxation = settings.sheetRelaxation;
  sweep.optimizedPaths = settings.optimizedPaths;
  // The colored sweeps weigh supported particles from the second round on, once the first has
  // shown which contacts press: their batches read the per-constraint inverse masses always, their
  // generic projections while `weighedEnds` is set (outside it they read the particle pool's, which
  // the fail-safe's pinned sweeps set to 0); the Jacobi sweeps read split masses.
  const bool weighsSupported = anyContacts && settings.supportedInverseMassScale != 1 &&
                               kind == SolverKind::ColoredGaussSeidel;
  int roundsDone = 0;
  for (const SweepOp& op : plan.ops) {
    runSweepOp(op, plan, constraints, sweep, kind);
    if (!op.endsRound) continue;
    if (anyContacts) report.contactSeconds += timed([&] { projectAllContacts(pools, kind); });
    if (roundsDone == 0 && weighsSupported) {
      report.supportedParticles =
          weighSupportedParticles(constraints, pools.contacts, pools.primitiveContacts, particles,
                                  settings.supportedInverseMassScale);
      sweep.weighedEnds = report.supportedParticles > 0;
    }
    // The repeated cascade, from the positions the fine sweeps left.
    if (++roundsDone < plan.rounds && settings.cascade && settings.cascadeEvery > 0 &&
        roundsDone % settings.cascadeEvery == 0)
      runCascade(pools, settings, context, report);
  }
  sweep.weighedEnds = false;
  releaseSupportedParticles(constraints, pools.contacts, particles);
  // Weighed, the sweeps move a supported particle's free neighbours farther than their predicted
  // motion: those that reached a collider get their contacts, as after a cascade.
  if (report.supportedParticles > 0 && pools.colliders.size() > 0 &&
      addReachedContacts(pools.contacts, pools.colliders, particles, context.h) > 0) {
    report.contactSeconds +=
        timed([&] { projectContacts(pools.contacts, pools.colliders, particles, kind); });
    ++report.colliderRedetections;
  }
  constraints.forEach([](auto& pool) { bookVertexMultipliers(pool); });
  // Counted in the pool (World::brokenAttachments).
  if (attachments.size() > 0) breakAttachments(attachments, context.h);
  report.collapsedPressureProjections = pressure.collapsedProjections;
  report.limitedPressureSteps = pressure.limitedSteps;
  pressure.collapsedProjections = pressure.limitedSteps = 0;
  report.limitedDensityMoves = constraints.liquid.limitedMoves;
  constraints.liquid.limitedMoves = 0;
  if (plan.ops.empty() && anyContacts)
    report.contactSeconds += timed([&] { projectAllContacts(pools, kind); });
  if (pools.colliders.size() > 0)
    report.contactSeconds += timed([&] {
      report.missedContacts =
          resolveMissedContacts(pools.contacts, pools.colliders, pools.particles);
    });
  if (pools.primitives.total() > 0)
    report.contactSeconds +=
        timed([&] { finishPrimitiveContacts(pools, settings, context, report); });
  return report;
}

std::uint64_t countProjections(const ConstraintPools& pools, const ParticlePool& particles,
                               const SweepPlan& plan) {
  std::uint64_t total = 0;
  for (const SweepOp& op : plan.ops) {
    const std::uint8_t* runs =
        op.objectRunsOffset < 0 ? nullptr : plan.objectRuns.data() + op.objectRunsOffset;
    if (op.family == ConstraintFamily::Pressure || op.family == ConstraintFamily::Attachment ||
        op.family == ConstraintFamily::Rigidity || op.family == ConstraintFamily::Density) {
      total += pools.count(op.family);  // one projection per constraint, whatever its size
      continue;
    }
    forEachPoolOf(op.family, pools, [&](const auto& pool, auto) {
      if (!runs) {
        total += pool.size();
        return;
      }
      for (std::size_t c = 0; c < pool.size(); ++c)
        total += runs[particles.phase[pool.particle(c, 0)]] != 0;
    });
  }
  return total;
}

}  // namespace nucleon
