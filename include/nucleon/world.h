// The public entry point: a World holds every object of a simulation and steps it.
//
//   nucleon::World world;
//   nucleon::ClothDef cloth = nucleon::gridCloth({...});
//   cloth.pins = {0, 63};
//   auto id = world.addCloth(cloth);
//   for (int frame = 0; frame < 120; ++frame) world.step(1.0 / 60);
//   std::span<const nucleon::Vec3> x = world.positions(id);  // a view into the pool, no copy
//
// Threading: step() runs its systems as a oneTBB flow graph inside the world's own task arena
// (setThreads, default: all cores). A World is not itself thread-safe: call it from one thread.
#pragma once

#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "nucleon/attachments.h"
#include "nucleon/colliders.h"
#include "nucleon/errors.h"
#include "nucleon/material.h"
#include "nucleon/object_def.h"
#include "nucleon/schedule.h"
#include "nucleon/solver_settings.h"
#include "nucleon/statistics.h"
#include "nucleon/types.h"
#include "nucleon/user_constraint.h"

namespace nucleon {

class World {
 public:
  World();
  ~World();
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  // Each add* validates the definition and throws std::invalid_argument (or MeshError, derived
  // from std::runtime_error) with a message naming the problem; the world is unchanged then.
  ObjectId addCloth(const ObjectDef& def);      // triangles; stretch on every edge
  ObjectId addRope(const ObjectDef& def);       // edges; stretch on every edge
  ObjectId addSolid(const ObjectDef& def);      // tets; stretch on every edge
  ObjectId addParticles(const ObjectDef& def);  // points only
  ObjectId addCollider(const ObjectDef& def);   // triangles; static or kinematic (never moved by
                                                // the solver; moves with def.velocity or is
                                                // animated by def.motion)

  // The positions (one per vertex of the collider, in its vertex order) a collider reaches at the
  // end of the next step; it moves to them in a straight line, evenly over the step's substeps,
  // and then holds still until it is given new targets. For colliders driven from outside
  // (animation data, another program); it replaces the collider's constant velocity. Throws
  // std::invalid_argument for an id that is not a collider, a collider animated by a motion, a
  // count other than the collider's vertex count or a non-finite position.
  void setColliderTargets(ObjectId id, std::span<const Vec3> positions);

  void setGravity(const Vec3& g);
  Vec3 gravity() const;
  void setGround(const GroundPlane& ground);  // throws std::invalid_argument on non-finite values
  const GroundPlane& ground() const;
  // Adds a static sphere collider; throws std::invalid_argument on non-finite values or a
  // radius that is not positive.
  void addSphereCollider(const SphereCollider& sphere);
  std::span<const SphereCollider> sphereColliders() const;
  // Adds a static plane of any orientation; throws std::invalid_argument on non-finite values or
  // a zero normal.
  void addPlaneCollider(const PlaneCollider& plane);
  std::span<const PlaneCollider> planeColliders() const;
  void setSolver(const SolverSettings& settings);
  const SolverSettings& solver() const;
  // Worker threads for step(); 0 = all cores. Results of the Gauss–Seidel solver do not depend on
  // it.
  void setThreads(int threads);
  int threads() const;

  // Advances by dt seconds in solver().substeps substeps, or more where a moving collider or an
  // animated pin group would otherwise go farther than SolverSettings::maxKinematicTravel in one
  // (counted in collisionReport()). dt must be finite and in (0, 1] s; anything else throws
  // std::invalid_argument and leaves the state untouched.
  void step(double dt);
  // Simulated seconds since the world was created: the time motions' keyframes refer to.
  double time() const;
  // Steps taken since the world was created (a checkpoint carries the count).
  std::uint64_t steps() const;

  std::size_t particleCount() const;
  std::size_t objectCount() const;  // objects in the world now (removed ones not counted)
  std::span<const Vec3> positions() const;  // all particles, a view into the pool
  std::span<const Vec3> velocities() const;
  std::span<const Real> inverseMasses() const;
  std::span<const Vec3> positions(ObjectId id) const;  // one object's particles
  std::string name(ObjectId id) const;
  ObjectKind kind(ObjectId id) const;
  ObjectId objectAt(std::size_t index) const;
  // Surface triangles of an object in its local vertex indices: a cloth's or collider's triangles,
  // a solid's boundary triangles; empty for ropes and particles.
  std::span<const std::array<Index, 3>> surfaceTriangles(ObjectId id) const;
  std::span<const std::array<Index, 2>> curveEdges(ObjectId id) const;  // a rope's segments
  Real thickness(ObjectId id) const;
  // Advice on the scene as built, one line each, naming the object: a cloth whose contact
  // distance (its thickness twice with self-collision, or its thickness plus a collider's) exceeds
  // its median edge length, which over a collider's sharp edges stretches edges that straddle them
  // (bench/results/2core-AMD-EPYC/torture.md, the 128² drape); a registered family with
  // constraints under the multigrid backend, whose coarse levels do not see it. Empty when there
  // is none.
  std::vector<std::string> warnings() const;

  std::size_t constraintCount(ConstraintFamily family) const;

  // Constraint families of your own (nucleon/user_constraint.h). Registering validates the
  // definition and throws std::invalid_argument on a bad one (empty or taken name, arity outside
  // [1, kMaxUserConstraintArity], no evaluate function); the family is then swept by every
  // backend, `iterations` times per substep unless a schedule names it. addConstraint adds one
  // constraint on `particles` (the object's local vertex indices, arity of them) with
  // `rest` (restSize values); it throws std::invalid_argument on a wrong count, an index out of
  // the object or a non-finite value. A constraint belongs to the object for per-object
  // schedules.
  ConstraintFamily registerConstraintFamily(const UserConstraintFamilyDef& def);
  void addConstraint(ObjectId object, ConstraintFamily family, std::span<const Index> particles,
                     std::span<const Real> rest, const ConstraintCompliance& compliance = {});
  // The built-in families and the registered ones: ids 0 … familyCount() − 1.
  std::size_t familyCount() const;
  std::string familyName(ConstraintFamily family) const;
  // A family by its schedule name, built-in or registered; false if there is none.
  bool findConstraintFamily(const std::string& name, ConstraintFamily& out) const;
  // Sweeps of a family in each substep under the current schedule (most of any object's).
  int sweepsPerSubstep(ConstraintFamily family) const;
  Measures measure() const;
  // The state of a cloth's pressure (Material::pressure) now (PressureReading): its enclosed
  // volume and rest volume (m³), the pressure inside (Pa, absolute: c·M / V for a gas; for
  // KeepVolume the pressure the last solve applied), the gas amount c·M (Pa·m³; 0 for
  // KeepVolume) and the pressure the last substep's solve applied. Throws std::invalid_argument
  // for an object without pressure.
  PressureReading pressure(ObjectId id) const;
  // The state of a liquid (Material::liquid) now (LiquidReading). Throws std::invalid_argument
  // for an object that is not a liquid.
  LiquidReading liquid(ObjectId id) const;
  bool isLiquid(ObjectId id) const;
  bool hasPressure(ObjectId id) const;
  // Repairs the steps have made since the world was created (non-finite resets, particles pushed
  // out of colliders they should never have entered): zero in a healthy run.
  const Recoveries& recoveries() const;
  // Collisions between objects' primitives (vertices, edges, faces; every object collides with
  // every other and with itself unless its material or excludeCollisions says otherwise): what
  // the collision stages did since the world was created.
  const CollisionReport& collisionReport() const;
  // What tearing (Material::tear) did since the world was created: edges cut, vertices split,
  // tears refused for want of spare particles.
  const TearReport& tearReport() const;
  // The two objects (the same one twice: its self-collision) never collide with each other.
  void excludeCollisions(ObjectId a, ObjectId b);
  // The primitives of `a` whose vertices are all in `verticesA` never collide with those of `b`
  // whose vertices are all in `verticesB` (local indices; a and b may be the same object). At most
  // 16 such pairs of sets; throws std::invalid_argument beyond, or on an index out of range.
  void excludeCollisions(ObjectId a, std::span<const Index> verticesA, ObjectId b,
                         std::span<const Index> verticesB);

  // Attachments (nucleon/attachments.h). addAttachment validates one (objects valid, vertex
  // indices in range, weights finite and summing to 1, non-negative finite distance, compliance
  // and strength, a motion's keyframes valid) and throws std::invalid_argument otherwise; it
  // returns the attachment's index. weld joins every vertex of `a` to the nearest vertex of `b`
  // within `within` m (adjacent borders, a seam) with PointToPoint attachments at `distance` (0:
  // coincident; the two objects' triangles then touch along the seam, and the exact intersection
  // count, which knows no welds, counts them) and returns how many. attachmentBroken says whether
  // attachment i has broken; brokenAttachments counts them.
  std::size_t addAttachment(const Attachment& attachment);
  std::size_t weld(ObjectId a, ObjectId b, Real within, Real compliance = 0, Real strength = 0,
                   Real distance = 0);
  std::size_t attachmentCount() const;
  // Takes attachment `index` out for good (skipped from the next step on; not counted as broken).
  void removeAttachment(std::size_t index);

  // Game-loop control, between steps (examples/game_loop.cpp). Each throws std::invalid_argument
  // on an invalid id, an index out of range, a wrong count or a non-finite value, and changes
  // nothing then.
  //
  // A drag holds a particle to a point the host moves (a mouse): a PointToTransform attachment
  // with `compliance` (m/N; the default lets a 1 kg pull stretch it about 1 cm per 100 N), whose
  // target moveDrag sets for the coming steps; endDrag lets go. beginDrag returns the drag's
  // attachment index. Colliders cannot be dragged.
  std::size_t beginDrag(ObjectId id, Index vertex, const Vec3& point, Real compliance = Real(1e-4));
  void moveDrag(std::size_t drag, const Vec3& point);
  void endDrag(std::size_t drag);
  // Sets an object's positions (x and the prediction p, a teleport: velocities are kept) or
  // velocities, one per particle in its vertex order; not for colliders (setColliderTargets).
  // The collision caches are dropped: the next step searches for pairs afresh.
  void setPositions(ObjectId id, std::span<const Vec3> positions);
  void setVelocities(ObjectId id, std::span<const Vec3> velocities);
  // An impulse J (N·s) on one particle (Δv = w J: none on a pinned one), or on a whole object,
  // shared by its free particles in proportion to their mass (each gains J / M).
  void applyImpulse(ObjectId id, Index vertex, const Vec3& impulse);
  void applyImpulse(ObjectId id, const Vec3& impulse);
  // Takes an object out of the world for good: its particles, constraints, tracks and collision
  // exclusions go, every other object keeps its id, and the id of the removed one is refused from
  // then on (an object added later may reuse its slot under a new generation). Particle indices
  // past the object's move down, so spans from positions() taken before are stale. Attachments
  // keep their indices: those that touched the object are taken out as removeAttachment does,
  // and their count is returned. The collision caches are dropped.
  std::size_t removeObject(ObjectId id);
  bool attachmentBroken(std::size_t index) const;
  std::size_t brokenAttachments() const;
  // Where the last substep's contacts pressed (a multiplier above zero), for display: a collider
  // contact at its particle, a contact between primitives at the point of its first primitive
  // (Σ c_k x_k over its positive coefficients). Appended to `out` after clearing it.
  void contactPoints(std::vector<Vec3>& out) const;
  const StepProfile& profile() const;
  void resetProfile();
  // 64-bit FNV-1a hash of every particle's position and velocity bytes.
  std::uint64_t stateHash() const;

  struct Impl;
  Impl& impl() { return *impl_; }  // for systems and tests inside the library's own tree
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace nucleon
