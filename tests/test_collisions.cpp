// Collisions between primitives: what the primitive lists hold, and the response measured on the
// state: resting separation, no tunnelling at speed, edge–edge contact of ropes, Coulomb
// friction on a slope, restitution, and a cloth folding onto itself without intersecting.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

#include <gtest/gtest.h>

#include "engine/src/world_state.h"
#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"
#include "systems/collision/broad_phase.h"
#include "systems/collision/ccd.h"
#include "systems/collision/primitive_contacts.h"
#include "systems/collision/primitive_distance.h"
#include "systems/diagnostics/triangle_intersections.h"
#include "systems/setup/build_collision_primitives.h"

using namespace nucleon;

namespace {

// A static square of two triangles, `half` m from its centre to each side, tilted about z by
// `degrees` (its normal turns from +y towards −x), as a collider mesh.
ObjectDef slab(Real half, double degrees = 0, Real height = 0) {
  ObjectDef def;
  const double a = degrees * M_PI / 180;
  const Vec3 u(static_cast<Real>(std::cos(a)), static_cast<Real>(std::sin(a)), 0);
  const Vec3 w(0, 0, 1);
  const Vec3 c(0, height, 0);
  def.vertices = {c - half * u - half * w, c + half * u - half * w, c + half * u + half * w,
                  c - half * u + half * w};
  def.triangles = {{0, 2, 1}, {0, 3, 2}};
  def.material.thickness = Real(0.005);
  return def;
}

ObjectDef pellet(const Vec3& at, const Vec3& velocity, Real thickness = Real(0.005)) {
  ObjectDef def;
  def.vertices = {at};
  def.velocity = velocity;
  def.material.mass = Real(0.01);
  def.material.thickness = thickness;
  return def;
}

World worldWith(SolverKind kind, int substeps) {
  World world;
  world.setSolver(test::solverSettings(kind, 10, substeps));
  return world;
}

// A vertical 0.8 m cloth of 24² vertices, 6 mm thick, 0.5 m up and moving at 0.3 m/s along z
// over the ground: it falls and folds onto itself.
World foldingClothWorld(bool selfCollision) {
  World world = worldWith(SolverKind::ColoredGaussSeidel, 2);
  GroundPlane ground;
  ground.enabled = true;
  world.setGround(ground);
  GridSpec spec;
  spec.resolution = {24, 24};
  spec.size = {Real(0.8), Real(0.8)};
  spec.center = Vec3(0, Real(0.5), 0);
  spec.vertical = true;
  ObjectDef cloth = gridCloth(spec);
  cloth.velocity = Vec3(0, 0, Real(0.3));
  cloth.material.thickness = Real(0.006);
  cloth.material.selfCollision = selfCollision;
  world.addCloth(cloth);
  return world;
}

}  // namespace

TEST(CollisionPrimitives, ListsFollowKindsAndFlags) {
  World world;
  GridSpec spec;
  spec.resolution = {4, 4};
  ObjectDef cloth = gridCloth(spec);
  cloth.material.selfCollision = true;
  world.addCloth(cloth);                                         // 16 v, 33 e, 18 t
  world.addRope(polylineRope(Vec3(0, 2, 0), Vec3(1, 2, 0), 5));  // 6 v, 5 e
  world.addParticles(pellet(Vec3(0, 3, 0), Vec3::Zero()));       // 1 isolated point
  ObjectDef box = tetBox(Vec3(0, 5, 0), Vec3(1, 1, 1), {2, 2, 2});
  box.material.selfCollision = false;
  box.material.collideEdges = false;
  const ObjectId solid = world.addSolid(box);  // boundary only: 26 v, 48 t
  world.step(1e-3);
  const CollisionPrimitives& p = world.impl().state.primitives;
  EXPECT_EQ(p.points(), 16u + 6u + 1u + 26u);
  EXPECT_EQ(p.edges(), 33u + 5u);  // the solid's edges are turned off
  EXPECT_EQ(p.triangles(), 18u + 48u);
  EXPECT_EQ(std::count(p.pointIsolated.begin(), p.pointIsolated.end(), 1), 1 + 26);
  EXPECT_TRUE(p.excluded(3, 3));  // the solid's self-collision is off
  EXPECT_FALSE(p.excluded(0, 0));
  world.excludeCollisions(world.objectAt(0), world.objectAt(1));
  world.step(1e-3);
  EXPECT_TRUE(world.impl().state.primitives.excluded(1, 0));
  (void)solid;
}

// A pellet dropped on a collider mesh rests at the contact distance (its radius plus the
// mesh's), for every backend: within 1 mm (the sweeps converge a single contact exactly; the
// slack is gravity's last substep of motion).
TEST(CollisionResponse, PointRestsOnAMeshAtTheContactDistance) {
  for (SolverKind kind :
       {SolverKind::GaussSeidel, SolverKind::Jacobi, SolverKind::ColoredGaussSeidel}) {
    World world = worldWith(kind, 2);
    world.addCollider(slab(1));
    const ObjectId p =
        world.addParticles(pellet(Vec3(Real(0.1), Real(0.3), Real(0.2)), Vec3::Zero()));
    test::simulate(world, 90);
    const Real y = world.positions(p)[0].y();
    EXPECT_NEAR(y, 0.01, 1e-3) << toString(kind);
    EXPECT_EQ(world.recoveries().total(), 0u);
  }
}

// At 300 m/s a pellet moves 5 m per step, 500 times the slab's thickness: the space-time
// contact still stops it on the near side.
TEST(CollisionResponse, FastPointDoesNotTunnelThroughAMesh) {
  for (SolverKind kind :
       {SolverKind::GaussSeidel, SolverKind::Jacobi, SolverKind::ColoredGaussSeidel}) {
    World world = worldWith(kind, 1);
    world.addCollider(slab(2));
    const ObjectId p = world.addParticles(pellet(Vec3(0, 1, 0), Vec3(0, -300, 0)));
    for (int i = 0; i < 30; ++i) {
      world.step(1.0 / 60);
      ASSERT_GT(world.positions(p)[0].y(), 0) << toString(kind) << " step " << i;
    }
  }
}

// A rope dropped across a second, pinned one (edge–edge contact of capsules) lies on it. The
// closest distance between the two ropes stays above 90% of the contact distance through the
// impact at 1.9 m/s and ends within 5% of it (resting on it, not bouncing off). With 16 substeps:
// at 4 the impact leaves up to a third of the distance, whatever the sweep count (40 sweeps do
// no better than 10), because segments next to the first contact come within reach only after
// the sweeps have moved them, and get their contact one substep later.
TEST(CollisionResponse, RopeRestsAcrossARope) {
  World world = worldWith(SolverKind::GaussSeidel, 16);
  ObjectDef lower = polylineRope(Vec3(-1, 1, 0), Vec3(1, 1, 0), 20);
  lower.pins = {0, 20};
  lower.material.thickness = Real(0.01);
  ObjectDef upper = polylineRope(Vec3(0, Real(1.2), -1), Vec3(0, Real(1.2), 1), 20);
  upper.pins = {};
  upper.material.thickness = Real(0.01);
  const ObjectId a = world.addRope(lower);
  const ObjectId b = world.addRope(upper);
  double closest = 1e9;
  for (int frame = 0; frame < 60; ++frame) {
    world.step(1.0 / 60);
    closest = 1e9;
    const auto pa = world.positions(a);
    const auto pb = world.positions(b);
    for (std::size_t i = 0; i + 1 < pa.size(); ++i)
      for (std::size_t j = 0; j + 1 < pb.size(); ++j) {
        // Exact segment–segment distance (Ericson's closest points).
        const Vec3d p0 = pa[i].cast<double>(), p1 = pa[i + 1].cast<double>();
        const Vec3d q0 = pb[j].cast<double>(), q1 = pb[j + 1].cast<double>();
        const auto st = closestBetweenSegments(p0, p1, q0, q1);
        closest = std::min(closest, ((p0 + st[0] * (p1 - p0)) - (q0 + st[1] * (q1 - q0))).norm());
      }
    ASSERT_GT(closest, 0.9 * 0.02) << "frame " << frame;
  }
  EXPECT_NEAR(closest, 0.02, 0.05 * 0.02);
}

// Coulomb friction of primitive contacts: on a slab tilted to 20° (tan = 0.364) a pellet with
// μ_s = 0.5 stays put, and with μ = 0.1 slides with a = g (sin θ − μ cos θ) within 10%
// (position-level friction acts on each substep's motion, so the figure is not exact).
TEST(CollisionResponse, FrictionHoldsOrSlidesOnASlope) {
  const double theta = 20 * M_PI / 180;
  for (Real mu : {Real(0.5), Real(0.1)}) {
    World world = worldWith(SolverKind::GaussSeidel, 4);
    ObjectDef surface = slab(3, 20);
    surface.material.friction = surface.material.staticFriction = mu;
    world.addCollider(surface);
    // Start on the surface, at the contact distance along its normal.
    const Vec3 normal(static_cast<Real>(-std::sin(theta)), static_cast<Real>(std::cos(theta)), 0);
    const Vec3 start = normal * Real(0.0101);
    ObjectDef body = pellet(start, Vec3::Zero());
    body.material.friction = body.material.staticFriction = mu;
    const ObjectId p = world.addParticles(body);
    // Positions along the slope after 10, 30 and 50 frames: a = (s3 − 2 s2 + s1) / Δ².
    const Vec3 downhill(static_cast<Real>(-std::cos(theta)), static_cast<Real>(-std::sin(theta)),
                        0);
    double s[3];
    test::simulate(world, 10);
    s[0] = downhill.dot(world.positions(p)[0] - start);
    test::simulate(world, 20);
    s[1] = downhill.dot(world.positions(p)[0] - start);
    test::simulate(world, 20);
    s[2] = downhill.dot(world.positions(p)[0] - start);
    if (mu == Real(0.5)) {
      EXPECT_LT(std::abs(s[2]), 1e-3);
    } else {
      const double dt = 20.0 / 60;
      const double measured = (s[2] - 2 * s[1] + s[0]) / (dt * dt);
      const double expected = 9.81 * (std::sin(theta) - 0.1 * std::cos(theta));
      EXPECT_NEAR(measured, expected, 0.1 * expected);
    }
  }
}

// Restitution: with e = 1 a pellet dropped from 0.5 m bounces back above 0.4 m; with e = 0 it
// stays on the surface.
TEST(CollisionResponse, RestitutionBounces) {
  for (Real e : {Real(0), Real(1)}) {
    World world = worldWith(SolverKind::GaussSeidel, 4);
    ObjectDef surface = slab(1);
    surface.material.restitution = e;
    world.addCollider(surface);
    const ObjectId p = world.addParticles(pellet(Vec3(0, Real(0.5), 0), Vec3::Zero()));
    double highestAfterImpact = 0;
    bool impacted = false;
    for (int frame = 0; frame < 90; ++frame) {
      world.step(1.0 / 60);
      const double y = world.positions(p)[0].y();
      if (y < 0.05) impacted = true;
      if (impacted) highestAfterImpact = std::max(highestAfterImpact, y);
    }
    ASSERT_TRUE(impacted);
    if (e == 1)
      EXPECT_GT(highestAfterImpact, 0.4);
    else
      EXPECT_LT(highestAfterImpact, 0.02);
  }
}

// A cloth falling edge-first onto the ground folds onto itself: with self-collision no two of
// its triangles intersect at any frame end; with self-collision off the same fall leaves
// intersecting triangles (the checker sees them, so the first figure is not vacuous).
TEST(CollisionResponse, FoldingClothDoesNotIntersectItself) {
  std::size_t withoutSelfCollision = 0;
  for (bool self : {true, false}) {
    World world = foldingClothWorld(self);
    std::size_t most = 0;
    for (int frame = 0; frame < 60; ++frame) {
      world.step(1.0 / 60);
      const std::size_t n = world.measure().intersections;
      most = std::max(most, n);
      if (self) {
        ASSERT_EQ(n, 0u) << "frame " << frame;
      }
    }
    if (self) {
      EXPECT_EQ(world.collisionReport().unresolvedPairs, 0u);
      EXPECT_GT(world.collisionReport().contacts, 0u);
    } else {
      withoutSelfCollision = most;
    }
  }
  EXPECT_GT(withoutSelfCollision, 0u);
}

// A cloth folded onto the ground comes to rest, and a step at rest starts from the last step's
// pairs without any search (CollisionReport::keptPairSets) while the layers stay apart: the
// kept set is complete as long as every particle stays within its bounds.
TEST(CollisionResponse, ClothAtRestKeepsItsPairsAcrossSteps) {
  World world = foldingClothWorld(true);
  for (int frame = 0; frame < 150; ++frame) {
    world.step(1.0 / 60);
    ASSERT_EQ(world.measure().intersections, 0u) << "frame " << frame;
  }
  const CollisionReport& report = world.collisionReport();
  EXPECT_GT(report.keptPairSets, 30u);
  EXPECT_LT(report.broadPhases, 150u + report.broadPhaseRefreshes + report.solveRedetections);
  EXPECT_EQ(report.unresolvedPairs, 0u);
  EXPECT_EQ(world.recoveries().total(), 0u);
}

// A cloth falling freely as a whole, self-collision on, keeps its pairs from step to step: the
// frame of the common motion falls with it, so after the first step's search every step starts
// from the last one's pairs. Its centre follows the integrator's free fall exactly: symplectic
// Euler with substeps of h reaches y0 − g T²/2 − g h T/2 at T (20.4 mm below the continuous
// fall after half a second at 120 substeps per second); 0.1 mm leaves room for float rounding.
TEST(CollisionResponse, ClothFallingAsAWholeKeepsItsPairs) {
  World world = worldWith(SolverKind::Multigrid, 2);
  GridSpec spec;
  spec.resolution = {32, 32};
  spec.size = {Real(0.6), Real(0.6)};
  spec.center = Vec3(0, Real(2), 0);
  ObjectDef cloth = gridCloth(spec);
  cloth.material.thickness = Real(0.006);
  cloth.material.selfCollision = true;
  world.addCloth(cloth);
  const int steps = 30;
  for (int step = 0; step < steps; ++step) world.step(1.0 / 60);
  const CollisionReport& report = world.collisionReport();
  EXPECT_GT(report.candidatePairs, 0u);
  EXPECT_EQ(report.keptPairSets, std::uint64_t(steps - 1));
  EXPECT_EQ(report.broadPhases, 1u);
  EXPECT_EQ(world.measure().intersections, 0u);
  const ObjectId sheet = world.objectAt(0);
  double height = 0;
  for (const Vec3& x : world.positions(sheet)) height += x.y();
  height /= double(world.positions(sheet).size());
  const double time = steps / 60.0, g = 9.81, h = 1.0 / 120;
  EXPECT_NEAR(height, 2 - g * time * time / 2 - g * h * time / 2, 1e-4);
}

// The pellet of bullet_cloth (200 m/s, 0.83 m per substep against a 5 mm cloth) never passes
// through the cloth. The world is stepped at the scene's substep rate, one substep per step, so
// that each step moves every particle on a straight line; after each step the pellet's motion is
// tested against every cloth triangle's by CCD at zero distance (ccd.h, which finds every
// crossing of the public CCD set's ground truth), over all 45 frames. (A parity test of a ray from
// the pellet back to where it was fired cannot tell a pellet that tunnelled from one the cloth
// flung over its own edge, which a pellet that keeps its momentum through the impact zones can
// be.) Run with the scene's solver and under multigrid with either smoother, whose cascade moves
// the cloth's particles between contact projections. The pellet gives its momentum to the cloth:
// it ends slower than a tenth of its speed.
static void expectPelletNeverTunnels(std::optional<SolverKind> kind, SolverKind smoother) {
  Scene scene = loadScene(NUCLEON_ASSETS_DIR "/scenes/bullet_cloth.json");
  if (kind) {
    scene.solver.kind = *kind;
    scene.solver.smoother = smoother;
  }
  const int substeps = scene.solver.substeps;
  scene.solver.substeps = 1;
  World world = buildWorld(scene);
  const ObjectId cloth = world.objectAt(0), pelletId = world.objectAt(1);
  const auto triangles = world.surfaceTriangles(cloth);
  std::vector<Vec3> before(world.positions(cloth).begin(), world.positions(cloth).end());
  Vec3 pelletBefore = world.positions(pelletId)[0];
  for (int step = 0; step < scene.frames * substeps; ++step) {
    world.step(1.0 / (scene.fps * substeps));
    const auto after = world.positions(cloth);
    const Vec3 pelletAfter = world.positions(pelletId)[0];
    int crossed = 0;
    for (const auto& t : triangles)
      crossed += vertexFaceCcd(pelletBefore.cast<double>(), before[t[0]].cast<double>(),
                               before[t[1]].cast<double>(), before[t[2]].cast<double>(),
                               pelletAfter.cast<double>(), after[t[0]].cast<double>(),
                               after[t[1]].cast<double>(), after[t[2]].cast<double>(), 0.0)
                     .hit;
    ASSERT_EQ(crossed, 0) << "step " << step << ": the pellet passed through the cloth";
    before.assign(after.begin(), after.end());
    pelletBefore = pelletAfter;
  }
  EXPECT_LT(world.velocities()[world.particleCount() - 1].norm(), 20);
  EXPECT_EQ(world.recoveries().total(), 0u);
}

TEST(CollisionScenes, BulletClothPelletNeverTunnels) {
  expectPelletNeverTunnels(std::nullopt, SolverKind::ColoredGaussSeidel);
}

TEST(CollisionScenes, BulletClothPelletNeverTunnelsUnderMultigrid) {
  expectPelletNeverTunnels(SolverKind::Multigrid, SolverKind::ColoredGaussSeidel);
  expectPelletNeverTunnels(SolverKind::Multigrid, SolverKind::Jacobi);
}

// A squeeze (torture/pinch.json): two boxes close on a pinned curtain from either side to a 4 mm
// gap, less than the 20 mm its contact distances with them need. Carried with either box, a
// particle between them would cross the other; the fail-safe holds it in the gap instead
// (collisions.squeezes). At the end, with the boxes' faces at z = ±2 mm, every curtain particle
// between the boxes lies between their faces (to the float rounding of the carries), and no
// repair was made.
TEST(CollisionScenes, ASqueezedCurtainIsHeldInTheGap) {
  Scene scene = loadScene(NUCLEON_ASSETS_DIR "/scenes/torture/pinch.json");
#if defined(__SANITIZE_ADDRESS__)
  scene.frames = 40;  // the boxes close at frame 30; the sanitizer looks for memory errors only
#endif
  World world = buildWorld(scene);
  ObjectId curtain{};
  for (std::size_t k = 0; k < world.objectCount(); ++k)
    if (world.name(world.objectAt(k)) == "curtain") curtain = world.objectAt(k);
  ASSERT_FALSE(world.positions(curtain).empty());
  for (int frame = 0; frame < scene.frames; ++frame) world.step(1.0 / scene.fps);
  EXPECT_GT(world.collisionReport().squeezes, 0u);
  EXPECT_EQ(world.recoveries().total(), 0u);
#if !defined(__SANITIZE_ADDRESS__)
  std::size_t between = 0;
  for (const Vec3& x : world.positions(curtain)) {
    if (std::abs(x.x()) > 0.29f || x.y() < 0.31f || x.y() > 0.89f) continue;
    ++between;
    EXPECT_LE(std::abs(x.z()), 0.002f + 1e-5f) << x.transpose();
  }
  EXPECT_GT(between, 500u);
#endif
}

// The narrow phase's carried lower bounds (primitive_contacts.h, "Lower bounds"), on a cloth
// crumpled on the ground and two substeps of made-up motion: a common fall, 2 mm of random
// flutter, the second substep starting up to 0.5 mm off where the first was predicted to end.
// Every pair whose bound says it stays out of reach over the second substep does (the CCD finds
// no approach within 0.9 of the reach), the second substep passes over many pairs without
// measuring them, and it makes exactly the contacts of a narrow phase that measures every pair.
// A point meets each feature of a mesh once. A pellet 0.5 mm beyond its contact distance over the
// slab's shared diagonal, or over its shared corner, is as close to both triangles (and to the
// diagonal edge), at the same point: one contact, on that feature, not one per primitive. The lower
// end of a vertical rope over the diagonal is held by its vertex's contact alone: the edge–edge
// pair of the rope and the diagonal, closest at that end, makes none.
TEST(PrimitiveContacts, OneContactPerFeatureOfAMesh) {
  const Real half = Real(0.5), above = Real(0.0105);  // contact distance 0.01, reach 0.0125
  struct Case {
    const char* what;
    ObjectDef def;
    std::array<Real, 4> weights;  // of slab particles 0–3 in the one contact
  };
  ObjectDef rope = polylineRope(Vec3(0, above, 0), Vec3(0, above + Real(0.05), 0), 1);
  rope.material.thickness = Real(0.005);
  const Case cases[] = {
      {"diagonal", pellet(Vec3(0, above, 0), Vec3::Zero()), {0.5, 0, 0.5, 0}},
      {"corner", pellet(Vec3(-half, above, -half), Vec3::Zero()), {1, 0, 0, 0}},
      {"rope end", rope, {0.5, 0, 0.5, 0}},
  };
  for (const Case& c : cases) {
    World world = worldWith(SolverKind::Jacobi, 1);
    world.setGravity(Vec3::Zero());
    world.addCollider(slab(half));
    if (c.def.vertices.size() == 1)
      world.addParticles(c.def);
    else
      world.addRope(c.def);
    world.step(1.0 / 60);
    const PrimitiveContactPool& contacts = world.impl().state.primitiveContacts;
    ASSERT_EQ(contacts.size(), 1u) << c.what;
    std::array<Real, 4> weights{};
    for (int k = 0; k < 4; ++k)
      if (contacts.particles[0][k] < 4)
        weights[contacts.particles[0][k]] -= contacts.coefficient[0][k];
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(weights[k], c.weights[k], 1e-6) << c.what << " " << k;
    EXPECT_NEAR(contacts.normal[0].y(), 1, 1e-6) << c.what;
  }
}

TEST(PrimitiveContacts, CarriedLowerBoundsKeepEveryContact) {
  World world = foldingClothWorld(true);
  for (int frame = 0; frame < 40; ++frame) world.step(1.0 / 60);
  const WorldState& s = world.impl().state;
  const CollisionPrimitives& primitives = s.primitives;
  ParticlePool particles = s.particles;
  std::mt19937 random(7);
  std::uniform_real_distribution<float> flutter(-0.002f, 0.002f);
  const auto jitter = [&](float scale) -> Vec3 {
    const float a = flutter(random), b = flutter(random), c = flutter(random);
    return Vec3(scale * a, scale * b, scale * c);
  };
  const Vec3 fall(0, -0.01f, 0);
  // The pairs found over four substeps' motion, as a step's broad phase finds them: many stay out
  // of reach over the first substeps.
  for (std::size_t i = 0; i < particles.size(); ++i)
    particles.p[i] = particles.x[i] + 4 * fall + jitter(4);
  CandidatePairs pairs;
  PrimitiveBvh bvh;
  findCandidatePairs(pairs, bvh, primitives, particles.x, particles.p, particles.w,
                     kPrimitiveContactMargin);
  for (std::size_t i = 0; i < particles.size(); ++i)
    particles.p[i] = particles.x[i] + fall + jitter(1);
  PrimitiveContactPool carried;
  detectPrimitiveContacts(carried, pairs, primitives, particles);
  for (std::size_t i = 0; i < particles.size(); ++i) {
    particles.x[i] = particles.p[i] + jitter(0.25f);
    particles.p[i] = particles.x[i] + fall + jitter(1);
  }
  detectPrimitiveContacts(carried, pairs, primitives, particles);
  PrimitiveContactPool measured;
  detectPrimitiveContacts(measured, pairs, primitives, particles);

  ASSERT_GT(pairs.size(), 1000u);
  std::size_t passedOver = 0, outOfReach = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    passedOver += carried.lowerBound[i] != measured.lowerBound[i];
    const bool faces = pairs.kind[i] == PairKind::VertexFace;
    ASSERT_TRUE(faces || pairs.kind[i] == PairKind::EdgeEdge);
    const Index a = pairs.first[i], b = pairs.second[i];
    const Real radius = faces ? primitives.pointRadius[a] + primitives.triangleRadius[b]
                              : primitives.edgeRadius[a] + primitives.edgeRadius[b];
    const double reach = double(radius) + double(kPrimitiveContactMargin);
    if (!(carried.lowerBound[i] > reach)) continue;
    ++outOfReach;
    std::array<Index, 4> id;
    if (faces) {
      const auto& t = primitives.triangleParticles[b];
      id = {primitives.pointParticle[a], t[0], t[1], t[2]};
    } else {
      const auto& e = primitives.edgeParticles[a];
      const auto& f = primitives.edgeParticles[b];
      id = {e[0], e[1], f[0], f[1]};
    }
    Vec3d X0[4], X1[4];
    for (int k = 0; k < 4; ++k) {
      X0[k] = particles.x[id[k]].cast<double>();
      X1[k] = particles.p[id[k]].cast<double>();
    }
    const CcdResult approach =
        faces ? vertexFaceCcd(X0[0], X0[1], X0[2], X0[3], X1[0], X1[1], X1[2], X1[3], 0.9 * reach)
              : edgeEdgeCcd(X0[0], X0[1], X0[2], X0[3], X1[0], X1[1], X1[2], X1[3], 0.9 * reach);
    ASSERT_FALSE(approach.hit) << "pair " << i << " bound " << carried.lowerBound[i];
  }
  EXPECT_GT(passedOver, pairs.size() / 8);  // 21% here
  EXPECT_GE(outOfReach, passedOver);        // a pair is passed over only while its bound is
  ASSERT_EQ(carried.size(), measured.size());
  ASSERT_GT(measured.size(), 0u);
  for (std::size_t c = 0; c < measured.size(); ++c) {
    EXPECT_EQ(carried.particles[c], measured.particles[c]) << c;
    EXPECT_EQ(carried.normal[c], measured.normal[c]) << c;
  }
}

namespace {

// The fail-safe's world for one crossing: a collider triangle (particles 0–2) at `corners`
// turned by `turn` about the y axis over the substep, and one point primitive on particle
// `point` (its triangle, if it has one, in `pointTriangle`) of the object `pointObject`;
// `moreTriangles` are free triangles of object 1.
struct FailsafeCase {
  ParticlePool particles;
  CollisionPrimitives primitives;
  Eigen::Matrix<Real, 3, 3> turn =
      Eigen::AngleAxis<Real>(Real(0.349066), Vec3::UnitY()).toRotationMatrix();  // 20°

  FailsafeCase(const std::array<Vec3, 3>& corners, std::size_t particleCount) {
    particles.append(particleCount);
    for (int k = 0; k < 3; ++k) {
      particles.x[k] = particles.restPosition[k] = corners[k];
      particles.p[k] = turn * corners[k];
    }
    primitives.objectSurface.resize(2);
    primitives.triangleParticles = {{0, 1, 2}};
    primitives.triangleRadius = {Real(0.001)};
    primitives.triangleObject = {0};
    primitives.smallestRadius = Real(0.001);
  }
  void addFree(Index i, const Vec3& start, const Vec3& predicted) {
    particles.x[i] = particles.restPosition[i] = start;
    particles.p[i] = predicted;
    particles.w[i] = 1;
  }
  void addPoint(Index particle, std::uint32_t object, Index triangle) {
    primitives.pointParticle.push_back(particle);
    primitives.pointRadius.push_back(Real(0.001));
    primitives.pointObject.push_back(object);
    primitives.pointIsolated.push_back(1);
    primitives.pointTriangle.push_back(triangle);
  }
  void addFreeEdge(const std::array<Index, 2>& e) {
    primitives.edgeParticles.push_back(e);
    primitives.edgeRadius.push_back(Real(0.001));
    primitives.edgeObject.push_back(1);
    primitives.edgeTriangle.push_back(CollisionPrimitives::kNoTriangle);
  }
  // Two free edges, particles 3–4 and 5–6, from `start` to `predicted`.
  void addFreeEdgePair(const Vec3 (&start)[4], const Vec3 (&predicted)[4]) {
    for (Index k = 0; k < 4; ++k) addFree(3 + k, start[k], predicted[k]);
    addFreeEdge({3, 4});
    addFreeEdge({5, 6});
  }
  // The side of point 6 against the plane of triangle 3–5 at positions x (orient3d's sign).
  static int pointSide(const std::vector<Vec3>& x) {
    return orient3d(x[3].cast<double>(), x[4].cast<double>(), x[5].cast<double>(),
                    x[6].cast<double>());
  }
  void addFreeTriangle(const std::array<Index, 3>& t) {
    primitives.triangleParticles.push_back(t);
    primitives.triangleRadius.push_back(Real(0.001));
    primitives.triangleObject.push_back(1);
  }
  // Units in the last place added to every pair's start distance before the fail-safe: the
  // rounding of a start distance the narrow phase measured (in the solve's moving frame, in
  // lanes) rather than measureStartDistances.
  int startDistanceUlps = 0;
  ColliderPool colliders;  // the analytic colliders the impact zones keep out of
  // The pairs of the motion x → p with their bounds, as the solve leaves them, then the
  // fail-safe; `pairCount` is how many candidate pairs there were.
  CrossingReport resolve(std::size_t& pairCount) {
    CandidatePairs pairs;
    PrimitiveBvh bvh;
    findCandidatePairs(pairs, bvh, primitives, particles.x, particles.p, particles.w,
                       kPrimitiveContactMargin);
    setMotionBounds(pairs, particles.x, particles.p);
    growParticleBounds(pairs, boundSlack(primitives, kPrimitiveContactMargin));
    pairCount = pairs.size();
    PrimitiveContactPool contacts;
    measureStartDistances(contacts, pairs, primitives, particles);
    for (double& distance : contacts.startDistance)
      for (int k = 0; k < startDistanceUlps; ++k)
        distance = std::nextafter(distance, std::numeric_limits<double>::infinity());
    return resolveCrossings(contacts, pairs, primitives, colliders, particles);
  }
};

}  // namespace

// A heavy pellet shot through a free cloth at 40 m/s, one substep per step: its contacts do not
// stop it within the step, so the fail-safe holds the crossing particles in impact zones
// (counted), which move as rigid bodies keeping their momentum. With no gravity, ground, pins or
// damping, and Gauss–Seidel (whose stretch, bend and contact projections keep momentum), the total
// linear momentum Σ m v of pellet and cloth stays the pellet's within 1% through the impact.
// (Stopping the crossing particles where the substep began, as the fail-safe did before the
// zones, took the pellet's momentum away.)
TEST(CrossingFailsafe, ImpactZonesKeepMomentum) {
  World world = worldWith(SolverKind::GaussSeidel, 1);
  world.setGravity(Vec3::Zero());
  GridSpec spec;
  spec.resolution = {16, 16};
  spec.size = {Real(0.4), Real(0.4)};
  spec.center = Vec3::Zero();
  ObjectDef cloth = gridCloth(spec);
  cloth.material.mass = Real(0.1);
  cloth.material.thickness = Real(0.002);
  world.addCloth(cloth);
  ObjectDef shot = pellet(Vec3(Real(0.011), Real(0.05), Real(0.007)), Vec3(0, -40, 0), Real(0.002));
  shot.material.mass = Real(0.05);
  world.addParticles(shot);
  const auto momentum = [&] {
    const ParticlePool& particles = world.impl().state.particles;
    Vec3d sum = Vec3d::Zero();
    for (std::size_t i = 0; i < particles.size(); ++i)
      if (particles.w[i] > 0) sum += particles.v[i].cast<double>() / double(particles.w[i]);
    return sum;
  };
  const Vec3d before = momentum();
  ASSERT_NEAR(before.y(), -2.0, 1e-5);
  for (int step = 0; step < 6; ++step) {
    world.step(1.0 / 60);
    EXPECT_LE((momentum() - before).norm(), 0.01 * before.norm()) << "step " << step;
  }
  EXPECT_GT(world.collisionReport().impactZones, 0u);
  EXPECT_EQ(world.recoveries().total(), 0u);
}

// A free point that the solve left crossing a triangle of a turning collider is carried by the
// collider's rigid motion: it ends where that motion takes its start, as seen from the triangle
// (not by the triangle's mean displacement, which for a turn leaves it somewhere else).
TEST(CrossingFailsafe, CarriesAPointWithATurningTriangleRigidly) {
  // A triangle 0.3–0.5 m from the turning axis; the point starts 4 mm above it and was predicted
  // to fall 2 cm, through it.
  const std::array<Vec3, 3> corners = {Vec3(0.3f, 0, -0.1f), Vec3(0.5f, 0, -0.1f),
                                       Vec3(0.4f, 0, 0.1f)};
  FailsafeCase world(corners, 4);
  const Vec3 start(0.4f, 0.004f, 0);
  world.addFree(3, start, start - Vec3(0, 0.02f, 0));
  world.addPoint(3, 1, CollisionPrimitives::kNoTriangle);
  std::size_t pairs = 0;
  const CrossingReport report = world.resolve(pairs);
  ASSERT_EQ(pairs, 1u);

  EXPECT_EQ(report.carried, 1u);
  EXPECT_EQ(report.unresolved, 0u);
  const Vec3 expected = world.turn * start;
  const Vec3& end = world.particles.p[3];
  EXPECT_LT((end - expected).norm(), 1e-5f);
  // Still 4 mm above the turned triangle, on the side it started.
  EXPECT_NEAR(end.y(), 0.004f, 1e-5f);
  Vec3 meanShift = Vec3::Zero();
  for (int k = 0; k < 3; ++k) meanShift += (world.particles.p[k] - corners[k]) / 3;
  EXPECT_GT((start + meanShift - expected).norm(), 0.005f);
}

// A zone whose momentum would turn it by a quarter or more within one substep (a point driven
// through a triangle 1.5 m per substep against it, 5 cm off its centre) only translates, and the
// turn left out is counted: the pair still ends uncrossed.
TEST(CrossingFailsafe, ImpactZoneTurnsOfAQuarterAreLeftOutAndCounted) {
  FailsafeCase c({Vec3(10, 0, 0), Vec3(11, 0, 0), Vec3(10, 0, 1)}, 7);  // a collider far off
  c.addFree(3, Vec3(Real(-0.1), 0, Real(-0.1)), Vec3(Real(-0.1), Real(0.5), Real(-0.1)));
  c.addFree(4, Vec3(Real(0.1), 0, Real(-0.1)), Vec3(Real(0.1), Real(0.5), Real(-0.1)));
  c.addFree(5, Vec3(0, 0, Real(0.1)), Vec3(0, Real(0.5), Real(0.1)));
  c.addFreeTriangle({3, 4, 5});
  c.addFree(6, Vec3(Real(0.05), Real(0.01), 0), Vec3(Real(0.05), Real(-1), 0));
  c.addPoint(6, 1, CollisionPrimitives::kNoTriangle);
  std::size_t pairs = 0;
  const CrossingReport report = c.resolve(pairs);
  EXPECT_GT(report.zones, 0u);
  EXPECT_GT(report.turnsDropped, 0u);
  EXPECT_EQ(report.unresolved, 0u);
  // Translated as one, not turned: the triangle stays level and the point keeps its height over it.
  const ParticlePool& p = c.particles;
  const Vec3 normal = (p.p[4] - p.p[3]).cross(p.p[5] - p.p[3]).normalized();
  EXPECT_NEAR(std::abs(normal.y()), 1, 1e-6);
  EXPECT_NEAR(std::abs(normal.dot(p.p[6] - p.p[3])), 0.01, 1e-5);
}

// A pair that starts touching, closer than float positions resolve but not on each other, and
// whose motion would take it through: its start is crossing-free, so the fail-safe holds it there
// like any other crossing pair. (Passed over as "touching", two layers of a pile of cloth pressed
// flat onto the ground in cloth_drop_sphere at 3 substeps ended a frame with a vertex lying on a
// triangle of the other layer.) The point starts 0.5 nm above a free triangle's centroid and was
// predicted to fall 1 mm through it; the two form an impact zone, which keeps their relative
// configuration: the point ends above the triangle's plane, exactly.
TEST(CrossingFailsafe, APairTouchingAtTheStartIsHeldUncrossed) {
  FailsafeCase c({Vec3(10, 0, 0), Vec3(11, 0, 0), Vec3(10, 0, 1)}, 7);  // a collider far off
  const Vec3 corners[3] = {Vec3(Real(-0.1), 0, Real(-0.1)), Vec3(Real(0.1), 0, Real(-0.1)),
                           Vec3(0, 0, Real(0.1))};
  for (Index k = 0; k < 3; ++k) c.addFree(3 + k, corners[k], corners[k]);
  c.addFreeTriangle({3, 4, 5});
  const Vec3 start(0, Real(5e-10), Real(-0.1) / 3);
  c.addFree(6, start, start - Vec3(0, Real(0.001), 0));
  c.addPoint(6, 1, CollisionPrimitives::kNoTriangle);
  const int startSide = FailsafeCase::pointSide(c.particles.x);
  ASSERT_NE(startSide, 0);
  std::size_t pairs = 0;
  const CrossingReport report = c.resolve(pairs);
  ASSERT_EQ(pairs, 1u);
  EXPECT_EQ(report.unresolved, 0u);
  EXPECT_GT(report.zones, 0u);
  EXPECT_EQ(FailsafeCase::pointSide(c.particles.p), startSide);
}

// A point that the solve left lying exactly in a free triangle's plane, inside it, having moved
// straight onto it by exactly its start distance: it touches the triangle, which the CCD at zero
// thickness counts as reached and the intersection measure as intersecting. Its start distance
// as the narrow phase measured it exceeded that motion by 3 units in the last place, and a test
// of "the motion cannot use up the start distance" without a margin for that rounding passed the
// pair over (a vertex of one layer of cloth_stack pressed onto the ground, at one substep, onto
// the layer lying there: eight intersecting triangle pairs in two frames, none reported
// unresolved). The triangle and the point of that frame, bit for bit, then the point moved
// across the triangle in 20 steps: each ends held on the side it started.
TEST(CrossingFailsafe, APointEndingExactlyOnATriangleIsHeldUncrossed) {
  const Real height = 0x1.89374cp-9f;  // 3 mm: the triangle lies on the ground
  const Vec3 corners[3] = {Vec3(-0x1.ab0fdcp-6f, height, 0x1.35c05cp-2f),
                           Vec3(-0x1.e8ef16p-8f, height, 0x1.204826p-2f),
                           Vec3(-0x1.bd52fcp-8f, height, 0x1.351f46p-2f)};
  const Vec3 first(-0x1.c2ff26p-7f, 0x1.e37a86p-9f, 0x1.2a7012p-2f);
  for (int k = 0; k < 20; ++k) {
    FailsafeCase c({Vec3(10, 0, 0), Vec3(11, 0, 0), Vec3(10, 0, 1)}, 7);  // a collider far off
    c.startDistanceUlps = 3;
    for (Index j = 0; j < 3; ++j) c.addFree(3 + j, corners[j], corners[j]);
    c.addFreeTriangle({3, 4, 5});
    const Vec3 start = first + Real(k) * Vec3(Real(-0.0002), 0, Real(0.00025));
    c.addFree(6, start, Vec3(start.x(), height, start.z()));
    c.addPoint(6, 1, CollisionPrimitives::kNoTriangle);
    const int startSide = FailsafeCase::pointSide(c.particles.x);
    ASSERT_NE(startSide, 0);
    ASSERT_EQ(FailsafeCase::pointSide(c.particles.p), 0)
        << "the prediction lies in the triangle's plane";
    std::size_t pairs = 0;
    const CrossingReport report = c.resolve(pairs);
    ASSERT_EQ(pairs, 1u);
    EXPECT_EQ(report.unresolved, 0u);
    EXPECT_GT(report.zones, 0u) << "case " << k;
    EXPECT_EQ(FailsafeCase::pointSide(c.particles.p), startSide) << "case " << k;
  }
}

// Two edges of one sheet lying flat on the ground across each other, one end a unit in the last
// place lower than the rest: 1.5 × 10⁻¹⁰ m apart where they cross, farther than the touching
// distance of free pairs (10⁻¹²) but within the CCD's tolerance, which counts even their start,
// standing still, as reached. Counted as crossing, such a pair was held to its start in every
// round and left unresolved, its impact zone stopped in every substep, so its particles stayed
// still while the cloth around them moved on (torture/high_drop at one substep, and the 128²
// drape on a box at three with supported particles weighed in the generic projections: edges
// beside them stretched 40 times). It has no crossing-free start to keep: it is left to its
// contacts, and the pair slides on with the sheet. The four positions are that pair's, bit for
// bit.
TEST(CrossingFailsafe, APairTheCcdCountsAsReachedAtItsStartIsLeftToItsContacts) {
  FailsafeCase c({Vec3(10, 0, 0), Vec3(11, 0, 0), Vec3(10, 0, 1)}, 7);  // a collider far off
  const Vec3 start[4] = {Vec3(0x1.2c63a6p-2f, 0x1.89374cp-9f, 0x1.85cb2ap-2f),
                         Vec3(0x1.46d42ep-2f, 0x1.89374ap-9f, 0x1.79821ep-2f),
                         Vec3(0x1.38f9c4p-2f, 0x1.89374cp-9f, 0x1.78679p-2f),
                         Vec3(0x1.46394p-2f, 0x1.89374cp-9f, 0x1.889478p-2f)};
  const Vec3 slide(Real(0.0078125), 0, 0);  // a power of two: every coordinate moves exactly
  Vec3 slid[4];
  for (Index k = 0; k < 4; ++k) slid[k] = start[k] + slide;
  c.addFreeEdgePair(start, slid);
  std::size_t pairs = 0;
  const CrossingReport report = c.resolve(pairs);
  ASSERT_EQ(pairs, 1u);
  EXPECT_EQ(report.crossings, 0u);
  EXPECT_EQ(report.unresolved, 0u);
  for (Index k = 0; k < 4; ++k) EXPECT_EQ(c.particles.p[3 + k], start[k] + slide) << k;
}

// Two cloth edges 6.8 × 10⁻⁷ m apart (cloth_drop_sphere at 2 substeps × 10 sweeps, the four
// positions bit for bit), predicted to turn through about 18° with their impact zone and, on top
// of it, to pass through each other. The zone takes them along its rigid motion, which cannot
// cross them; asked about that motion, the CCD stepped the turning pair forward a sliver at a
// time and reported a hit at its iteration cap, in every round, until the zones stopped at half
// the round limit (the particles held where the substep began). Now a pair that moves with one
// zone is not asked: one round finds the crossing, the next none, and the zone keeps its motion.
TEST(CrossingFailsafe, APairTurningWithItsZoneIsNotCrossingAgain) {
  FailsafeCase c({Vec3(10, 0, 0), Vec3(11, 0, 0), Vec3(10, 0, 1)}, 7);  // a collider far off
  const Vec3 start[4] = {Vec3(0x1.901166p-3f, 0x1.cd74bap-6f, 0x1.7f8d64p-4f),
                         Vec3(0x1.7f695ep-3f, 0x1.6ca472p-6f, 0x1.2bf162p-4f),
                         Vec3(0x1.98375cp-3f, 0x1.1fada4p-5f, 0x1.54989cp-4f),
                         Vec3(0x1.7a919ep-3f, 0x1.13614ap-6f, 0x1.60b26cp-4f)};
  const Vec3 turned[4] = {Vec3(0x1.a2dae8p-3f, 0x1.9f047ap-6f, 0x1.709f04p-4f),
                          Vec3(0x1.89eb5ep-3f, 0x1.721f7p-6f, 0x1.22b126p-4f),
                          Vec3(0x1.abaaf6p-3f, 0x1.ff980ep-6f, 0x1.439656p-4f),
                          Vec3(0x1.85c838p-3f, 0x1.2088b6p-6f, 0x1.587408p-4f)};
  // The edges' common normal at the start, and a push along it through the other edge: equal and
  // opposite, so the pair's momentum is the turn's.
  const Vec3 normal = (start[1] - start[0]).cross(start[3] - start[2]).normalized();
  const Real side = normal.dot(start[0] - start[2]) > 0 ? Real(1) : Real(-1);
  const Vec3 push = Real(0.002) * side * normal;
  Vec3 predicted[4];
  for (Index k = 0; k < 4; ++k) predicted[k] = turned[k] + (k < 2 ? -push : push);
  c.addFreeEdgePair(start, predicted);
  std::size_t pairs = 0;
  const CrossingReport report = c.resolve(pairs);
  ASSERT_EQ(pairs, 1u);
  EXPECT_EQ(report.crossings, 1u);
  EXPECT_EQ(report.rounds, 2);
  EXPECT_EQ(report.zones, 1u);
  EXPECT_EQ(report.stoppedZones, 0u);
  EXPECT_EQ(report.unresolved, 0u);
  // Held to a rigid motion of the start: the edges keep their lengths and their distance, and
  // they moved (a stopped zone would have left them where they began).
  EXPECT_NEAR((c.particles.p[4] - c.particles.p[3]).norm(), (start[1] - start[0]).norm(), 1e-6f);
  EXPECT_NEAR((c.particles.p[6] - c.particles.p[5]).norm(), (start[3] - start[2]).norm(), 1e-6f);
  for (Index k = 0; k < 4; ++k)
    EXPECT_GT((c.particles.p[3 + k] - start[k]).norm(), Real(0.005)) << k;
}

// A crossing pair lying on the ground, predicted to slide 2 cm along it while sinking into the
// ground's contact layer: a cloth triangle at the layer's top and a vertex 2 mm above it that
// passes through it. The zone's rigid motion would take the triangle deeper into the layer;
// halved six times it still would, and the zone stopped where the substep began, its particles
// held still while their cloth slid on. Now it keeps what the plane allows: the slide, without
// the sinking.
TEST(CrossingFailsafe, AZoneOnTheGroundSlidesAlongItInsteadOfStopping) {
  FailsafeCase c({Vec3(10, 0, 0), Vec3(11, 0, 0), Vec3(10, 0, 1)}, 7);  // a collider far off
  const Real layer = Real(0.003);
  c.colliders.append(ColliderShape::Plane, Vec3::Zero(), Vec3::UnitY(), 0, layer, Real(0.5),
                     Real(0.5));
  const Vec3 slide(Real(0.02), 0, 0);
  const Vec3 triangle[3] = {Vec3(0, layer, 0), Vec3(Real(0.02), layer, 0),
                            Vec3(0, layer, Real(0.02))};
  for (Index k = 0; k < 3; ++k)
    c.addFree(3 + k, triangle[k], triangle[k] + slide - Vec3(0, Real(0.001), 0));
  const Vec3 vertex(Real(0.005), layer + Real(0.002), Real(0.005));
  c.addFree(6, vertex, vertex + slide - Vec3(0, Real(0.006), 0));
  c.addFreeTriangle({3, 4, 5});
  c.addPoint(6, 1, CollisionPrimitives::kNoTriangle);
  std::size_t pairs = 0;
  const CrossingReport report = c.resolve(pairs);
  ASSERT_GE(pairs, 1u);
  EXPECT_GE(report.crossings, 1u);
  EXPECT_EQ(report.zones, 1u);
  // Slowed, not stopped: its sinking went to the ground, and the zone is counted for it.
  EXPECT_EQ(report.stoppedZones, 1u);
  EXPECT_EQ(report.unresolved, 0u);
  for (Index k = 0; k < 4; ++k) {
    const Vec3 from = k < 3 ? triangle[k] : vertex;
    // The slide kept (the zone's mean motion along the ground), the height kept to rounding.
    EXPECT_NEAR(c.particles.p[3 + k].x() - from.x(), slide.x(), 1e-6f) << k;
    EXPECT_NEAR(c.particles.p[3 + k].y(), from.y(), 1e-7f) << k;
    EXPECT_NEAR(c.particles.p[3 + k].z(), from.z(), 1e-6f) << k;
  }
}

// The same when the collider's side of the pair is a point: its turn comes from a triangle of the
// collider that contains it.
TEST(CrossingFailsafe, CarriesATriangleWithATurningColliderVertexRigidly) {
  // The collider's vertex 0 is also a point primitive; a free cloth triangle (3–5) 4 mm below
  // that vertex was predicted to rise 2 cm through it.
  FailsafeCase world({Vec3(0.4f, 0, 0), Vec3(0.6f, 0, -0.1f), Vec3(0.6f, 0, 0.1f)}, 6);
  const Vec3 cloth[3] = {Vec3(0.35f, -0.004f, -0.05f), Vec3(0.45f, -0.004f, -0.05f),
                         Vec3(0.4f, -0.004f, 0.05f)};
  for (Index k = 0; k < 3; ++k) world.addFree(3 + k, cloth[k], cloth[k] + Vec3(0, 0.02f, 0));
  world.addPoint(0, 0, 0);
  world.addFreeTriangle({3, 4, 5});
  std::size_t pairs = 0;
  const CrossingReport report = world.resolve(pairs);
  ASSERT_EQ(pairs, 1u);

  EXPECT_EQ(report.carried, 3u);
  EXPECT_EQ(report.unresolved, 0u);
  for (int k = 0; k < 3; ++k)
    EXPECT_LT((world.particles.p[3 + k] - world.turn * cloth[k]).norm(), 1e-5f) << k;
}
