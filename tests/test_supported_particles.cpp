// Supported particles (systems/solver/supported_particles.h): the ends of a two-particle constraint
// between a particle a pressed, frictional contact holds and a free one are reweighed in the
// Gauss–Seidel sweeps, their sum kept; a draped rope's weight then reaches its support in fewer
// sweeps.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/src/world_state.h"
#include "systems/solver/supported_particles.h"
#include "tests/sim_test_context.h"

namespace nucleon {
namespace {

// A 4-particle rope along +x whose particles 0 and 1 a frictional collider presses, its surface
// facing −x there: particle 2 lies on the support's side of particle 1's tangent plane, i.e.
// hangs from it. The constraint 0–1 (both supported) keeps its inverse masses, 1–2 (supported,
// hanging) gets the supported end's scaled by k and both rescaled to their old sum, 2–3 (free,
// free) is untouched; release restores them all. With the surface facing +x, particle 2 rises
// from particle 1's support (kRisingCosine) and nothing changes.
TEST(SupportedParticles, ReweighsSupportedAgainstFreeEndsAndKeepsTheirSum) {
  World world;
  ObjectDef rope = polylineRope(Vec3(0, 1, 0), Vec3(Real(0.3), 1, 0), 3);
  rope.material.mass = Real(0.4);
  world.addRope(rope);
  world.step(1.0 / 60);  // builds the derived tables, endInverseMass among them
  WorldState& state = world.impl().state;
  ConstraintPool<2>& stretch = state.constraints.stretch;
  ASSERT_EQ(stretch.size(), 3u);
  ASSERT_EQ(stretch.endInverseMass.size(), 3u);
  const std::vector<Real> w = state.particles.w;
  ColliderPool colliders;
  colliders.friction = {Real(0.5)};
  ContactPool contacts;
  contacts.resize(2);
  contacts.particle = {0, 1};
  contacts.collider = {0, 0};
  contacts.lambda = {Real(1e-4), Real(2e-4)};
  contacts.normal = {Vec3(-1, 0, 0), Vec3(-1, 0, 0)};
  const PrimitiveContactPool none;
  const Real k = Real(0.1);
  ASSERT_EQ(
      weighSupportedParticles(state.constraints, contacts, colliders, none, state.particles, k),
      2u);
  for (std::size_t c = 0; c < stretch.size(); ++c) {
    const Index a = stretch.particles[c][0], b = stretch.particles[c][1];
    const std::array<Real, 2>& end = stretch.endInverseMass[c];
    EXPECT_NEAR(end[0] + end[1], w[a] + w[b], 1e-6f * (w[a] + w[b])) << c;
    const bool supportedA = a < 2, supportedB = b < 2;
    if (supportedA == supportedB) {
      EXPECT_EQ(end[0], w[a]) << c;
      EXPECT_EQ(end[1], w[b]) << c;
    } else {
      const Real supportedEnd = supportedA ? end[0] : end[1],
                 freeEnd = supportedA ? end[1] : end[0];
      const Real wSupported = supportedA ? w[a] : w[b], wFree = supportedA ? w[b] : w[a];
      EXPECT_NEAR(supportedEnd / freeEnd, k * wSupported / wFree, 1e-6f) << c;
    }
  }
  releaseSupportedParticles(state.constraints, contacts, state.particles);
  const auto expectUnweighed = [&] {
    for (std::size_t c = 0; c < stretch.size(); ++c)
      for (int e = 0; e < 2; ++e)
        EXPECT_EQ(stretch.endInverseMass[c][e], w[stretch.particles[c][e]]) << c << ' ' << e;
  };
  expectUnweighed();

  contacts.normal = {Vec3(1, 0, 0), Vec3(1, 0, 0)};
  EXPECT_EQ(
      weighSupportedParticles(state.constraints, contacts, colliders, none, state.particles, k),
      2u);
  expectUnweighed();
  releaseSupportedParticles(state.constraints, contacts, state.particles);

  // A contact that has not pressed (λ = 0), or a frictionless one, supports nothing.
  contacts.lambda = {0, 0};
  EXPECT_EQ(
      weighSupportedParticles(state.constraints, contacts, colliders, none, state.particles, k),
      0u);
  contacts.lambda = {Real(1e-4), Real(1e-4)};
  colliders.friction = {0};
  EXPECT_EQ(
      weighSupportedParticles(state.constraints, contacts, colliders, none, state.particles, k),
      0u);
  expectUnweighed();
}

struct DrapeResult {
  std::size_t recoveries = 0;
  std::vector<Vec3> positions;
};

// A 1.2 m rope of 60 segments laid across the top of a 0.2 m sphere, each half hanging, colored
// Gauss–Seidel × 10 at one substep for 1.5 s.
DrapeResult drapeRopeOverSphere(Real supportedScale, Real friction) {
  SphereCollider sphere;
  sphere.center = Vec3(0, 1, 0);
  sphere.radius = Real(0.2);
  sphere.thickness = Real(0.005);
  sphere.friction = sphere.staticFriction = friction;
  World world;
  SolverSettings settings = test::solverSettings(SolverKind::ColoredGaussSeidel, 10, 1);
  settings.supportedInverseMassScale = supportedScale;
  world.setSolver(settings);
  world.addSphereCollider(sphere);
  const Real top = Real(1.2 + 0.005 + 0.001);
  ObjectDef rope = polylineRope(Vec3(Real(-0.6), top, 0), Vec3(Real(0.6), top, 0), 60);
  rope.material.mass = Real(0.2);
  world.addRope(rope);
  test::simulate(world, 90);
  DrapeResult result;
  result.recoveries = world.recoveries().total();
  result.positions.assign(world.positions().begin(), world.positions().end());
  return result;
}

// Without friction no contact holds anything: the run is the same, bit for bit, at any scale.
TEST(SupportedParticles, FrictionlessSupportsAreLeftAsTheyWere) {
  const DrapeResult plain = drapeRopeOverSphere(1, 0);
  const DrapeResult weighed = drapeRopeOverSphere(Real(0.1), 0);
  EXPECT_EQ(plain.recoveries, 0u);
  // The rope lies on the sphere with both halves hanging (below its centre's height): there are
  // contacts to weigh.
  Real lowest = 1e9;
  for (const Vec3& x : plain.positions) lowest = std::min(lowest, x.y());
  EXPECT_LT(lowest, Real(1.0));
  ASSERT_EQ(plain.positions.size(), weighed.positions.size());
  for (std::size_t i = 0; i < plain.positions.size(); ++i)
    EXPECT_EQ(plain.positions[i], weighed.positions[i]) << i;
}

// The scale is a factor on an inverse mass: 0 would make a supported particle a pin, above 1 it
// would push the supported particle into its support harder than plain sweeps. Both, NaN and
// a negative value are refused, by World::setSolver and in a scene file.
TEST(SupportedParticles, AScaleOutsideItsRangeIsRefused) {
  for (Real bad : {Real(0), Real(-0.5), Real(1.5), std::numeric_limits<Real>::quiet_NaN()}) {
    World world;
    SolverSettings settings = test::solverSettings(SolverKind::ColoredGaussSeidel, 10, 1);
    settings.supportedInverseMassScale = bad;
    EXPECT_THROW(world.setSolver(settings), std::invalid_argument) << bad;
  }
  const std::string scene =
      R"({"name": "t", "frames": 1, "solver": {"type": "colored-gs",
          "supported_inverse_mass_scale": 0}, "objects": []})";
  EXPECT_NE(test::sceneError(scene).find("supported_inverse_mass_scale"), std::string::npos)
      << test::sceneError(scene);
}

}  // namespace
}  // namespace nucleon
