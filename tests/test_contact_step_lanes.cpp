// The contact steps in lanes (systems/collision/contact_step_lanes.h) give the bits of the
// scalar step Gauss–Seidel takes (primitiveContactStep: Δλ = −C / Σ w_k c_k² for
// C = n · Σ c_k p_k − distance < 0, and below the stickiness, 0 otherwise), and λ += Δλ Σ w_k c_k²,
// on random contacts of every kind of the narrow phase, pressed, separated, sticky and of zero
// inverse mass, over any sub-range. The step itself is checked against its analytic value too.
// And the parallel projection moves each particle by the mean of its pressed contacts'
// corrections, summed in contact order, to the same bits whether it gathers them per particle
// (many pressed) or scatters the few pressed ones, at 1 and 2 threads.
#include <cmath>
#include <random>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "systems/collision/contact_step_lanes.h"
#include "systems/collision/primitive_contacts.h"

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

// Random contacts over `count` particles; `pressedShare` of them are pushed a little into their
// distance, the rest held apart. Particle 0 is fixed (w = 0).
std::tuple<ParticlePool, PrimitiveContactPool> pressedContacts(std::size_t count,
                                                               std::size_t contacts,
                                                               double pressedShare, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1, 1), share(0, 1);
  ParticlePool particles;
  particles.append(count);
  for (std::size_t i = 0; i < count; ++i) {
    particles.p[i] = Vec3(Real(unit(rng)), Real(unit(rng)), Real(unit(rng))) * Real(0.05);
    particles.w[i] = i == 0 ? Real(0) : Real(0.5 + share(rng));
  }
  PrimitiveContactPool pool;
  pool.resize(contacts);
  std::uniform_int_distribution<Index> particle(0, Index(count - 1));
  for (std::size_t c = 0; c < contacts; ++c) {
    const Real a = Real(share(rng)), b = Real(share(rng)) * (1 - a);
    pool.coefficient[c] = c % 2 == 0 ? std::array<Real, 4>{1, -a, -b, -(1 - a - b)}
                                     : std::array<Real, 4>{1, -1, 0, 0};
    // Four different particles: the pool's contacts never name one twice.
    std::array<Index, 4> ids{};
    for (int k = 0; k < 4; ++k) {
      bool repeated = true;
      while (repeated) {
        ids[k] = particle(rng);
        repeated = false;
        for (int j = 0; j < k; ++j) repeated |= ids[j] == ids[k];
      }
    }
    pool.particles[c] = ids;
    pool.normal[c] = Vec3(Real(unit(rng)), Real(unit(rng)), Real(unit(rng))).normalized();
    Vec3 sum = Vec3::Zero();
    for (int k = 0; k < 4; ++k) sum += pool.coefficient[c][k] * particles.p[ids[k]];
    const Real gap = pool.normal[c].dot(sum);
    // Pressed by up to 1 mm, or held 1 mm or more apart.
    pool.distance[c] = share(rng) < pressedShare ? gap + Real(0.001 * (0.1 + share(rng)))
                                                 : gap - Real(0.001 * (1 + share(rng)));
    pool.stickiness[c] = 0;
    pool.inverseMass[c] = 0;
    for (int k = 0; k < 4; ++k)
      pool.inverseMass[c] += particles.w[ids[k]] * pool.coefficient[c][k] * pool.coefficient[c][k];
    pool.lambda[c] = 0;
  }
  buildContactIncidence(pool, count);
  return {std::move(particles), std::move(pool)};
}

TEST(ContactStepLanes, GatherAndScatterMoveEachParticleByItsPressedContactsMean) {
  // 6% pressed goes through the scatter (at most a quarter: kScatterShare in
  // primitive_contacts.cpp), 60% through the gather.
  for (const double pressedShare : {0.06, 0.6}) {
    auto [start, pool] = pressedContacts(400, 1500, pressedShare, 5);
    // The expected positions, contact by contact in pool order: what one round must give.
    std::vector<Vec3> sum(start.size(), Vec3::Zero());
    std::vector<int> active(start.size(), 0);
    std::size_t pressed = 0;
    for (std::size_t c = 0; c < pool.size(); ++c) {
      const Real step = primitiveContactStep(pool, start, c);
      if (step == 0) continue;
      ++pressed;
      for (int k = 0; k < 4; ++k) {
        if (pool.coefficient[c][k] == 0) continue;
        sum[pool.particles[c][k]] += pool.coefficient[c][k] * Vec3(step * pool.normal[c]);
        ++active[pool.particles[c][k]];
      }
    }
    if (pressedShare < 0.1) {
      EXPECT_LE(pressed * 4, pool.size());
    } else {
      EXPECT_GT(pressed * 4, pool.size());
    }
    for (const int threads : {1, 2}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(threads));
      ParticlePool particles = start;
      PrimitiveContactPool round = pool;
      projectPrimitiveContacts(round, particles, SolverKind::Jacobi);
      int moved = 0;
      for (std::size_t i = 0; i < particles.size(); ++i) {
        const Vec3 expected =
            active[i] == 0 ? start.p[i] : Vec3(start.p[i] + start.w[i] * sum[i] / Real(active[i]));
        ASSERT_EQ(particles.p[i], expected) << "particle " << i << ", " << threads << " threads";
        moved += particles.p[i] != start.p[i];
      }
      EXPECT_GT(moved, 20);
      // A second round finds the scatter's sums cleared: it moves as a fresh round would.
      ParticlePool again = start;
      projectPrimitiveContacts(round, again, SolverKind::Jacobi);
      ParticlePool fresh = start;
      PrimitiveContactPool freshPool = pool;
      freshPool.lambda = round.lambda;
      projectPrimitiveContacts(freshPool, fresh, SolverKind::Jacobi);
      for (std::size_t i = 0; i < again.size(); ++i) ASSERT_EQ(again.p[i], fresh.p[i]);
    }
  }
}

}  // namespace
}  // namespace nucleon
