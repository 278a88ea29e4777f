// Coulomb friction of the contact pool against analytic thresholds, for every backend and for
// 1, 4 and 20 sweeps per substep: friction bounds a particle's whole tangential motion over the
// substep by μ times the substep's normal correction, so neither the threshold nor the sliding
// law may depend on how many rounds project the contact.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"
#include "sim_test_context.h"

namespace nucleon {
namespace {

constexpr double kGravity = 9.81;
constexpr Real kStaticFriction = Real(0.5);
constexpr Real kKineticFriction = Real(0.4);

struct FrictionCase {
  SolverKind kind;
  int sweeps;
};

std::string caseName(const testing::TestParamInfo<FrictionCase>& info) {
  std::string name =
      std::string(toString(info.param.kind)) + "_" + std::to_string(info.param.sweeps) + "sweeps";
  for (char& c : name)
    if (c == '-') c = '_';
  return name;
}

class Friction : public testing::TestWithParam<FrictionCase> {};

// A 0.4 m cloth (8×8) lying on a plane tilted by θ = atan(slope) about z, in contact (gap 0).
// Returns how far its centroid moved down the slope in `seconds`.
double slideDownSlope(const FrictionCase& c, double slope, double seconds) {
  const double theta = std::atan(slope);
  const Real s = Real(std::sin(theta)), co = Real(std::cos(theta));
  PlaneCollider plane;
  plane.normal = Vec3(-s, co, 0);  // the surface y = x tan θ, rising along +x
  plane.thickness = Real(0.005);
  plane.friction = kKineticFriction;
  plane.staticFriction = kStaticFriction;
  GridSpec spec;
  spec.resolution = {8, 8};
  spec.size = {Real(0.4), Real(0.4)};
  spec.center = Vec3::Zero();
  ObjectDef cloth = gridCloth(spec);
  for (Vec3& v : cloth.vertices)
    v = Vec3(v.x() * co, v.x() * s, v.z()) + plane.normal * plane.thickness;
  World world;
  world.setSolver(test::solverSettings(c.kind, c.sweeps, 1));
  world.addPlaneCollider(plane);
  const ObjectId id = world.addCloth(cloth);
  auto centroid = [&] {
    Vec3d sum = Vec3d::Zero();
    for (const Vec3& x : world.positions(id)) sum += x.cast<double>();
    return Vec3d(sum / double(world.positions(id).size()));
  };
  const Vec3d start = centroid();
  test::simulate(world, static_cast<int>(std::lround(seconds * 60)));
  EXPECT_EQ(world.recoveries().total(), 0u);
  const Vec3d downhill(-std::cos(theta), -std::sin(theta), 0);
  return (centroid() - start).dot(downhill);
}

// On a slope θ a substep's gravity motion g h² splits into g h² cos θ into the plane (the normal
// correction) and g h² sin θ along it: Coulomb sticks when tan θ ≤ μ_s and otherwise slides with
// acceleration a = g (sin θ − μ_k cos θ), covering ½ a t² (symplectic Euler adds a factor
// 1 + 1/steps: 1.7% at 60 steps, inside the 5% allowed).
TEST_P(Friction, SticksBelowTheFrictionAngleAndSlidesAbove) {
  const double held = slideDownSlope(GetParam(), 0.8 * kStaticFriction, 1.0);
  EXPECT_LT(std::abs(held), 1e-3) << "slid on a slope below the friction angle";
  const double slope = 1.2 * kStaticFriction, theta = std::atan(slope);
  const double slid = slideDownSlope(GetParam(), slope, 1.0);
  const double expected =
      0.5 * kGravity * (std::sin(theta) - kKineticFriction * std::cos(theta)) * 1.0 * 1.0;
  EXPECT_NEAR(slid, expected, 0.05 * expected) << "kinetic friction does not follow Coulomb";
}

// Two particles on the ground joined by a soft segment stretched by δ: the segment pulls each
// with F = δ/α towards the other, and static friction holds them while F ≤ μ_s m g. The sliding
// is driven by the constraint, round after round, not by a re-penetration: friction must hold
// against all of it. XPBD's implicit step applies F α̃/(α̃ + Σw) per substep (0.9 F here), a
// 10% shift that the ±40% margins below leave out of the question.
double pullApartOnGround(const FrictionCase& c, double stretch) {
  const Real compliance = Real(0.01);  // m/N
  GroundPlane ground;
  ground.enabled = true;
  ground.thickness = 0;
  ground.friction = kKineticFriction;
  ground.staticFriction = kStaticFriction;
  ObjectDef segment;
  segment.vertices = {Vec3(-0.25f, 0, 0), Vec3(0.25f, 0, 0)};
  segment.edges = {{0, 1}};
  segment.material.mass = 1;  // 0.5 kg per particle
  segment.material.stretchCompliance = compliance;
  segment.material.compressionCompliance = compliance;
  World world;
  world.setSolver(test::solverSettings(c.kind, c.sweeps, 1));
  world.setGround(ground);
  world.addRope(segment);
  world.step(1.0 / 60);  // pools built
  WorldState& s = world.impl().state;
  const Real half = Real(stretch / 2);
  s.particles.x[0] = Vec3(-0.25f - half, 0, 0);
  s.particles.x[1] = Vec3(0.25f + half, 0, 0);
  s.particles.v[0] = s.particles.v[1] = Vec3::Zero();
  const Vec3 start0 = s.particles.x[0];
  test::simulate(world, 60);
  EXPECT_EQ(world.recoveries().total(), 0u);
  return (world.positions()[0] - start0).x();  // how far particle 0 moved towards particle 1
}

TEST_P(Friction, HoldsAgainstAConstraintBelowTheStaticLimit) {
  const double limit = kStaticFriction * 0.5 * kGravity * 0.01;  // δ at which F = μ_s m g
  EXPECT_LT(std::abs(pullApartOnGround(GetParam(), 0.6 * limit)), 1e-4)
      << "a pull below μ_s m g moved the particles";
  EXPECT_GT(pullApartOnGround(GetParam(), 1.6 * limit), 2e-3)
      << "a pull above μ_s m g did not move the particles";
}

INSTANTIATE_TEST_SUITE_P(Backends, Friction,
                         testing::Values(FrictionCase{SolverKind::GaussSeidel, 1},
                                         FrictionCase{SolverKind::GaussSeidel, 4},
                                         FrictionCase{SolverKind::GaussSeidel, 20},
                                         FrictionCase{SolverKind::Jacobi, 1},
                                         FrictionCase{SolverKind::Jacobi, 4},
                                         FrictionCase{SolverKind::Jacobi, 20},
                                         FrictionCase{SolverKind::ColoredGaussSeidel, 1},
                                         FrictionCase{SolverKind::ColoredGaussSeidel, 4},
                                         FrictionCase{SolverKind::ColoredGaussSeidel, 20}),
                         caseName);

}  // namespace
}  // namespace nucleon
