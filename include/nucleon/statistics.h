// What a world reports about itself: the per-stage profile and the quality measures.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace nucleon {

// Wall-clock seconds each stage of step() has taken since the world was created or the profile
// was last reset (the engine's own profile). `solve` excludes the contact projections, which are
// `collisions` (with contact detection); `projections` counts constraint projections in the solve
// stage; `animate` is the animated colliders' two stages (posing them before predict, placing
// them on their track after update); `broadPhase` and `narrowPhase` are the collision detection
// between primitives (BVH and candidate pairs; primitive contacts), while `collisions` holds
// collider contacts, the projection of every contact, friction, the crossing fail-safe and
// restitution. `cascade` is the part of `solve` that the multigrid cascade took: its coarse
// sweeps and prolongations, the contact limits and projections between its levels, and the
// collider contacts found again after it.
struct StepProfile {
  double forces = 0;
  double animate = 0;
  double predict = 0;
  double solve = 0;
  double collisions = 0;
  double broadPhase = 0;
  double narrowPhase = 0;
  double update = 0;
  double cascade = 0;
  // Between substeps: tearing (Material::tear) after a step, and the rebuild of the derived
  // tables (colouring, incidence, levels, primitives, plan) a changed topology asks for.
  double tear = 0;
  double derivedTables = 0;
  std::uint64_t steps = 0;
  std::uint64_t substeps = 0;
  std::uint64_t projections = 0;
};

// Repairs the step made to keep the state usable, counted since the world was created. Each one
// means that the solver did not resolve something it should have (or that the input was bad); a
// healthy run has none.
struct Recoveries {
  // Particles whose new position or velocity was not finite: they kept their position at the
  // start of the substep and lost their velocity.
  std::uint64_t nonFinite = 0;
  // Free particles that ended a solve inside a collider without a contact (they moved farther
  // than the contact pool's reach): pushed out to the surface.
  std::uint64_t missedContacts = 0;
  // Projections of a gas-filled surface (Material::pressure) that enclosed less than 1% of its
  // rest volume, or was turned inside out: the gas's pressure was taken at 1% of the rest volume,
  // so that it stays finite and pushes the surface back out.
  std::uint64_t collapsedPressureVolumes = 0;
  // Gas projections whose Newton step asked to change the volume by more than half of it, held to
  // half: the linearised volume is far off there (a surface collapsing or torn inside out).
  std::uint64_t limitedPressureSteps = 0;
  // Moves of a liquid particle by one density projection shortened to the kernel radius over the
  // substep's density sweeps, so that the projections together stay within the collider contacts'
  // reach: a particle packed far beyond rest density (a liquid driven into a corner at a speed
  // its substeps do not resolve).
  std::uint64_t limitedDensityMoves = 0;
  std::uint64_t firstStep = 0;  // 1-based step of the first repair; 0 if there was none
  std::uint64_t total() const {
    return nonFinite + missedContacts + collapsedPressureVolumes + limitedPressureSteps +
           limitedDensityMoves;
  }
};

// What the collision stages did since the world was created: pairs and contacts summed over
// substeps, the displacement bound and the crossing fail-safe's work (ARCHITECTURE.md §4)
// (their time is StepProfile's broadPhase, narrowPhase and collisions).
struct CollisionReport {
  // Broad-phase runs: at most one per step, plus the refreshes.
  std::uint64_t broadPhases = 0;
  // Steps that started from the last step's pairs, complete and tight, with no search at all.
  std::uint64_t keptPairSets = 0;
  std::uint64_t broadPhaseRefreshes = 0;  // runs within a step: a prediction left its bounds
  std::uint64_t solveRedetections = 0;    // runs after a solve that left the bounds
  // Refreshes and re-detections that found again only the pairs of the primitives whose particles
  // had left their bounds (few of them), rather than every pair.
  std::uint64_t incrementalBroadPhases = 0;
  // Collider contact pools refilled after the multigrid cascade, or the sweeps that weighed
  // supported particles, had carried a particle without a contact within a collider's reach
  // (particle_contacts.h, addReachedContacts).
  std::uint64_t colliderRedetections = 0;
  // Particles a pressed contact with friction supported in a substep, summed over the substeps:
  // their constraints were reweighed in the colored sweeps
  // (SolverSettings::supportedInverseMassScale).
  std::uint64_t supportedParticles = 0;
  std::uint64_t candidatePairs = 0;    // broad-phase pairs, summed over substeps
  std::uint64_t contacts = 0;          // primitive contacts made, summed over substeps
  std::uint64_t clampedParticles = 0;  // particles held within their broad-phase bounds
  std::uint64_t crossings = 0;         // crossing pairs the fail-safe stopped
  std::uint64_t stoppedParticles = 0;  // particle positions the fail-safe reset
  std::uint64_t carriedParticles = 0;  // … of them carried by a kinematic body's rigid motion
  // Squeezes: crossings of a particle carried with one collider body with another body, after
  // which the fail-safe held it in the gap between the two (primitive_contacts.h).
  std::uint64_t squeezes = 0;
  // Impact zones the fail-safe moved as rigid bodies keeping their particles' momentum (summed
  // over its passes and substeps; the rest of the reset positions are theirs).
  std::uint64_t impactZones = 0;
  // … of them stopped where the substep began, their momentum lost, to end the fail-safe's rounds,
  // or moved only part of their rigid motion (or none) because the whole of it would have entered
  // the ground or a sphere.
  std::uint64_t stoppedImpactZones = 0;
  // … and turns of a quarter or more in one substep the zones left out, translating only.
  std::uint64_t impactZoneTurnsDropped = 0;
  // Substeps in which the fail-safe carried particles with a body and the sweeps then ran again
  // with those particles pinned, pulling their neighbours back to them.
  std::uint64_t carryRelaxations = 0;
  std::uint64_t unresolvedPairs = 0;  // pairs still crossing at the fail-safe's round limit
  // Errors of the broad phase's tree builder (Embree's device), each build that failed having
  // fallen back to a tree of one leaf: complete, but every pair of its boxes is tested.
  std::uint64_t broadPhaseTreeErrors = 0;
  // Steps that took more substeps than the solver's setting because a kinematic particle (a
  // moving collider's or an animated pin, SolverSettings::maxKinematicTravel) or a free particle
  // near a collider (SolverSettings::maxImpactTravel) moved fast; of those, the steps the free
  // particles raised further than the kinematic ones did; the most substeps any step took; and
  // the steps that needed more than SolverSettings::maxSubsteps and took that many.
  std::uint64_t raisedSubstepSteps = 0;
  std::uint64_t impactRaisedSteps = 0;
  // Of those, the steps that held the last step's count while the world was still stretched
  // after a strike (kImpactHoldStrain).
  std::uint64_t impactHeldSteps = 0;
  std::uint64_t mostSubsteps = 0;
  std::uint64_t cappedSubstepSteps = 0;
  std::uint64_t firstCrossingStep = 0;  // 1-based step of the first fail-safe action; 0 if none
};

// What tearing (Material::tear) did since the world was created.
struct TearReport {
  std::uint64_t tornEdges = 0;    // edges cut in two (each now borders one triangle per side)
  std::uint64_t newVertices = 0;  // vertex splits: spare particles taken into use
  // Tears refused because the cloth's spare particles had run out (Tear::maxNewVertices).
  std::uint64_t refusedTears = 0;
  std::uint64_t tearSteps = 0;       // steps after which at least one vertex split
  std::uint64_t spareParticles = 0;  // spare particles reserved by tearable cloths, used or not
};

// A pressured surface's state (World::pressure).
struct PressureReading {
  double volume = 0;      // m³, enclosed now
  double restVolume = 0;  // m³, enclosed in the rest shape
  double pressure = 0;    // Pa, absolute
  double gas = 0;         // c·M, Pa·m³
  // Pa, absolute: the ambient plus the pressure difference the last substep's solve applied to
  // the surface (its multiplier over h²). Where the solve converged it is `pressure`.
  double appliedPressure = 0;
};

// A liquid's state (World::liquid), per particle in the object's vertex order and summarised.
struct LiquidReading {
  double restDensity = 0;       // kg/m³
  std::vector<double> density;  // SPH density at the positions now, kg/m³
  // The pressure the last substep's density constraints applied, −ρ0 Λ / (m h²) (Pa above the
  // free surface's; Λ the particle's multipliers summed over the substep's projections, m its
  // mass).
  std::vector<double> pressure;
  // Of the compression max(ρ/ρ0 − 1, 0), which the constraints hold to 0: mean, 99th percentile
  // (nearest rank) and max. A particle at the free surface, short of neighbours, has none.
  double meanCompression = 0, compressionP99 = 0, maxCompression = 0;
  // Neighbours the search dropped beyond a particle's list (all liquids, since creation): a
  // particle packed far beyond rest density. 0 in a sound state.
  std::uint64_t droppedNeighbours = 0;
};

// Quality measures of the current state (ARCHITECTURE.md §6).
struct Measures {
  double maxStrain = 0;   // max |L/L0 − 1| over stretch constraints
  double meanStrain = 0;  // mean of the same
  // 99th percentile of the same (nearest rank: the smallest value that at least 99% of the
  // constraints do not exceed); unlike the max, one bad edge does not decide it.
  double strainP99 = 0;
  // The two signs of the strain apart: the largest L/L0 − 1 and the largest 1 − L/L0, each 0
  // when no constraint is longer (shorter) than at rest. Cloth resists stretch and buckles under
  // compression, so the two mean different things.
  double maxStretch = 0;
  double maxCompression = 0;
  // Largest (d − d_rest)/d_rest over the tethers (a tether only limits from above); 0 when there
  // are none or none is violated.
  double maxTetherViolation = 0;
  double kineticEnergy = 0;
  double potentialEnergy = 0;  // −m g·x summed over free particles
  std::size_t nanCount = 0;    // non-finite position or velocity components now
  double minHeight = 0;        // lowest particle coordinate along −gravity (y if gravity is 0)
  double volumeRatio = -1;     // current / rest volume of closed objects; −1 if there are none
  std::size_t contacts = 0;    // particles touching the ground plane or a sphere collider
  // Free particles behind the ground's, a plane's or a sphere's surface itself (deeper than its
  // thickness, by more than 1 µm): contacts that failed. 0 in a sound state.
  std::size_t insideColliders = 0;
  // Pairs of surface triangles (cloth, solid boundary and collider triangles, of all objects
  // together) that share no vertex and intersect, touching included; decided exactly
  // (systems/diagnostics/triangle_intersections.h). A state free of interpenetration has 0.
  std::size_t intersections = 0;
};

}  // namespace nucleon
