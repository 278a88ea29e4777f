// The batched (AVX2) dihedral projection against the scalar kernel it stands in for: same
// positions, multipliers and Jacobi slots, hinge by hinge, over folds of every angle (flat, folded
// past ±π/2, nearly closed), hard and compliant hinges, pinned corners and degenerate wings; and
// a whole cloth whose bending takes the batches, against the generic sweep.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "components/constraint_pool.h"
#include "components/particles.h"
#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"
#include "systems/solver/constraint_sweeps.h"
#include "systems/solver/hinge_batch.h"

namespace nucleon {
namespace {

// 45 hinges (five full batches and a remainder), none sharing a particle: hinge k joins particles
// 4k … 4k+3, the edge (x0, x1) and wings x2, x3 folded about it by a random angle. Every fifth
// has a pinned corner, every seventh is hard, one has a wing on the edge's line (no area).
struct Fixture {
  ParticlePool particles;
  DihedralConstraints pool;
  Fixture() {
    std::mt19937 random(11);
    std::uniform_real_distribution<float> unit(-1, 1);
    const int count = 45;
    particles.append(4 * count);
    for (int k = 0; k < count; ++k) {
      const Index a = 4 * k;
      const Vec3 origin(unit(random), unit(random), unit(random));
      const Vec3 edge = Vec3(unit(random), unit(random), unit(random)).normalized() * 0.1f;
      const Vec3 side = edge.unitOrthogonal();
      const Vec3 up = edge.normalized().cross(side);
      // Wing x2 in the plane (edge, side); wing x3 turned by the fold angle about the edge.
      const float fold = std::numbers::pi_v<float> * unit(random);
      const float along2 = 0.5f + 0.4f * unit(random), along3 = 0.5f + 0.4f * unit(random);
      particles.p[a] = origin;
      particles.p[a + 1] = origin + edge;
      particles.p[a + 2] = origin + along2 * edge + 0.08f * side;
      particles.p[a + 3] =
          origin + along3 * edge - 0.07f * (std::cos(fold) * side + std::sin(fold) * up);
      if (k == 17) particles.p[a + 3] = origin + 0.5f * edge;  // degenerate wing
      for (Index i = a; i < a + 4; ++i) particles.w[i] = 1 + 0.5f * unit(random);
      if (k % 5 == 0) particles.w[a + (k / 5) % 4] = 0;
      const Real rest = std::numbers::pi_v<float> * unit(random);
      const Real alpha = k % 7 == 0 ? 0 : 1e-3f * (1 + unit(random));
      pool.append({a, a + 1, a + 2, a + 3}, rest, alpha, alpha, 0);
      pool.lambda.back() = 0.01f * unit(random);
      pool.endInverseMass.push_back(
          {particles.w[a], particles.w[a + 1], particles.w[a + 2], particles.w[a + 3]});
    }
    particles.x = particles.p;
    pool.correction.assign(4 * pool.size(), Vec3::Zero());
    pool.splitInverseMass = particles.w;  // each particle in one hinge: no splitting
  }
};

#ifndef NUCLEON_DOUBLE
constexpr Real kH = Real(1.0 / 240);

TEST(HingeBatch, MatchesScalarKernelInPlace) {
  if (!hingeBatchesAvailable()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  Fixture batched, scalar;
  const Real invH = 1 / kH;
  HingeBatch batch;
  batch.particles = batched.pool.particles.data();
  batch.rest = batched.pool.rest.data();
  batch.compliance = batched.pool.compliance.data();
  batch.compressionCompliance = batched.pool.compressionCompliance.data();
  batch.lambda = batched.pool.lambda.data();
  batch.positions = batched.particles.p.data();
  batch.endInverseMass = batched.pool.endInverseMass.data();
  batch.inverseH2 = invH * invH;
  const Index size = static_cast<Index>(batched.pool.size());
  const Index left = projectHingeBatches(batch, 0, size);
  EXPECT_EQ(left, 40u);  // five batches of eight; the caller projects the rest
  for (Index c = 0; c < size; ++c) {
    sweep_detail::projectInPlace<DihedralKernel>(scalar.pool, c, scalar.particles, invH);
    if (c >= left)
      sweep_detail::projectInPlace<DihedralKernel>(batched.pool, c, batched.particles, invH);
  }
  int moved = 0;
  for (Index c = 0; c < size; ++c) {
    // The polynomial arctangent (relative error ~2e-7) and FMA contraction against libm's atan2
    // in float: agreement to a few ulps of the O(1) multipliers and the 0.1 m hinge's coordinates.
    EXPECT_NEAR(batched.pool.lambda[c], scalar.pool.lambda[c],
                2e-5f * std::max(1.0f, std::abs(scalar.pool.lambda[c])))
        << c;
    for (Index i = 4 * c; i < 4 * c + 4; ++i) {
      EXPECT_LT((batched.particles.p[i] - scalar.particles.p[i]).norm(), 2e-6f) << c << ' ' << i;
      moved += (scalar.particles.p[i] - scalar.particles.x[i]).norm() > 1e-4f;
      if (scalar.particles.w[i] == 0) {
        EXPECT_EQ(batched.particles.p[i], batched.particles.x[i]);
      }
    }
  }
  // The degenerate hinge is left alone by both.
  for (Index i = 68; i < 72; ++i) EXPECT_EQ(batched.particles.p[i], batched.particles.x[i]);
  EXPECT_GT(moved, 60);  // the comparison is not between two unchanged states
}

// The Jacobi form, plain and accelerated: the same slots and multipliers as jacobiOne.
void expectJacobiMatchesScalar(Real carry) {
  if (!hingeBatchesAvailable()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  Fixture batched, scalar;
  const Real invH = 1 / kH;
  // History in the slots, some along the coming step and some against it.
  std::mt19937 random(3);
  std::uniform_real_distribution<float> unit(-1, 1);
  for (std::size_t s = 0; s < batched.pool.correction.size(); ++s)
    batched.pool.correction[s] = scalar.pool.correction[s] =
        1e-3f * Vec3(unit(random), unit(random), unit(random));
  sweep_detail::JacobiFactors factors;
  factors.relaxation = 0.9f;
  factors.step = (1 + carry) * 0.9f;
  factors.carry = carry;
  HingeJacobiBatch batch;
  batch.particles = batched.pool.particles.data();
  batch.rest = batched.pool.rest.data();
  batch.compliance = batched.pool.compliance.data();
  batch.compressionCompliance = batched.pool.compressionCompliance.data();
  batch.lambda = batched.pool.lambda.data();
  batch.positions = batched.particles.p.data();
  batch.splitInverseMass = batched.pool.splitInverseMass.data();
  batch.correction = batched.pool.correction.data();
  batch.inverseH2 = invH * invH;
  batch.relaxation = factors.relaxation;
  batch.step = factors.step;
  batch.carry = factors.carry;
  const Index size = static_cast<Index>(batched.pool.size());
  const Index left = projectHingeJacobiBatches(batch, 0, size);
  EXPECT_EQ(left, 40u);
  SweepContext context{scalar.particles, kH};
  SweepContext batchedContext{batched.particles, kH};
  for (Index c = 0; c < size; ++c) {
    sweep_detail::jacobiOne<DihedralKernel>(scalar.pool, c, context, factors, invH);
    if (c >= left)
      sweep_detail::jacobiOne<DihedralKernel>(batched.pool, c, batchedContext, factors, invH);
  }
  int written = 0;
  for (Index c = 0; c < size; ++c) {
    EXPECT_NEAR(batched.pool.lambda[c], scalar.pool.lambda[c],
                2e-5f * std::max(1.0f, std::abs(scalar.pool.lambda[c])))
        << c;
    for (Index s = 4 * c; s < 4 * c + 4; ++s) {
      EXPECT_LT((batched.pool.correction[s] - scalar.pool.correction[s]).norm(), 2e-6f)
          << c << ' ' << s;
      written += scalar.pool.correction[s].norm() > 1e-4f;
    }
  }
  EXPECT_GT(written, 60);
  EXPECT_EQ(batched.particles.p, batched.particles.x);  // Jacobi only writes slots
}

TEST(HingeBatch, JacobiMatchesScalarKernel) {
  expectJacobiMatchesScalar(0);
}

TEST(HingeBatch, AcceleratedJacobiMatchesScalarKernel) {
  expectJacobiMatchesScalar(0.6f);
}
#endif

// The hinges of a real cloth (coloring, mass splitting, shared particles), folded by a second of
// draping from a pinned edge: five sweeps of the bend pool with the batches and five with the
// generic sweep, from the same state, end at the same positions and multipliers.
TEST(HingeBatch, ClothHingesMatchTheGenericSweep) {
  if (!hingeBatchesAvailable()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  for (SolverKind kind : {SolverKind::ColoredGaussSeidel, SolverKind::Jacobi}) {
    GridSpec spec;
    spec.resolution = {24, 24};
    spec.size = {0.5f, 0.5f};
    ObjectDef cloth = gridCloth(spec);
    cloth.pins = {0, 23};
    cloth.material.bending = true;
    cloth.material.bendCompliance = 0.1f;
    World world;
    SolverSettings settings;
    settings.kind = kind;
    world.setSolver(settings);
    world.setThreads(1);
    world.addCloth(cloth);
    for (int i = 0; i < 60; ++i) world.step(1.0 / 60);
    WorldState& state = world.impl().state;
    DihedralConstraints batchedPool = state.constraints.bend, scalarPool = batchedPool;
    ParticlePool batchedParticles = state.particles, scalarParticles = state.particles;
    // The cloth is folded: the hinges have work to do.
    Real largestAngle = 0;
    for (std::size_t c = 0; c < scalarPool.size(); ++c) {
      Points<4> x, grad;
      for (int k = 0; k < 4; ++k) x[k] = scalarParticles.p[scalarPool.particles[c][k]];
      largestAngle = std::max(largestAngle, std::abs(DihedralKernel::value(x, grad)));
    }
    EXPECT_GT(largestAngle, 0.02f) << toString(kind);
    SweepContext batchedContext{batchedParticles, Real(1.0 / 60)};
    SweepContext scalarContext{scalarParticles, Real(1.0 / 60)};
    for (int sweep = 0; sweep < 5; ++sweep) {
      solveSweep<DihedralKernel, kHingeBatch>(kind, batchedPool, batchedContext);
      solveSweep<DihedralKernel, kGenericSweep>(kind, scalarPool, scalarContext);
    }
    Real most = 0, moved = 0;
    for (std::size_t i = 0; i < scalarParticles.size(); ++i) {
      most = std::max(most, (batchedParticles.p[i] - scalarParticles.p[i]).norm());
      moved = std::max(moved, (scalarParticles.p[i] - state.particles.p[i]).norm());
    }
    // Float rounding of 0.5 m coordinates, a few ulps, carried through five sweeps.
    EXPECT_LT(most, 1e-5f) << toString(kind);
    EXPECT_GT(moved, 1e-4f) << toString(kind);
    for (std::size_t c = 0; c < scalarPool.size(); ++c)
      EXPECT_NEAR(batchedPool.lambda[c], scalarPool.lambda[c],
                  1e-4f * std::max(Real(1), std::abs(scalarPool.lambda[c])))
          << toString(kind) << ' ' << c;
  }
}

}  // namespace
}  // namespace nucleon
