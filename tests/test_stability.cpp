// Stability of every backend over a grid of substep counts, sweep counts and resolutions: a
// hanging cloth and a swinging rope, both inextensible, for one second each. Every value must stay
// finite, the total energy must never rise above its start, and the edges must stay near their
// rest length.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <tuple>

#include "nucleon/shapes.h"
#include "sim_test_context.h"

using namespace nucleon;

namespace {

enum class Shape { Cloth, Rope };

constexpr double kGravity = 9.81;
constexpr double kMass = 1;    // kg, the default material's
constexpr double kLength = 2;  // m: the cloth's side and the rope's length

// One second at 60 Hz. Under AddressSanitizer a step costs about fifteen times as much (the whole
// matrix took 225 s instead of 15 on two cores); there the matrix serves as a memory and
// undefined-behaviour check of the same code paths, for which a quarter of a second suffices, and
// the Release build checks the dynamics over the whole second.
#if defined(__SANITIZE_ADDRESS__)
constexpr int kFrames = 15;
#else
constexpr int kFrames = 60;
#endif

// Energy: the scenes have no damping, friction or contact, so the exact motion keeps its energy,
// and a stable solver can only lose some: with a finite number of sweeps the unconverged
// constraint residual acts as numerical damping (the iteration-count dependent behaviour of
// position based dynamics that Macklin, Müller and Chentanez 2016, "XPBD", set out from).
// Measured: in every stable cell the energy stays below its start in every frame, while a
// diverging run gains about 1 J to 10⁵ J within the second. The tolerance, 1% of the potential
// energy scale m·g·L (0.2 J), is far above the rounding of the energy of a float state (about a
// microjoule here) and below every divergence seen.
constexpr double kEnergyTolerance = 0.01 * kMass * kGravity * kLength;

// Strain |L/L0 − 1|: with hard constraints it is only the solver's residual, largest at the pins,
// from which the whole weight hangs (the README's benchmark table shows it growing with the
// resolution and falling with the sweeps). The largest in a stable cell is 1.53 (64², one substep
// of two sweeps); the fastest diverging runs reach 8 to 90. The bound 3, an edge four times its
// rest length, leaves room for the under-iterated cells and for rounding, and still rejects those.
constexpr double kStrainBound = 3;

// A 2 m square cloth of n×n vertices, horizontal at 1 m, pinned at the two corners of one side,
// or a 2 m rope of n segments pinned at one end and released horizontally, so that it swings down
// as a pendulum and whips its free end. Both inextensible, with the default tethers.
World makeWorld(Shape shape, SolverKind kind, int n, int substeps, int sweeps) {
  World world;
  world.setSolver(test::solverSettings(kind, sweeps, substeps));
  // One thread: every backend's result is independent of the thread count, and the test runs
  // beside others on a small machine.
  world.setThreads(1);
  if (shape == Shape::Cloth) {
    GridSpec spec;
    spec.resolution = {n, n};
    spec.size = {Real(kLength), Real(kLength)};
    ObjectDef cloth = gridCloth(spec);
    cloth.pins = {0, static_cast<Index>(n - 1)};
    world.addCloth(cloth);
  } else {
    ObjectDef rope = polylineRope(Vec3(0, 1, 0), Vec3(Real(kLength), 1, 0), n);
    rope.pins = {0};
    world.addRope(rope);
  }
  return world;
}

double totalEnergy(const Measures& m) {
  return m.kineticEnergy + m.potentialEnergy;
}

using Cell = std::tuple<Shape, SolverKind, int, int, int>;  // shape, backend, n, substeps, sweeps

std::string cellName(const ::testing::TestParamInfo<Cell>& info) {
  const auto [shape, kind, n, substeps, sweeps] = info.param;
  std::string backend = toString(kind);
  std::replace(backend.begin(), backend.end(), '-', '_');
  return std::string(shape == Shape::Cloth ? "cloth" : "rope") + "_" + backend + "_n" +
         std::to_string(n) + "_substeps" + std::to_string(substeps) + "_sweeps" +
         std::to_string(sweeps);
}

class Stability : public ::testing::TestWithParam<Cell> {};

TEST_P(Stability, StaysFiniteGainsNoEnergyAndKeepsItsEdges) {
  const auto [shape, kind, n, substeps, sweeps] = GetParam();
  World world = makeWorld(shape, kind, n, substeps, sweeps);
  const double start = totalEnergy(world.measure());
  for (int frame = 1; frame <= kFrames; ++frame) {
    world.step(1.0 / 60);
    const Measures m = world.measure();
    ASSERT_EQ(m.nanCount, 0u) << "frame " << frame;
    ASSERT_LE(totalEnergy(m) - start, kEnergyTolerance)
        << "frame " << frame << ": energy " << totalEnergy(m) << " J, at the start " << start
        << " J";
    ASSERT_LE(m.maxStrain, kStrainBound) << "frame " << frame;
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, Stability,
                         ::testing::Combine(::testing::Values(Shape::Cloth, Shape::Rope),
                                            ::testing::Values(SolverKind::GaussSeidel,
                                                              SolverKind::Jacobi,
                                                              SolverKind::ColoredGaussSeidel),
                                            ::testing::Values(16, 32, 64),
                                            ::testing::Values(1, 2, 4, 10),
                                            ::testing::Values(1, 2, 10)),
                         cellName);

// The sequential reference sweeps in the order colored-gs runs in parallel, so the two agree bit
// for bit where both use the scalar kernel: damping takes the stretch constraints off the batched
// distance path, and tethers, which are never damped, are left out.
TEST(ReferenceOrder, ColoredGaussSeidelMatchesTheSequentialReference) {
  auto run = [](SolverKind kind) {
    GridSpec spec;
    spec.resolution = {32, 32};
    ObjectDef cloth = gridCloth(spec);
    cloth.pins = {0, 31};
    cloth.material.damping = Real(0.01);
    cloth.material.tethers = false;
    World world;
    world.setSolver(test::solverSettings(kind, 3, 2));
    world.setThreads(2);
    world.addCloth(cloth);
    test::simulate(world, 60);
    return world.stateHash();
  };
  EXPECT_EQ(run(SolverKind::GaussSeidel), run(SolverKind::ColoredGaussSeidel));
}

}  // namespace
