// Dynamics against physics: free fall against the integrator's closed form and the analytic
// parabola, a pendulum's length and period, a hanging cloth's convergence with sweeps, energy.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "sim_test_context.h"

using namespace nucleon;

namespace {
constexpr double kG = 9.81;
}

TEST(FreeFall, MatchesTheIntegratorsRecurrenceBitForBit) {
  World world;
  ObjectDef point;
  point.vertices = {Vec3(0, 10, 0)};
  point.velocity = Vec3(1, 2, 0);
  world.addParticles(point);
  const Real h = Real(1.0 / 60);
  Vec3 x = point.vertices[0], v = point.velocity;
  const Vec3 g = world.gravity();
  for (int n = 0; n < 100; ++n) {
    world.step(1.0 / 60);
    // Symplectic Euler, written with the same operations as the systems: v += h g; x = x + h v.
    v += h * g;
    x = x + h * v;
    ASSERT_EQ(world.positions()[0], x) << "step " << n;
    ASSERT_EQ(world.velocities()[0], v) << "step " << n;
  }
}

TEST(FreeFall, FollowsClosedFormAndConvergesToTheParabolaAtFirstOrder) {
  // x_n = x0 + n h v0 − g h² n(n+1)/2 exactly for symplectic Euler; the analytic parabola
  // x0 + t v0 − g t²/2 differs from it by −g t h / 2, an O(h) error that halves with h.
  const double t = 100.0 / 60;
  double previousError = 0;
  for (int substeps : {1, 2, 4}) {
    World world;
    ObjectDef point;
    point.vertices = {Vec3(0, 10, 0)};
    point.velocity = Vec3(0, 3, 0);
    world.addParticles(point);
    world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 10, substeps));
    for (int i = 0; i < 100; ++i) world.step(1.0 / 60);
    const double n = 100.0 * substeps, h = t / n;
    const double closedForm = 10 + n * h * 3 - kG * h * h * n * (n + 1) / 2;
    const double y = world.positions()[0].y();
    // Float state: 100·substeps additions of a few units at ε = 6e-8 each stay below 1e-4.
    EXPECT_NEAR(y, closedForm, 1e-4) << substeps;
    const double analytic = 10 + t * 3 - kG * t * t / 2;
    const double error = y - analytic;
    EXPECT_NEAR(error, -kG * t * h / 2, 1e-4) << substeps;
    if (previousError != 0) {
      EXPECT_NEAR(error / previousError, 0.5, 0.01) << substeps;
    }
    previousError = error;
  }
}

TEST(Pendulum, KeepsItsLengthAndSwingsWithTheSmallAnglePeriod) {
  const double length = 1.0, theta0 = 0.05;
  ObjectDef rope;
  const Vec3 pivot(0, 2, 0);
  rope.vertices = {
      pivot, pivot + Vec3(Real(length * std::sin(theta0)), Real(-length * std::cos(theta0)), 0)};
  rope.edges = {{0, 1}};
  rope.pins = {0};
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 1, 4));
  world.addRope(rope);

  const double dt = 1.0 / 60;
  std::vector<double> upwardCrossings;  // times where x goes from negative to positive
  double previousX = world.positions()[1].x(), maxLengthError = 0;
  for (int frame = 1; frame <= 60 * 8; ++frame) {
    world.step(dt);
    const Vec3 bob = world.positions()[1];
    maxLengthError = std::max(maxLengthError, std::abs((bob - pivot).norm() / length - 1));
    const double x = bob.x();
    if (previousX < 0 && x >= 0)  // linear interpolation of the crossing time within the frame
      upwardCrossings.push_back((frame - 1 + previousX / (previousX - x)) * dt);
    previousX = x;
  }
  EXPECT_LT(maxLengthError, 1e-4);
  ASSERT_GE(upwardCrossings.size(), 3u);
  const double period = (upwardCrossings.back() - upwardCrossings.front()) /
                        static_cast<double>(upwardCrossings.size() - 1);
  const double expected = 2 * std::numbers::pi * std::sqrt(length / kG);
  // The 5% amplitude adds (θ0²/16) ≈ 0.016% to the period; the rest is the scheme's error.
  EXPECT_NEAR(period / expected, 1.0, 0.02) << "period " << period;
}

TEST(HangingCloth, MaxStrainDecreasesMonotonicallyWithSweeps) {
  double previous = std::numeric_limits<double>::infinity();
  for (int sweeps : {1, 2, 4, 8, 16}) {
    World world = test::hangingCloth(24, sweeps);
    test::simulate(world, 90);
    const Measures m = world.measure();
    EXPECT_EQ(m.nanCount, 0u);
    EXPECT_LT(m.maxStrain, previous) << sweeps << " sweeps";
    previous = m.maxStrain;
  }
}

TEST(HangingCloth, NeverGainsEnergy) {
  // Constraint projection only removes energy (PBD is dissipative), so kinetic + potential
  // energy stays below its initial value, up to float rounding of the potential (~1e-6 relative).
  World world = test::hangingCloth(16, 10);
  const Measures start = world.measure();
  const double e0 = start.kineticEnergy + start.potentialEnergy;
  for (int frame = 0; frame < 120; ++frame) {
    world.step(1.0 / 60);
    const Measures m = world.measure();
    ASSERT_LE(m.kineticEnergy + m.potentialEnergy, e0 + 1e-5 * std::abs(e0) + 1e-6)
        << "frame " << frame;
  }
}

TEST(World, RejectsBadInputWithoutChangingState) {
  World world;
  ObjectDef point;
  point.vertices = {Vec3(0, 1, 0)};
  world.addParticles(point);
  const std::uint64_t before = world.stateHash();
  for (double dt : {0.0, -1.0, 5.0, std::nan(""), std::numeric_limits<double>::infinity()})
    EXPECT_THROW(world.step(dt), std::invalid_argument) << dt;
  EXPECT_EQ(world.stateHash(), before);

  ObjectDef bad = point;
  bad.material.mass = 0;
  EXPECT_THROW(world.addParticles(bad), std::invalid_argument);
  bad = point;
  bad.vertices[0].x() = std::numeric_limits<Real>::quiet_NaN();
  EXPECT_THROW(world.addParticles(bad), std::invalid_argument);
  bad = point;
  bad.pins = {3};
  EXPECT_THROW(world.addParticles(bad), std::invalid_argument);
  for (Real limit : {std::numeric_limits<Real>::quiet_NaN(), Real(2000)}) {
    bad = point;
    bad.material.stretchLimit = limit;
    EXPECT_THROW(world.addParticles(bad), std::invalid_argument) << limit;
  }
  ObjectDef tri;
  tri.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};  // collinear: zero area
  tri.triangles = {{0, 1, 2}};
  EXPECT_THROW(world.addCloth(tri), MeshError);
  EXPECT_EQ(world.objectCount(), 1u);
  EXPECT_EQ(world.particleCount(), 1u);
}

TEST(World, PositionsAreAViewIntoThePool) {
  World world = test::hangingCloth(8, 4);
  const auto before = world.positions();
  world.step(1.0 / 60);
  const auto after = world.positions();
  EXPECT_EQ(before.data(), after.data());  // no copy, no reallocation in a step
  EXPECT_EQ(after.size(), 64u);
  EXPECT_EQ(world.positions(world.objectAt(0)).data(), after.data());
}
