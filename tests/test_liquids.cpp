// Liquids (Material::liquid, position-based fluids) against physics: a settled tank keeps its
// rest density and carries its weight as a hydrostatic pressure profile, a sloshing liquid stays in
// its closed box with its mass and particle count, surface tension rounds a drop, adhesion holds
// one under a ceiling, a liquid and a cloth push each other, and the result does not depend on
// the thread count.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "engine/src/world_state.h"
#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"

using namespace nucleon;

namespace {

constexpr Real kSpacing = Real(0.02);  // particles 2 cm apart, kernel radius 4 cm
constexpr Real kWater = 1000;

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif

// A block of water of cells[0..2] particles `kSpacing` apart, its lowest layer `kSpacing`/2
// above `floor`, starting at rest density.
ObjectDef waterBlock(const std::array<int, 3>& cells, const Vec3& center,
                     Real viscosity = Real(0.01)) {
  ObjectDef def = particleBlock(
      center, kSpacing * Vec3(Real(cells[0]), Real(cells[1]), Real(cells[2])), kSpacing);
  def.name = "water";
  def.material.mass = kWater * Real(def.vertices.size()) * kSpacing * kSpacing * kSpacing;
  def.material.thickness = kSpacing / 2;
  def.material.liquid.enabled = true;
  def.material.liquid.restDensity = kWater;
  def.material.liquid.viscosity = viscosity;
  return def;
}

SolverSettings liquidSolver(int sweeps, int substeps) {
  SolverSettings s;
  s.kind = SolverKind::Jacobi;
  s.substeps = substeps;
  s.schedule = {{ConstraintFamily::Density, sweeps}};
  return s;
}

// A closed box [0, size] of frictionless walls, floor and lid.
void addBox(World& world, const Vec3& size) {
  GroundPlane ground;
  ground.enabled = true;
  ground.thickness = 0;
  ground.friction = ground.staticFriction = 0;
  world.setGround(ground);
  auto wall = [&](const Vec3& point, const Vec3& normal) {
    PlaneCollider plane;
    plane.point = point;
    plane.normal = normal;
    plane.thickness = 0;
    plane.friction = plane.staticFriction = 0;
    world.addPlaneCollider(plane);
  };
  wall(Vec3::Zero(), Vec3(1, 0, 0));
  wall(Vec3(size.x(), 0, 0), Vec3(-1, 0, 0));
  wall(Vec3::Zero(), Vec3(0, 0, 1));
  wall(Vec3(0, 0, size.z()), Vec3(0, 0, -1));
  wall(Vec3(0, size.y(), 0), Vec3(0, -1, 0));
}

}  // namespace

// A tank of water settled for 2 s: its particles away from the free surface (more than a kernel
// radius below it) keep the rest density, and the pressure the constraints apply grows with depth
// as ρ g. The constraints hold the density from above, so the measured mean is the compression
// the sweeps leave: at 4 substeps × 4 sweeps the weight of 12 layers of water compresses the
// lowest ones by about a percent. The pressure profile is a property of the equilibrium, not of
// convergence: at rest the projections must undo gravity's g h² every substep, so the pressure
// they apply balances the weight above whatever density they leave.
TEST(Liquids, SettledTankKeepsItsRestDensityUnderAHydrostaticProfile) {
  const int side = 12, height = 12;
  World world;
  world.setSolver(liquidSolver(4, 4));
  const Real width = kSpacing * side;
  addBox(world, Vec3(width, 1, width));
  const ObjectId water = world.addParticles(
      waterBlock({side, height, side}, Vec3(width / 2, kSpacing * height / 2, width / 2)));
  test::simulate(world, kSanitized ? 30 : 120);
  const LiquidReading reading = world.liquid(water);
  const auto x = world.positions(water);
  double top = 0;
  for (const Vec3& p : x) top = std::max(top, double(p.y()));
  // Interior: a kernel radius from the free surface and from the walls.
  const double H = 2 * kSpacing;
  double sum = 0, count = 0, sy = 0, sp = 0, syy = 0, syp = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Vec3 p = x[i];
    const bool interior =
        p.y() < top - H && p.x() > H && p.x() < width - H && p.z() > H && p.z() < width - H;
    if (!interior) continue;
    sum += reading.density[i];
    ++count;
    const double depth = top - p.y();
    sy += depth, sp += reading.pressure[i], syy += depth * depth,
        syp += depth * reading.pressure[i];
  }
  ASSERT_GT(count, 100);
  const double mean = sum / count;
  const double slope = (count * syp - sy * sp) / (count * syy - sy * sy);
  std::printf(
      "interior %g particles: mean density %.2f, pressure slope %.1f Pa/m (ρg %.1f), max "
      "compression %.4f p99 %.4f dropped %llu\n",
      count, mean, slope, 1000 * 9.81, reading.maxCompression, reading.compressionP99,
      (unsigned long long)reading.droppedNeighbours);
  EXPECT_NEAR(mean / kWater, 1.0, 0.02);
  EXPECT_NEAR(slope / (kWater * 9.81), 1.0, 0.1);
}

