// The cloth scenes of the peer comparison, defined once so that every engine builds exactly the
// same thing: an N×N vertex grid, 2 m square, horizontal at 1 m, 1 kg, gravity −9.81 m/s²,
// stepped at 1/60 s with one substep and K constraint iterations. Two scenes: hanging from two
// adjacent corners, and free, dropped onto a static sphere of radius 0.5 at the origin.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "nucleon/world.h"

namespace nucleon::bench {

enum class ClothScene { Hanging, Sphere };
const char* toString(ClothScene scene);

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
  Real sphereRadius = Real(0.5);
  Real thickness = Real(0.01);  // contact distance kept from the sphere
  Real friction = Real(0.5);
};

// The shared rest shape: positions, triangles, the unique edges (the stretch constraints of both
// engines), per-vertex masses (nucleon's lumped masses; 0 marks a pinned vertex).
struct ClothMesh {
  ObjectDef def;
  std::vector<std::array<Index, 2>> edges;
  std::vector<Real> restLength;
  std::vector<Real> mass;
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
  double penetration = 0;           // sphere scene: deepest vertex inside the sphere
  double lowestY = 0;
  std::uint64_t stateHash = 0;  // nucleon only
  std::size_t tetherCount = 0;  // nucleon only: tether constraints in the world
  bool finite = true;
};

// Fills the end-of-run figures (final strain and its 99th percentile, penetration, lowest
// point, finiteness) from the positions after the last step.
void finishRun(const ClothCase& c, const ClothMesh& mesh, const std::vector<Vec3>& positions,
               RunResult& result);

RunResult runNucleonCloth(const ClothCase& c, const ClothMesh& mesh, SolverKind solver,
                          int threads);

// Bullet's btSoftBody on the same case; only when the program was built with Bullet.
bool bulletAvailable();
RunResult runBulletCloth(const ClothCase& c, const ClothMesh& mesh);

}  // namespace nucleon::bench
