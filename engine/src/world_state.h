// Everything a World owns: the component pools and the settings the systems read.
// Internal to the library (the public World hides it behind a pointer); tests and benchmarks in
// this tree include it to reach the pools directly.
#pragma once

#include <memory>
#include <vector>

#include <tbb/task_arena.h>

#include "components/attachment_pool.h"
#include "components/candidate_pairs.h"
#include "components/collider_pool.h"
#include "components/collision_primitives.h"
#include "components/constraint_pools.h"
#include "components/contact_pool.h"
#include "components/kinematic_tracks.h"
#include "components/level_hierarchy.h"
#include "components/objects.h"
#include "components/particles.h"
#include "components/pressure_pool.h"
#include "components/primitive_bvh.h"
#include "components/primitive_contact_pool.h"
#include "components/shape_match_pool.h"
#include "components/sweep_plan.h"
#include "nucleon/world.h"
#include "systems/dynamics/impact_travel.h"
#include "systems/setup/build_collision_primitives.h"

namespace nucleon {

class StepGraph;

struct ImpactHold {
  int substeps = 0;
  int stepsLeft = 0;
  bool travelRaised = false;
};

struct WorldState {
  ParticlePool particles;
  ConstraintPools constraints;
  std::vector<ObjectRecord> objects;
  // The handles' slots (ObjectSlot), and the slots free for reuse since their objects were
  // removed.
  std::vector<ObjectSlot> objectSlots;
  std::vector<Index> freeObjectSlots;
  Vec3 gravity = Vec3(0, Real(-9.81), 0);
  SolverSettings solver;
  // The colliders as the API defined them; `colliders` is the solver's list built from them.
  GroundPlane ground;
  std::vector<PlaneCollider> planes;
  std::vector<SphereCollider> spheres;
  ColliderPool colliders;  // static lifetime: rebuilt when a collider is added or changed
  ContactPool contacts;    // per-substep lifetime: refilled by contact detection every substep
  SweepPlan plan;          // from solver.schedule and the objects' schedules
  // The multigrid backend's level hierarchies (static, built with the derived tables when that
  // backend is chosen) and its cascade's scratch (the positions when the cascade began).
  LevelHierarchies hierarchies;
  CascadeScratch cascade;  // the cascade's scratch
  // Collisions between primitives (ARCHITECTURE.md §4): the primitive lists (static, rebuilt with
  // the derived tables), the object pairs the API excluded, the broad phase's BVH and candidate
  // pairs and the primitive contacts (per substep), and what the collision stages did.
  CollisionPrimitives primitives;
  std::vector<std::uint64_t> excludedObjectPairs;
  std::vector<VertexSetExclusion> excludedVertexSets;  // global particle indices
  PrimitiveBvh bvh;
  CandidatePairs candidates;
  PrimitiveContactPool primitiveContacts;
  CollisionReport collisionReport;
  KinematicTracks kinematics;  // static lifetime: one track per animated collider or pin group
  // The smallest contact distance between a primitive of an animated object (collider or pinned)
  // and a primitive that moves (0: no such pair), rebuilt with the derived tables: the default
  // bound on how far an animated particle may travel in one substep derives from it
  // (SolverSettings::maxKinematicTravel).
  double kinematicContactDistance = 0;
  // Per object, its median rest edge length (0: a collider, or no edges), rebuilt with the
  // derived tables: the default bound on how far a free particle about to strike a collider may
  // travel in one substep derives from it (SolverSettings::maxImpactTravel).
  std::vector<double> objectEdgeLength;
  ImpactTravelScratch impactScratch;  // scratch of the substeps' count (per-step lifetime)
  // The impact rule's count carried to the next step (holdImpactSubsteps in world.cpp): the
  // count to hold (0: none), the steps a hold may still last, and whether the last step was
  // raised for its particles' travel (which renews them).
  ImpactHold impactHold;
  bool topologyDirty = true;    // incidence, coloring and plan need rebuilding
  Recoveries recoveries;        // repairs since creation
  TearReport tearReport;        // tears since creation (systems/topology/tear_cloth.h)
  std::uint64_t stepCount = 0;  // steps taken since creation
  // Simulated seconds since creation, advanced after every substep; animations are functions of
  // it. The substep being run, with its place in time, is the step graph's SubstepContext.
  double time = 0;
  double lastSubstep = 0;  // the last substep's h (s), for readings of its multipliers
  StepProfile profile;     // the engine's own per-stage timing
};

// Rebuilds the tables derived from the topology when it changed (world.cpp); every step calls it
// first.
void buildDerivedTablesIfDirty(WorldState& s);

struct World::Impl {
  WorldState state;
  int threads = 0;
  std::unique_ptr<tbb::task_arena> arena;
  std::unique_ptr<StepGraph> graph;
  ~Impl();
};

}  // namespace nucleon
