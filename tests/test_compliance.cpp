// Compliance and damping against physics: a softened hanging rope settles at the static
// extension of its springs, a softened cloth sags the same for any sweep or substep count, the
// Rayleigh damping of a mass on a spring decays at the analytic rate, the three backends reach
// the same equilibrium, and bending, shear and twist hold the shapes they should.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <numbers>

#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"
#include "systems/setup/build_constraint_graph.h"

using namespace nucleon;

namespace {

constexpr double kG = 9.81;

// A softened 16×16 curtain, 1 m square, hanging in its own plane from its two top corners and
// damped, so that it comes to rest without swinging (damping acts on deformation only; a cloth
// released horizontally would swing about its pins as a pendulum for a long time).
World softCurtain(SolverKind kind, int sweeps, int substeps, int resolution = 16) {
  GridSpec spec;
  spec.resolution = {resolution, resolution};
  spec.size = {1, 1};
  spec.center = Vec3(0, 1, 0);
  spec.vertical = true;
  ObjectDef cloth = gridCloth(spec);
  Index left = 0, right = 0;
  for (Index i = 0; i < cloth.vertices.size(); ++i) {
    const Vec3& v = cloth.vertices[i];
    if (v.y() >= cloth.vertices[left].y() && v.x() <= cloth.vertices[left].x()) left = i;
    if (v.y() >= cloth.vertices[right].y() && v.x() >= cloth.vertices[right].x()) right = i;
  }
  cloth.pins = {left, right};
  cloth.material.stretchCompliance = cloth.material.compressionCompliance = Real(5e-2);
  cloth.material.damping = Real(0.05);
  World world;
  world.setSolver(test::solverSettings(kind, sweeps, substeps));
  world.addCloth(cloth);
  return world;
}

// Depth of the lowest point below the pins (at y = 1.5).
double sag(const World& world) {
  return 1.5 - world.measure().minHeight;
}

}  // namespace

// Static equilibrium of a vertical chain of springs: segment i carries the weight of everything
// below it, so it stretches by α·g·m_below(i), and the rope's extension is α g Σ_i m_below(i).
// Lumped masses: M/N per interior vertex, M/2N at the ends. Damping brings it to rest; 10 s is
// more than 20 decay times.
TEST(Compliance, HangingRopeSettlesAtTheStaticExtensionOfItsSprings) {
  const int n = 20;
  const double mass = 1, length = 1, alpha = 1e-3;
  ObjectDef rope = polylineRope(Vec3(0, 1, 0), Vec3(0, 0, 0), n);
  rope.pins = {0};
  rope.material.mass = Real(mass);
  rope.material.stretchCompliance = Real(alpha);
  rope.material.damping = Real(0.05);
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 40, 4));
  world.addRope(rope);
  test::simulate(world, 600);

  double expected = 0, below = mass / (2 * n);  // the bottom vertex
  for (int i = n; i >= 1; --i) {
    expected += alpha * kG * below;
    below += mass / n;
  }
  const auto x = world.positions(world.objectAt(0));
  const double extension = (x[0] - x[n]).norm() - length;
  EXPECT_NEAR(extension, expected, 0.01 * expected) << "expected " << expected;
  EXPECT_LT(world.measure().kineticEnergy, 1e-8);
}

// With edge compliance 0.05 m/N the curtain hangs about 40% longer than at rest. Measured sags:
// 1.425 m at 20 sweeps vs 1.413 m at 80 (0.9%); 1.414 m at 1 substep vs 1.417 m at 4 (0.2%).
// Stiffer cloth is not converged by 20 Gauss–Seidel sweeps, and then sags more than at 80.
namespace {
// Settles two soft curtains that differ only in sweeps or substeps; their sags agree within 2%.
void expectSameSag(int sweepsA, int substepsA, int sweepsB, int substepsB) {
  World a = softCurtain(SolverKind::GaussSeidel, sweepsA, substepsA),
        b = softCurtain(SolverKind::GaussSeidel, sweepsB, substepsB);
  test::simulate(a, 300);
  test::simulate(b, 300);
  EXPECT_NEAR(sag(a), sag(b), 0.02 * sag(b)) << sag(a) << " vs " << sag(b);
}
}  // namespace

TEST(Compliance, SoftClothSagsTheSameFor20And80Sweeps) {
  expectSameSag(20, 1, 80, 1);
}

TEST(Compliance, SoftClothSagsTheSameFor1And4Substeps) {
  expectSameSag(40, 1, 40, 4);
}

namespace {

// A 1 kg particle on a vertical spring (a one-segment rope of 2 kg: half its mass at each end,
// the top end pinned), released at the spring's rest length. Returns the natural log of the
// oscillation amplitude at each extremum, with its time.
std::vector<std::pair<double, double>> springExtrema(double alpha, double damping, int substeps) {
  ObjectDef rope = polylineRope(Vec3(0, 1, 0), Vec3(0, 0, 0), 1);
  rope.pins = {0};
  rope.material.mass = 2;
  rope.material.stretchCompliance = rope.material.compressionCompliance = Real(alpha);
  rope.material.damping = Real(damping);
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 1, substeps));
  world.addRope(rope);
  const double equilibrium = -alpha * kG;  // y where k·extension = m g, k = 1/α, m = 1
  std::vector<double> y;
  const double h = 1.0 / 60;
  for (int i = 0; i < 180; ++i) {
    world.step(h);
    y.push_back(world.positions()[1].y() - equilibrium);
  }
  std::vector<std::pair<double, double>> extrema;
  for (std::size_t i = 1; i + 1 < y.size(); ++i)
    if (std::abs(y[i]) >= std::abs(y[i - 1]) && std::abs(y[i]) > std::abs(y[i + 1]))
      extrema.emplace_back((i + 1) * h, std::log(std::abs(y[i])));
  return extrema;
}

// Least-squares slope of log-amplitude against time: the decay rate, negated.
double decayRate(const std::vector<std::pair<double, double>>& points) {
  double st = 0, sl = 0, stt = 0, stl = 0;
  const double n = static_cast<double>(points.size());
  for (auto [t, l] : points) st += t, sl += l, stt += t * t, stl += t * l;
  return -(n * stl - st * sl) / (n * stt - st * st);
}

}  // namespace

// Rayleigh damping c = τ k on a mass-spring decays the amplitude as e^(−ζωt) with ζω = c/2m =
// τ ω² / 2. The implicit integration damps by itself (about ω² h / 2 at small ω h), so the test
// compares the decay with and without τ: their difference is τ ω² / 2. ω = 10 rad/s, h = 1/600 s,
// τ = 0.01 s: the expected extra decay is 0.5 /s. Peaks are sampled at 60 Hz (period 0.63 s), so
// each sits within half a frame of the true extremum; 5% covers that.
TEST(Damping, MassOnASpringDecaysAtTheRayleighRate) {
  const double alpha = 0.01, tau = 0.01, omega = std::sqrt(1 / alpha);
  const auto undamped = springExtrema(alpha, 0, 10), damped = springExtrema(alpha, tau, 10);
  ASSERT_GE(undamped.size(), 6u);
  ASSERT_GE(damped.size(), 6u);
  const double numerical = decayRate(undamped), total = decayRate(damped);
  EXPECT_LT(numerical, 0.2);  // ω² h / 2 ≈ 0.08 /s
  EXPECT_NEAR(total - numerical, tau * omega * omega / 2, 0.05 * tau * omega * omega / 2)
      << "numerical " << numerical << ", with damping " << total;
}

// The three backends solve the same equations: converged and at rest, they settle on the same
// shape. An 8×8 curtain with 200 sweeps converges for all three (Gauss–Seidel's sag is the same
// to 0.1 mm from 60 sweeps on; Jacobi's is 0.3 mm from it at 200): every particle within 5 mm
// (0.5% of the curtain's size; Jacobi's worst is 2.1 mm, sideways) of the Gauss–Seidel result.
// Jacobi's mass splitting matters here: with plain averaging it settled 1.3 m lower.
TEST(Backends, ReachTheSameEquilibriumOnASmallCloth) {
  World reference = softCurtain(SolverKind::GaussSeidel, 200, 1, 8);
  test::simulate(reference, 300);
  for (SolverKind kind : {SolverKind::Jacobi, SolverKind::ColoredGaussSeidel}) {
    World world = softCurtain(kind, 200, 1, 8);
    test::simulate(world, 300);
    double worst = 0;
    for (std::size_t i = 0; i < world.particleCount(); ++i)
      worst = std::max(worst, double((world.positions()[i] - reference.positions()[i]).norm()));
    EXPECT_LT(worst, 0.005) << toString(kind) << " sag " << sag(world) << " vs " << sag(reference);
  }
}

namespace {
// Largest droop of the tip of a 1 m horizontal rope of 10 segments, clamped at one end (its first
// two vertices pinned), over 2 s. Hard angle chains converge slowly per sweep; substeps are what
// make them stiff (10 substeps × 10 sweeps: 5 mm at the tip, against 0.23 m at 1 × 10).
double cantileverDroop(bool bending, Real bendCompliance) {
  ObjectDef rope = polylineRope(Vec3(0, 1, 0), Vec3(1, 1, 0), 10);
  rope.pins = {0, 1};
  rope.material.bending = bending;
  rope.material.bendCompliance = bendCompliance;
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 10, 10));
  world.addRope(rope);
  double droop = 0;
  for (int i = 0; i < 120; ++i) {
    world.step(1.0 / 60);
    droop = std::max(droop, 1.0 - world.positions()[10].y());
  }
  return droop;
}
}  // namespace

// Type 2 bending holds a cantilever: hard angles keep the tip within 1 cm of its rest height,
// a soft bend compliance lets it droop further, and without bending it swings down.
TEST(Bending, StiffCurveHoldsACantilever) {
  const double stiff = cantileverDroop(true, 0), soft = cantileverDroop(true, Real(0.5)),
               none = cantileverDroop(false, 0);
  EXPECT_LT(stiff, 0.01);
  EXPECT_GT(soft, 2 * stiff);
  EXPECT_GT(none, 0.5);  // a free rope swings down (0.89 m)
  EXPECT_LT(soft, none);
}

namespace {
World hangingCloth32(bool tethers, SolverKind kind = SolverKind::GaussSeidel) {
  GridSpec spec;
  spec.resolution = {32, 32};
  ObjectDef cloth = gridCloth(spec);
  cloth.pins = {0, 31};
  cloth.material.tethers = tethers;
  World world;
  world.setSolver(test::solverSettings(kind, 4, 1));
  world.addCloth(cloth);
  return world;
}
}  // namespace

// Tethers bound how far a free vertex gets from its nearest pin: after every step, each is
// within its rest path length (here they are the last family of each round, so they hold up
// to rounding). With only 4 sweeps, the same cloth without tethers reaches twice the max strain
// (measured 0.63 against 1.25).
TEST(Tethers, HoldEveryVertexWithinItsRestPathFromThePin) {
  World tethered = hangingCloth32(true), loose = hangingCloth32(false);
  test::simulate(tethered, 120);
  test::simulate(loose, 120);
  const auto& pool = tethered.impl().state.constraints.tether;
  ASSERT_EQ(pool.size(), 2u * (32u * 32u - 2u));  // every free vertex to each of the two pins
  const auto x = tethered.positions();
  double worst = 0;
  for (std::size_t c = 0; c < pool.size(); ++c) {
    const auto [free, pin] = pool.particles[c];
    worst = std::max(worst, double((x[free] - x[pin]).norm() / pool.rest[c]) - 1);
  }
  // A vertex's two limits are projected one after the other: the last holds to rounding, the
  // first overshoots where the two nearly conflict (the taut top edge, measured 3.6%).
  EXPECT_LT(worst, 0.05);
  EXPECT_LT(tethered.measure().maxStrain * 1.5, loose.measure().maxStrain)
      << tethered.measure().maxStrain << " vs " << loose.measure().maxStrain;
  EXPECT_GT(tethered.measure().minHeight, -2.0);  // the cloth's diagonal is 2.83 m

  // Every tether shares one of two pins, yet they color like independent constraints: pins are
  // never written, so the coloring ignores them, and only a vertex's own two tethers conflict.
  const std::span<const std::array<Index, 2>> tuples = pool.particles;
  const auto w = tethered.inverseMasses();
  const ConstraintColoring coloring = colorConstraints(tuples, x.size(), w);
  EXPECT_EQ(coloring.colorCount(), 2u);
  EXPECT_TRUE(validateColoring(coloring, tuples, x.size(), w));
  EXPECT_FALSE(validateColoring(coloring, tuples, x.size()));  // counting pins, it would not be
}

namespace {
// Mean |angle − rest angle| over the corners of a soft-stretch curtain's triangles.
double meanCornerError(bool shear) {
  GridSpec spec;
  spec.resolution = {12, 12};
  spec.size = {1, 1};
  spec.vertical = true;
  ObjectDef cloth = gridCloth(spec);
  cloth.pins = {0, 11};
  cloth.material.stretchCompliance = cloth.material.compressionCompliance = Real(0.05);
  cloth.material.shear = shear;
  cloth.material.shearCompliance = 0;
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 20, 2));
  const ObjectId id = world.addCloth(cloth);
  test::simulate(world, 120);
  const auto x = world.positions(id);
  double error = 0;
  int corners = 0;
  for (const auto& t : cloth.triangles)
    for (int k = 0; k < 3; ++k) {
      auto angle = [&](auto p) {
        const Vec3 u = p[t[(k + 1) % 3]] - p[t[k]], v = p[t[(k + 2) % 3]] - p[t[k]];
        return std::atan2(u.cross(v).norm(), u.dot(v));
      };
      error += std::abs(angle(x) - angle(cloth.vertices));
      ++corners;
    }
  return error / corners;
}
}  // namespace

// Type 2 shear at triangle corners keeps a soft-stretch cloth's triangles in shape: the corner
// angles stay at least 3 times closer to their rest values than without shear.
TEST(Shear, KeepsTriangleCornersOfASoftCloth) {
  const double with = meanCornerError(true), without = meanCornerError(false);
  EXPECT_LT(3 * with, without) << with << " vs " << without;
}

namespace {
// Largest distance from the rest shape of a hard-bent helix (a spring of 3 turns, 60 segments)
// clamped at one end by three pins, after 1 s under gravity.
double helixDeviation(bool twist) {
  std::vector<Vec3> points;
  for (int i = 0; i <= 60; ++i) {
    const double t = 2 * std::numbers::pi * 3 * i / 60;
    points.emplace_back(Real(0.1 * std::cos(t)), Real(1 + 0.1 * std::sin(t)), Real(0.005 * i));
  }
  ObjectDef rope = polylineRope(points);
  rope.pins = {0, 1, 2};
  rope.material.bending = true;
  rope.material.twist = twist;
  rope.material.twistCompliance = Real(0.1);
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 20, 10));
  const ObjectId id = world.addRope(rope);
  test::simulate(world, 60);
  double worst = 0;
  const auto x = world.positions(id);
  for (std::size_t i = 0; i < x.size(); ++i)
    worst = std::max(worst, double((x[i] - points[i]).norm()));
  return worst;
}
}  // namespace

// Bend angles alone leave a helix free to turn about its own segments, so the clamped spring
// swings down; twist (type 3 dihedrals of consecutive segments, compliance 0.1) resists that
// freedom and halves the deviation (measured 0.69 m against 1.35 m). Hard twist (compliance 0)
// on this helix is not stable with Gauss–Seidel yet (it deviates 3.2 m), which this test does
// not hide: it uses the soft setting.
TEST(Twist, ResistsTheTurningThatBendAnglesAllow) {
  const double with = helixDeviation(true), without = helixDeviation(false);
  EXPECT_LT(with * 1.5, without) << with << " vs " << without;
}

namespace {

// A 1 m rope of n segments as in HangingRopeSettlesAtTheStaticExtensionOfItsSprings, with a
// strain limit, 160 sweeps × 4 substeps (40 segments: two levels under multigrid, so the cascade
// runs, as do the tethers and the fine sweeps). At 40 sweeps the springs-only rope below ends 7%
// longer than its static extension, XPBD's iteration error, which a slack limit cannot take out;
// at 160, 0.01%.
World limitedRope(SolverKind kind, int n, double mass, double alpha, double limit) {
  ObjectDef rope = polylineRope(Vec3(0, 1, 0), Vec3(0, 0, 0), n);
  rope.pins = {0};
  rope.material.mass = Real(mass);
  rope.material.stretchCompliance = Real(alpha);
  rope.material.stretchLimit = Real(limit);
  rope.material.damping = Real(0.05);
  World world;
  world.setSolver(test::solverSettings(kind, 160, 4));
  world.addRope(rope);
  return world;
}

std::vector<Vec3> settledLimitedRope(int n, double mass, double alpha, double limit) {
  World world = limitedRope(SolverKind::Multigrid, n, mass, alpha, limit);
  test::simulate(world, 600);
  EXPECT_LT(world.measure().kineticEnergy, 1e-8);
  const auto x = world.positions(world.objectAt(0));
  return {x.begin(), x.end()};
}

// Static equilibrium of the rope under a strain limit ε: segment i would carry the weight below
// it, W_i, at strain α W_i / ℓ; where that passes ε the tethers and coarse limits hold the
// segment at ε and take the rest of the load, so the rope's length is Σ_i ℓ (1 + min(ε, α W_i/ℓ)).
double limitedRopeLength(int n, double mass, double alpha, double limit) {
  const double segment = 1.0 / n;
  double length = 0, below = mass / (2 * n);
  for (int i = n; i >= 1; --i) {
    length += segment * (1 + std::min(limit, alpha * kG * below / segment));
    below += mass / n;
  }
  return length;
}

}  // namespace

// A limit above every segment's static strain (the top one's is α W / ℓ = 23%, W the weight
// below it) never grips: the rope settles at its springs' extension, as without the limit (within
// 1% of the extension, as the test without a limit).
TEST(StretchLimit, AboveTheStaticStrainTheRopeHangsAtItsSpringsExtension) {
  const int n = 40;
  const double alpha = 6e-4, limit = 0.3;
  const std::vector<Vec3> x = settledLimitedRope(n, 1, alpha, limit);
  const double expected = limitedRopeLength(n, 1, alpha, 1e9) - 1;
  EXPECT_NEAR((x[0] - x[n]).norm() - 1, expected, 0.01 * expected);
  std::printf("extension %.6f m, expected %.6f m\n", (x[0] - x[n]).norm() - 1, expected);
}

// A limit of 5%, below the upper segments' static strain: the tethers hold every vertex within
// 1.05 times its rest distance from the pin (to float rounding of the limits, 1e-5), and the
// rope settles at the length the limit leaves it (the upper segments held at 5%, the lower ones
// hanging free), neither the inextensible 1 m nor the springs' 1.118 m (within 1% of the
// extension, as above; measured 0.3%).
TEST(StretchLimit, BelowTheStaticStrainTheTethersHoldTheRopeAtTheLimit) {
  const int n = 40;
  const double alpha = 6e-4, limit = 0.05;
  const std::vector<Vec3> x = settledLimitedRope(n, 1, alpha, limit);
  for (int v = 1; v <= n; ++v) {
    const double rest = double(v) / n;
    EXPECT_LE((x[v] - x[0]).norm(), (1 + limit) * rest * (1 + 1e-5)) << "vertex " << v;
  }
  const double expected = limitedRopeLength(n, 1, alpha, limit) - 1;
  EXPECT_NEAR((x[0] - x[n]).norm() - 1, expected, 0.01 * expected) << "expected " << expected;
  // The cascade runs and its limits grip: a second of the same rope under colored Gauss–Seidel,
  // whose sweeps are multigrid's without the cascade, ends elsewhere.
  World cascaded = limitedRope(SolverKind::Multigrid, n, 1, alpha, limit);
  World colored = limitedRope(SolverKind::ColoredGaussSeidel, n, 1, alpha, limit);
  test::simulate(cascaded, 60);
  test::simulate(colored, 60);
  EXPECT_NE(cascaded.stateHash(), colored.stateHash());
  std::printf("extension %.6f m, expected %.6f m\n", (x[0] - x[n]).norm() - 1, expected);
}
