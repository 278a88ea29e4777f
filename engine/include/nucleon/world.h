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

#include "nucleon/errors.h"
#include "nucleon/types.h"

namespace nucleon {

enum class ObjectKind { Cloth, Rope, Solid, Particles, Collider };
const char* toString(ObjectKind kind);

enum class SolverKind { GaussSeidel, Jacobi, ColoredGaussSeidel, Multigrid };
const char* toString(SolverKind kind);
// Parses "gauss-seidel", "jacobi", "colored-gs", "multigrid"; returns false on anything else.
bool parseSolverKind(const std::string& name, SolverKind& out);

// The constraint families a schedule names (DESIGN.md §2): stretch (type 1, edges), shear
// (type 2 at triangle corners), bend (type 3 hinges of cloth and type 2 angles of curves), twist
// (type 3 on four consecutive curve points), volume (tetrahedra), tether (long-range
// attachments of free particles to the nearest pin).
enum class ConstraintFamily { Stretch, Shear, Bend, Twist, Volume, Tether };
constexpr std::size_t kConstraintFamilyCount = 6;
const char* toString(ConstraintFamily family);
// Parses "stretch", "shear", "bend", "twist", "volume", "tether"; false on anything else.
bool parseConstraintFamily(const std::string& name, ConstraintFamily& out);

// How many sweeps per substep each family gets, and the order in which they interleave: the
// families are visited in list order within a round, and a family with n sweeps runs in n of the
// R rounds of a substep (R = the largest count), spread evenly. {stretch 4, bend 2} solves
// stretch, stretch, bend, stretch, stretch, bend. Families the list leaves out are not solved.
struct ScheduleEntry {
  ConstraintFamily family = ConstraintFamily::Stretch;
  int sweeps = 1;
};
using Schedule = std::vector<ScheduleEntry>;
// The same schedule with its largest count set to `sweeps` and the others scaled in proportion
// (rounded, and at least 1 where they were non-zero).
Schedule rescaleSchedule(const Schedule& schedule, int sweeps);

// Generational handle of an object. index1 is 1-based so that a value-initialised id is null.
struct ObjectId {
  std::uint32_t index1 = 0;
  std::uint32_t generation = 0;
  bool valid() const { return index1 != 0; }
};

struct Material {
  // Mass of the whole object in kg, spread over its particles in proportion to the length, area
  // or volume around each (lumped mass). Must be positive and finite.
  Real mass = 1;
  // XPBD compliance (inverse stiffness, m/N) of the stretch constraints; 0 is inextensible.
  Real stretchCompliance = 0;
  Real compressionCompliance = 0;
  // Bending, off by default: for cloth, type 3 (dihedral) across every interior edge; for ropes,
  // type 2 (angle) at every vertex where two segments meet. Compliance in rad/(N·m).
  bool bending = false;
  Real bendCompliance = 0;
  // Shear of cloth, off by default: type 2 (angle) at each corner of each triangle, in rad/(N·m).
  // Stretch on all three edges already holds a triangle's shape; shear matters when the
  // stretch is soft.
  bool shear = false;
  Real shearCompliance = 0;
  // Twist of ropes, off by default: type 3 (dihedral) of each four consecutive points whose rest
  // shape is not straight (a straight run has no defined dihedral), in rad/(N·m).
  bool twist = false;
  Real twistCompliance = 0;
  // Long-range attachments (Kim, Chentanez and Müller 2012) of inextensible (stretch compliance
  // 0) cloth and ropes that have pins: each free vertex may not move farther from its nearest pin
  // (along the mesh's edges) than in the rest shape. A unilateral, hard limit: it stops a pinned
  // cloth from stretching away from its pins when the sweeps are too few to carry its weight, and
  // costs one projection per vertex.
  bool tethers = true;
  // Stiffness-proportional damping time τ (s) of every constraint of the object: the constraint
  // force is −(C + τ dC/dt)/α. 0 = undamped. With α = 0 it makes C relax as e^(−t/τ).
  Real damping = 0;
  // Volume constraints of a solid's tetrahedra (m³/N); 0 keeps every tet's volume.
  Real volumeCompliance = 0;
  // Collision thickness in m: radius of points and edges, half-width of triangle slabs.
  Real thickness = Real(0.01);
};

// An object defined by its rest shape. The simplices index `vertices`.
struct ObjectDef {
  std::string name;
  std::vector<Vec3> vertices;
  std::vector<std::array<Index, 2>> edges;      // ropes / curves
  std::vector<std::array<Index, 3>> triangles;  // cloth, colliders
  std::vector<std::array<Index, 4>> tets;       // soft solids
  Material material;
  std::vector<Index> pins;       // vertices held in place (inverse mass 0)
  Vec3 velocity = Vec3::Zero();  // initial velocity; for a kinematic collider, its constant motion
  // Sweep counts for this object's constraints; empty = the world's schedule. The interleaving
  // order is always the world's.
  Schedule schedule;
};

struct SolverSettings {
  SolverKind kind = SolverKind::GaussSeidel;
  int iterations = 10;  // sweeps per substep of every family, when `schedule` is empty
  int substeps = 1;     // substeps per step(dt)
  // Jacobi relaxation ω in (0, 2): each particle moves by ω times the average of its
  // constraints' corrections. Ignored by the Gauss–Seidel backends.
  Real relaxation = 1;
  // Per-family sweep counts and order; empty = every family `iterations` times, in the order
  // stretch, tether, shear, bend, twist, volume.
  Schedule schedule;
};

// A horizontal ground plane (y up). Particles stay `thickness` above it; friction is Coulomb's
// (μ_k sliding, μ_s sticking), applied to each substep's motion.
struct GroundPlane {
  bool enabled = false;
  Real height = 0;
  Real thickness = Real(0.005);
  Real friction = Real(0.5);
  Real staticFriction = Real(0.6);
};

// A static sphere the particles may not enter (a collider without a mesh). Particles stay
// `thickness` outside its surface; friction as for the ground.
struct SphereCollider {
  Vec3 center = Vec3::Zero();
  Real radius = Real(0.5);
  Real thickness = Real(0.005);
  Real friction = Real(0.5);
  Real staticFriction = Real(0.6);
};

// Wall-clock seconds each stage of step() has taken since the world was created or the profile
// was last reset (the engine's own profile). `solve` excludes the contact projections, which are
// `collisions`; `projections` counts constraint projections in the solve stage.
struct StepProfile {
  double forces = 0;
  double predict = 0;
  double solve = 0;
  double collisions = 0;
  double update = 0;
  std::uint64_t steps = 0;
  std::uint64_t substeps = 0;
  std::uint64_t projections = 0;
};

// Quality measures of the current state (DESIGN.md §7).
struct Measures {
  double maxStrain = 0;   // max |L/L0 − 1| over stretch constraints
  double meanStrain = 0;  // mean of the same
  double kineticEnergy = 0;
  double potentialEnergy = 0;  // −m g·x summed over free particles
  std::size_t nanCount = 0;    // non-finite position or velocity components
  double minHeight = 0;        // lowest particle coordinate along −gravity (y if gravity is 0)
  double volumeRatio = -1;     // current / rest volume of closed objects; −1 if there are none
  std::size_t contacts = 0;    // particles touching the ground plane or a sphere collider
};

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
                                                // the solver; moves with def.velocity)

  void setGravity(const Vec3& g);
  Vec3 gravity() const;
  void setGround(const GroundPlane& ground);  // throws std::invalid_argument on non-finite values
  const GroundPlane& ground() const;
  // Adds a static sphere collider; throws std::invalid_argument on non-finite values or a
  // radius that is not positive.
  void addSphereCollider(const SphereCollider& sphere);
  std::span<const SphereCollider> sphereColliders() const;
  void setSolver(const SolverSettings& settings);
  const SolverSettings& solver() const;
  // Worker threads for step(); 0 = all cores. Results of the Gauss–Seidel solver do not depend on
  // it.
  void setThreads(int threads);
  int threads() const;

  // Advances by dt seconds in solver().substeps substeps. dt must be finite and in (0, 1] s;
  // anything else throws std::invalid_argument and leaves the state untouched.
  void step(double dt);

  std::size_t particleCount() const;
  std::size_t objectCount() const;
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

  std::size_t constraintCount(ConstraintFamily family) const;
  // Sweeps of a family in each substep under the current schedule (most of any object's).
  int sweepsPerSubstep(ConstraintFamily family) const;
  Measures measure() const;
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
