// The solve stage of a substep, in one place: the multigrid cascade when due, the sweeps of the
// plan round by round with the chosen backend, contact projection after every round, then the
// collider contacts the motion missed, primitive friction, re-detection of candidate pairs the
// motion left, and the crossing fail-safe. The step graph calls it once per substep; nothing in it
// calls back into the step graph.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "components/attachment_pool.h"
#include "components/candidate_pairs.h"
#include "components/collider_pool.h"
#include "components/collision_primitives.h"
#include "components/constraint_pools.h"
#include "components/contact_pool.h"
#include "components/level_hierarchy.h"
#include "components/objects.h"
#include "components/particles.h"
#include "components/pressure_pool.h"
#include "components/primitive_bvh.h"
#include "components/primitive_contact_pool.h"
#include "components/shape_match_pool.h"
#include "components/sweep_plan.h"
#include "nucleon/solver_settings.h"
#include "systems/collision/primitive_contacts.h"
#include "systems/solver/jacobi_chebyshev.h"
#include "systems/substep_context.h"

namespace nucleon {

// How the solve runs, from SolverSettings (solveSettingsOf).
struct SolveSettings {
  SolverKind sweepKind = SolverKind::ColoredGaussSeidel;  // the fine sweeps: multigrid's smoother
  Real relaxation = 1;
  Real chebyshevRho = kChebyshevSpectralRadius;
  Real sheetRelaxation = 0;
  Real supportedInverseMassScale = 1;  // SolverSettings::supportedInverseMassScale
  bool optimizedPaths = true;
  // The multigrid cascade: before the first round, then after every `cascadeEvery` rounds (0:
  // only before the first), with `sweepsPerLevel` sweeps of each coarse level.
  bool cascade = false;
  int cascadeEvery = 0;
  std::span<const int> sweepsPerLevel;
  Real cascadeRelaxation = 1;  // ω of the coarse sweeps
};
// Refers to solver.sweepsPerLevel: the settings live as long as `solver`.
SolveSettings solveSettingsOf(const SolverSettings& solver);

// The pools the solve reads and writes.
struct SolvePools {
  ConstraintPools& constraints;
  ParticlePool& particles;
  const SweepPlan& plan;
  ContactPool& contacts;
  const ColliderPool& colliders;
  PrimitiveContactPool& primitiveContacts;
  CandidatePairs& candidates;
  const CollisionPrimitives& primitives;
  PrimitiveBvh& bvh;
  const LevelHierarchies& hierarchies;
  std::span<const ObjectRecord> objects;
  CascadeScratch& cascade;
};

// What one solve did, for the profile, the collision report and the repair log.
struct SolveReport {
  double contactSeconds = 0;  // contact projection, friction and fail-safe: booked as collisions
  std::size_t missedContacts = 0;           // particles pushed out of colliders they entered
  std::size_t redetections = 0;             // candidate pairs found again after the sweeps
  std::size_t incrementalRedetections = 0;  // of which only around the particles off course
  std::size_t colliderRedetections = 0;     // collider contacts found again after a cascade
  std::size_t supportedParticles = 0;  // weighed by their pressed contacts (supported_particles.h)
  std::size_t cascadeProjections = 0;
  double cascadeSeconds = 0;  // the cascades of the substep, within the solve's time
  std::uint64_t collapsedPressureProjections = 0;  // gas pressures taken at the least volume
  std::uint64_t limitedPressureSteps = 0;          // gas steps held to half the volume
  std::uint64_t limitedDensityMoves = 0;           // liquid moves shortened (projectDensity)
  CrossingReport crossing;
};

// Resets every multiplier (XPBD's λ lives for one substep) and runs plan.ops on particles.p,
// projecting the collider contact pool and the primitive contact pool after each round (and once
// when the plan has no sweeps), so that pressure and resting contact are solved with the
// constraints and not after them.
SolveReport solveConstraints(SolvePools& pools, const SolveSettings& settings,
                             const SubstepContext& context);

// Constraint projections one substep of `plan` performs (for throughput figures).
std::uint64_t countProjections(const ConstraintPools& pools, const ParticlePool& particles,
                               const SweepPlan& plan);

}  // namespace nucleon
