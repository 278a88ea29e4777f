// The contact steps in lanes (systems/collision/contact_step_lanes.h) give the bits of the
// scalar step Gauss–Seidel takes (primitiveContactStep: Δλ = −C / Σ w_k c_k² for
// C = n · Σ c_k p_k − distance < 0, and below the stickiness, 0 otherwise), and λ += Δλ Σ w_k c_k²,
// on random contacts of every kind of the narrow phase, pressed, separated, sticky and of zero
// inverse mass, over any sub-range. The step itself is checked against its analytic value too.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "systems/collision/contact_step_lanes.h"

namespace nucleon {
namespace {

TEST(ContactStepLanes, SameBitsAsTheScalarStep) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1), share(0, 1);
  ParticlePool particles;
  const std::size_t count = 500;
  particles.append(count);
  for (std::size_t i = 0; i < count; ++i)
    particles.p[i] = Vec3(Real(unit(rng)), Real(unit(rng)), Real(unit(rng))) * Real(0.05);
  PrimitiveContactPool pool;
  const std::size_t contacts = 1037;  // not a multiple of any lane count
  pool.resize(contacts);
  std::uniform_int_distribution<Index> particle(0, Index(count - 1));
  int pressed = 0;
  for (std::size_t c = 0; c < contacts; ++c) {
    const int kind = int(c % 4);  // vertex–face, edge–edge, vertex–edge, vertex–vertex
    const Real a = Real(share(rng)), b = Real(share(rng)) * (1 - a);
    const std::array<std::array<Real, 4>, 4> weights = {
        {{1, -a, -b, -(1 - a - b)}, {1 - a, a, -(1 - b), -b}, {1, -(1 - a), -a, 0}, {1, -1, 0, 0}}};
    pool.coefficient[c] = weights[kind];
    for (int k = 0; k < 4; ++k) pool.particles[c][k] = particle(rng);
    pool.normal[c] = Vec3(Real(unit(rng)), Real(unit(rng)), Real(unit(rng))).normalized();
    pool.distance[c] = Real(0.01 * share(rng));
    pool.stickiness[c] = c % 3 == 0 ? Real(0.005 * share(rng)) : Real(0);
    pool.inverseMass[c] = c % 17 == 0 ? Real(0) : Real(1 + 3 * share(rng));
    pool.lambda[c] = Real(unit(rng));
  }
  std::vector<Real> lambdaBefore = pool.lambda;
  // Two sub-ranges with odd ends, as the parallel loop hands them out.
  primitiveContactSteps(pool, particles, 0, 517);
  primitiveContactSteps(pool, particles, 517, contacts);
  for (std::size_t c = 0; c < contacts; ++c) {
    const Real expected = primitiveContactStep(pool, particles, c);
    EXPECT_EQ(pool.step[c], expected) << "contact " << c;
    EXPECT_EQ(pool.lambda[c], lambdaBefore[c] + expected * pool.inverseMass[c]) << "contact " << c;
    pressed += expected != 0;
    // The analytic step, in double: a pressed contact's step restores C = 0 through its
    // generalised inverse mass (float rounding of C, with |p| ≤ 0.09 m, is below 1e-7 m); an
    // unpressed one holds, is within its stickiness, or cannot move.
    Vec3d sum = Vec3d::Zero();
    for (int k = 0; k < 4; ++k)
      sum += double(pool.coefficient[c][k]) * particles.p[pool.particles[c][k]].cast<double>();
    const double C = pool.normal[c].cast<double>().dot(sum) - double(pool.distance[c]);
    const double m = double(pool.inverseMass[c]), s = double(pool.stickiness[c]);
    if (expected != 0) {
      EXPECT_NEAR(double(expected) * m, -C, 1e-6) << "contact " << c;
    } else {
      EXPECT_TRUE(!(m > 0) || C >= s - 1e-6 || (s == 0 && C >= -1e-6)) << "contact " << c;
    }
  }
  // Both outcomes are exercised: about half of random contacts press.
  EXPECT_GT(pressed, 200);
  EXPECT_LT(pressed, int(contacts) - 200);
}

}  // namespace
}  // namespace nucleon
