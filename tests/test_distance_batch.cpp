// The batched (AVX2) distance projection against the scalar kernel it stands in for: same
// positions and multipliers, constraint by constraint, for stretch and tether constraints with
// hard and compliant, stretched and compressed, pinned and degenerate cases.
#include <random>

#include <gtest/gtest.h>

#include "components/constraint_pool.h"
#include "components/particles.h"
#include "systems/constraint_sweeps.h"
#include "systems/distance_batch.h"

namespace nucleon {
namespace {

// 37 constraints (four full batches and a remainder), none sharing a free particle: constraint k
// joins particles 2k and 2k+1. Every fifth has a pinned end, one has coincident ends.
struct Fixture {
  ParticlePool particles;
  ConstraintPool<2> pool;
  Fixture() {
    std::mt19937 random(7);
    std::uniform_real_distribution<float> unit(-1, 1);
    const int count = 37;
    particles.append(2 * count);
    for (int k = 0; k < count; ++k) {
      const Index a = 2 * k, b = 2 * k + 1;
      particles.p[a] = Vec3(unit(random), unit(random), unit(random));
      particles.p[b] = particles.p[a] + Vec3(unit(random), unit(random), unit(random)) * 0.3f;
      particles.w[a] = k % 5 == 0 ? 0 : 1 + unit(random) * 0.5f;
      particles.w[b] = 1 + unit(random) * 0.5f;
      if (k == 11) particles.p[b] = particles.p[a];  // degenerate: no direction
      const Real rest = 0.2f + 0.1f * unit(random);  // some stretched, some compressed
      const Real alpha = k % 3 == 0 ? 0 : 1e-4f, alphaBelow = k % 4 == 0 ? 0 : 1e-3f;
      pool.append({a, b}, rest, alpha, alphaBelow, 0);
      pool.lambda.back() = 0.01f * unit(random);
    }
    particles.x = particles.p;
  }
};

void expectBatchMatchesScalar(bool unilateral) {
  if (!distanceBatchesAvailable()) GTEST_SKIP() << "no AVX2/FMA on this CPU or a double build";
  Fixture batched, scalar;
  const Real h = Real(1.0 / 60), invH = 1 / h;
  const DistanceBatch batch{batched.pool.particles.data(),
                            batched.pool.rest.data(),
                            batched.pool.compliance.data(),
                            batched.pool.compressionCompliance.data(),
                            batched.pool.lambda.data(),
                            batched.particles.p.data(),
                            batched.particles.w.data(),
                            invH * invH,
                            unilateral};
  const Index size = static_cast<Index>(batched.pool.size());
  const Index left = projectDistanceBatches(batch, 0, size);
  EXPECT_EQ(left, 32u);  // four batches of eight; the caller projects the rest
  for (Index c = 0; c < size; ++c) {
    if (unilateral)
      sweep_detail::projectInPlace<TetherKernel>(scalar.pool, c, scalar.particles, invH);
    else
      sweep_detail::projectInPlace<DistanceKernel>(scalar.pool, c, scalar.particles, invH);
    if (c >= left) {
      if (unilateral)
        sweep_detail::projectInPlace<TetherKernel>(batched.pool, c, batched.particles, invH);
      else
        sweep_detail::projectInPlace<DistanceKernel>(batched.pool, c, batched.particles, invH);
    }
  }
  int moved = 0;
  for (Index c = 0; c < size; ++c) {
    // FMA contraction and a different operation order: agreement to float rounding of O(1)
    // values, a few ulps of 1.
    EXPECT_NEAR(batched.pool.lambda[c], scalar.pool.lambda[c], 1e-5) << c;
    moved += (scalar.particles.p[2 * c + 1] - scalar.particles.x[2 * c + 1]).norm() > 1e-4f;
    for (Index i : {2 * c, 2 * c + 1})
      EXPECT_LT((batched.particles.p[i] - scalar.particles.p[i]).norm(), 1e-5) << c << ' ' << i;
    for (Index i : {2 * c, 2 * c + 1}) {
      if (scalar.particles.w[i] == 0) {
        EXPECT_EQ(batched.particles.p[i], batched.particles.x[i]);
      }
    }
  }
  EXPECT_GT(moved, 10);  // the comparison is not between two unchanged states
}

TEST(DistanceBatch, StretchMatchesScalarKernel) {
  expectBatchMatchesScalar(false);
}

TEST(DistanceBatch, TetherMatchesScalarKernel) {
  expectBatchMatchesScalar(true);
}

}  // namespace
}  // namespace nucleon
