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
  // Type 3 (dihedral) bending of cloth across every interior edge, off by default; its
  // compliance is in rad/(N·m).
  bool bending = false;
  Real bendCompliance = 0;
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
};

struct SolverSettings {
  SolverKind kind = SolverKind::GaussSeidel;
  int iterations = 10;  // constraint sweeps per substep
  int substeps = 1;     // substeps per step(dt)
  // Jacobi relaxation ω in (0, 2): each particle moves by ω times the average of its
  // constraints' corrections. Ignored by the Gauss–Seidel backends.
  Real relaxation = 1;
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

  std::size_t constraintCount(const std::string& family) const;  // "stretch", ...
  Measures measure() const;
  // 64-bit FNV-1a hash of every particle's position and velocity bytes.
  std::uint64_t stateHash() const;

  struct Impl;
  Impl& impl() { return *impl_; }  // for systems and tests inside the library's own tree
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace nucleon
