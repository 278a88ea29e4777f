// The comparison cloth in nucleon: the shared mesh, hard stretch (compliance 0) on every edge,
// K sweeps per substep, the case's substeps (one but in the mesh scene), the engine's defaults
// otherwise. Tethers as the case says:
// on, they are part of how nucleon holds a pinned cloth and are counted in its projections and
// time; off, nucleon solves the same constraint set as Bullet.
#include <algorithm>
#include <chrono>

#include "bench/cloth_case.h"

namespace nucleon::bench {

RunResult runNucleonCloth(const ClothCase& c, const ClothMesh& mesh, SolverKind solver, int threads,
                          SolverKind smoother) {
  using Clock = std::chrono::steady_clock;
  World world;
  SolverSettings settings;
  settings.kind = solver;
  settings.smoother = smoother;
  settings.iterations = c.iterations;
  settings.substeps = c.substeps;
  world.setSolver(settings);
  world.setThreads(threads);
  if (c.scene == ClothScene::Sphere) {
    SphereCollider sphere;
    sphere.radius = c.sphereRadius;
    sphere.thickness = c.thickness;
    sphere.friction = c.friction;
    sphere.staticFriction = c.friction;
    world.addSphereCollider(sphere);
  }
  if (c.scene == ClothScene::Mesh) {
    ObjectDef collider = mesh.collider;
    collider.material.staticFriction = std::max(collider.material.staticFriction, c.friction);
    world.addCollider(collider);
  }
  ObjectDef cloth = mesh.def;
  cloth.material.tethers = c.tethers;
  // Bullet's cloth does not collide with itself here either (no VF_SS or CL_SS).
  cloth.material.selfCollision = false;
  if (c.scene == ClothScene::Mesh) {  // as the scene file: μ_k from the case, μ_s at least that
    cloth.material.friction = c.friction;
    cloth.material.staticFriction = std::max(cloth.material.staticFriction, c.friction);
  }
  const ObjectId clothId = world.addCloth(cloth);

  RunResult r;
  std::vector<Vec3> x(mesh.def.vertices.size());
  double timed = 0;
  for (int step = 0; step < c.steps; ++step) {
    if (step == c.warmup) world.resetProfile();
    const auto start = Clock::now();
    world.step(c.dt);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    if (step >= c.warmup) timed += seconds;
    const auto positions = world.positions(clothId);
    x.assign(positions.begin(), positions.end());
    observeStep(c, mesh, x, step, r);
  }
  const int measured = c.steps - c.warmup;
  r.msPerStep = timed * 1e3 / measured;
  const StepProfile& p = world.profile();
  r.predictMs = p.predict * 1e3 / measured;
  r.forcesMs = p.forces * 1e3 / measured;
  r.solveMs = p.solve * 1e3 / measured;
  r.collisionsMs = p.collisions * 1e3 / measured;
  r.updateMs = p.update * 1e3 / measured;
  r.projectionsPerSecond = timed > 0 ? double(p.projections) / timed : 0;
  finishRun(c, mesh, x, r);
  r.stateHash = world.stateHash();
  r.tetherCount = world.constraintCount(ConstraintFamily::Tether);
  return r;
}

}  // namespace nucleon::bench
