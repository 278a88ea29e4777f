// The cloth scenes of the peer comparison, defined once so that every engine builds exactly the
// same thing: an N×N vertex grid, 2 m square, horizontal at 1 m, 1 kg, gravity −9.81 m/s²,
// stepped at 1/60 s with one substep and K constraint iterations. Three scenes: hanging from two
// adjacent corners; free, dropped onto a static sphere of radius 0.5 at the origin (an analytic
// collider in both engines); and free, dropped onto a static triangle mesh of a sphere (nucleon's
// icosphere, the same triangles in both engines), off the cloth's centre so that it drapes and
// slides, with two substeps per step.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "nucleon/world.h"

namespace nucleon::bench {

enum class ClothScene { Hanging, Sphere, Mesh };
const char* toString(ClothScene scene);

// How Bullet's soft body collides with the rigid triangle mesh (btSoftBody::fCollision): SDF_RS,
// its default, samples a signed distance field of each triangle (extruded into a thin prism by
// Bullet's concave collision algorithm) at the nodes; CL_RS collides clusters of nodes (here one
// per triangle, as Bullet's own cloth cluster demo) as convex hulls against each triangle.
enum class BulletCollision { Sdf, Cluster };
const char* toString(BulletCollision mode);

struct ClothCase {
  ClothScene scene = ClothScene::Hanging;
  int resolution = 64;  // N: vertices along each side
  int iterations = 10;  // K: constraint iterations per step
  bool bending = false;
  // nucleon's long-range attachments (Material::tethers) for a pinned cloth. Bullet has no such
  // constraint, so the comparison runs nucleon both with them (its default) and without them
  // (the same constraint set as Bullet's).
  bool tethers = true;
  int steps = 120;  // simulated steps per run (2 s)
  int warmup = 10;  // leading steps left out of the timing (first-step setup, caches)
  double dt = 1.0 / 60;
  int substeps = 1;  // nucleon's substeps; Bullet steps dt/substeps that many times
  Real sphereRadius = Real(0.5);
  Real thickness = Real(0.01);  // the cloth's; the contact distance kept from the sphere
  Real friction = Real(0.5);
  // Mesh scene: the icosphere collider. Its top is 0.9 m below the cloth, its centre 0.15 m off
  // the cloth's centre along x: the cloth drapes unevenly and slides, and stays on the sphere
  // for the 2 s (0.35 m off, as in the scene file, nucleon's cloth slides off before the end).
  Vec3 meshCenter = Vec3(Real(0.15), Real(-0.4), 0);
  int meshSubdivisions = 3;          // 1 280 triangles
  Real meshThickness = Real(0.005);  // the collider's; cloth and mesh keep the sum apart
  BulletCollision bulletCollision = BulletCollision::Sdf;
};

// The mesh scene as nucleon's scene cloth_drop_sphere sets it up (thicknesses 6 mm for the cloth
// and 5 mm for the collider, friction 0.3, two substeps), without its ground plane and with the
// cloth's self-collision off.
ClothCase meshDropCase(int resolution, int iterations);

// The distance cloth and mesh keep apart in the mesh scene: the sum of their thicknesses.
double meshContactDistance(const ClothCase& c);

// Signed distance to a closed, outward-oriented triangle mesh, computed from its triangles alone
// (nothing of either engine's collision code): the exact distance to the nearest triangle,
// negative inside, the side decided by the parity of a ray's crossings.
class MeshDistance {
 public:
  MeshDistance() = default;
  explicit MeshDistance(const ObjectDef& mesh);
  bool empty() const { return triangles_.empty(); }
  // Points farther than `beyond` outside the mesh's bounding ball are not measured: they return
  // a lower bound of their distance (> beyond).
  double signedDistance(const Vec3d& point, double beyond) const;

 private:
  struct Triangle {
    Vec3d a, b, c;
    Vec3d centroid;
    double radius = 0;  // of the ball about the centroid that holds the triangle
  };
  std::vector<Triangle> triangles_;
  Vec3d ballCenter_ = Vec3d::Zero();
  double ballRadius_ = 0;
};

// The shared rest shape: positions, triangles, the unique edges (the stretch constraints of both
// engines), per-vertex masses (nucleon's lumped masses; 0 marks a pinned vertex).
struct ClothMesh {
  ObjectDef def;
  std::vector<std::array<Index, 2>> edges;
  std::vector<Real> restLength;
  std::vector<Real> mass;
  // Mesh scene: the collider (nucleon's icosphere) and the measure of distance to it.
  ObjectDef collider;
  MeshDistance colliderDistance;
};
ClothMesh makeClothMesh(const ClothCase& c);

struct StrainStats {
  double max = 0;
  double mean = 0;
};
// |L/L0 − 1| over the mesh edges: the quality figure reported for every engine.
StrainStats measureStrain(const ClothMesh& mesh, const std::vector<Vec3>& positions);

// Deepest penetration of any vertex into the sphere's contact surface (r + thickness), in m;
// ≤ 0 when nothing is inside.
double spherePenetration(const ClothCase& c, const std::vector<Vec3>& positions);

// One run of one engine on one case.
struct RunResult {
  double msPerStep = 0;  // mean over the timed steps
  // The engine's own per-stage profile per step (nucleon only; zero for a peer).
  double forcesMs = 0, predictMs = 0, solveMs = 0, collisionsMs = 0, updateMs = 0;
  double projectionsPerSecond = 0;  // nucleon only
  StrainStats finalStrain;          // after the last step
  double finalStrainP99 = 0;        // 99th percentile of the same, nearest rank
  double peakMaxStrain = 0;         // largest max strain seen after any step
  double averageMeanStrain = 0;     // mean strain averaged over all steps (less phase-dependent)
  // Mean, p99 and max strain of each step averaged over the second half of the run (steps
  // ⌊steps/2⌋+1 … steps: the cloth hanging or draped, past its first fall). One step's figures
  // depend on where the swing is; a single sample of a chaotic run can flatter either side.
  StrainStats lateStrain;
  double lateStrainP99 = 0;
  double penetration = 0;  // sphere scene: deepest vertex inside the sphere
  double lowestY = 0;
  // Mesh scene, from the signed distance s of every cloth vertex to the mesh after every step:
  // the smallest s over the run (the deepest penetration below the contact distance d is
  // max(0, d − s), below the surface itself max(0, −s)), the vertices with s < 0 after the last
  // step and the most after any step, and the smallest s after the last step.
  double meshMinDistance = 1e30;
  int meshInsideAtEnd = 0;
  int meshInsidePeak = 0;
  double meshMinDistanceAtEnd = 1e30;
  std::uint64_t stateHash = 0;  // nucleon only
  std::size_t tetherCount = 0;  // nucleon only: tether constraints in the world
  bool finite = true;
};

// |L/L0 − 1| of every mesh edge, nearest-rank 99th percentile (nucleon's strain_p99 definition).
double strainP99(const ClothMesh& mesh, const std::vector<Vec3>& positions);

// Updates the figures tracked over the run (peak strain, mean strain, the late-run averages, the
// mesh scene's distances) from the positions after step `step` (0-based).
void observeStep(const ClothCase& c, const ClothMesh& mesh, const std::vector<Vec3>& positions,
                 int step, RunResult& result);

// Fills the end-of-run figures (final strain and its 99th percentile, penetration, lowest
// point, finiteness) from the positions after the last step.
void finishRun(const ClothCase& c, const ClothMesh& mesh, const std::vector<Vec3>& positions,
               RunResult& result);

// `smoother`: the fine sweeps' backend when `solver` is multigrid.
RunResult runNucleonCloth(const ClothCase& c, const ClothMesh& mesh, SolverKind solver, int threads,
                          SolverKind smoother = SolverKind::ColoredGaussSeidel);

// Bullet's btSoftBody on the same case; only when the program was built with Bullet.
bool bulletAvailable();
RunResult runBulletCloth(const ClothCase& c, const ClothMesh& mesh);

}  // namespace nucleon::bench
