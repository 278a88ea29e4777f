// The batched (AVX2) angular projections against the scalar kernels they stand in for: same
// positions, multipliers and Jacobi slots, constraint by constraint, for dihedral hinges over
// folds of every angle (flat, folded past ±π/2, nearly closed) and for angles from nearly closed
// to straight, hard and compliant, with pinned corners and degenerate cases; and the hinges and
// angles of a real cloth and rope, whose sweeps take the batches, against the generic sweep.
#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include "components/constraint_pool.h"
#include "components/particles.h"
#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"
#include "systems/solver/angular_batch.h"
#include "systems/solver/constraint_sweeps.h"

namespace nucleon {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// 45 constraints (five full batches and a remainder), none sharing a particle: constraint k joins
// particles N k … N k + N − 1. Every fifth has a pinned corner, every seventh is hard, one is
// degenerate (a hinge's wing on its edge's line, an angle whose two arms coincide with its apex)
// and, for angles, one is straight (no plane: no gradient).
// With `kWeighted` (the isometric hinges), each hinge gets the weights of its unfolded shape and
// rest 0, and the degenerate one is flat (all four corners at the origin: v = 0 exactly).
template <std::size_t N, bool kWeighted = false>
struct Fixture {
  ParticlePool particles;
  ConstraintPool<N> pool;
  static constexpr int kCount = 45;
  static constexpr int kDegenerate = 17, kStraight = 23;
  Fixture() {
    std::mt19937 random(11);
    std::uniform_real_distribution<float> unit(-1, 1);
    particles.append(N * kCount);
    for (int k = 0; k < kCount; ++k) {
      const Index a = N * k;
      const Vec3 origin(unit(random), unit(random), unit(random));
      const Vec3 edge = Vec3(unit(random), unit(random), unit(random)).normalized() * 0.1f;
      const Vec3 side = edge.unitOrthogonal();
      const Vec3 up = edge.normalized().cross(side);
      Real rest = 0;
      if constexpr (N == 4) {
        // Edge (x0, x1); wing x2 in the plane (edge, side), wing x3 turned about the edge.
        const float fold = kPi * unit(random);
        const float along2 = 0.5f + 0.4f * unit(random), along3 = 0.5f + 0.4f * unit(random);
        particles.p[a] = origin;
        particles.p[a + 1] = origin + edge;
        particles.p[a + 2] = origin + along2 * edge + 0.08f * side;
        particles.p[a + 3] =
            origin + along3 * edge - 0.07f * (std::cos(fold) * side + std::sin(fold) * up);
        if (k == kDegenerate) particles.p[a + 3] = origin + 0.5f * edge;
        rest = kPi * unit(random);
        if constexpr (kWeighted) {
          const Points<4> unfolded = {origin, origin + edge, particles.p[a + 2],
                                      origin + along3 * edge - 0.07f * side};
          std::array<Real, 4> weights{};
          EXPECT_TRUE(IsometricBendKernel::weightsOf(unfolded, weights));
          pool.weights.push_back(weights);
          rest = 0;
          if (k == kDegenerate)
            for (Index i = a; i < a + 4; ++i) particles.p[i] = Vec3::Zero();
        }
      } else {
        // Apex x2; arms to x0 and x1 an angle in (0, π) apart.
        const float opening = kPi * (0.5f + 0.5f * unit(random));
        particles.p[a + 2] = origin;
        particles.p[a] = origin + edge;
        particles.p[a + 1] =
            origin + 0.07f * (std::cos(opening) * edge.normalized() + std::sin(opening) * side);
        if (k == kDegenerate) particles.p[a] = particles.p[a + 1] = origin;
        if (k == kStraight) particles.p[a + 1] = origin - edge;
        rest = kPi * (0.5f + 0.5f * unit(random));
      }
      for (Index i = a; i < a + N; ++i) particles.w[i] = 1 + 0.5f * unit(random);
      if (k % 5 == 0) particles.w[a + (k / 5) % N] = 0;
      const Real alpha = k % 7 == 0 ? 0 : 1e-3f * (1 + unit(random));
      std::array<Index, N> ids;
      for (std::size_t c = 0; c < N; ++c) ids[c] = a + static_cast<Index>(c);
      pool.append(ids, rest, alpha, alpha, 0);
      pool.lambda.back() = 0.01f * unit(random);
      std::array<Real, N> masses;
      for (std::size_t c = 0; c < N; ++c) masses[c] = particles.w[ids[c]];
      pool.endInverseMass.push_back(masses);
    }
    particles.x = particles.p;
    pool.correction.assign(N * pool.size(), Vec3::Zero());
    pool.splitInverseMass = particles.w;  // each particle in one constraint: no splitting
  }
};

#ifndef NUCLEON_DOUBLE
constexpr Real kH = Real(1.0 / 240);

template <class Kernel>
void expectInPlaceMatchesScalar() {
  constexpr std::size_t n = Kernel::kArity;
  if (!angularBatchesAvailable()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  Fixture<n, std::is_same_v<Kernel, IsometricBendKernel>> batched, scalar;
  const Real invH = 1 / kH;
  const SweepContext batchedContext{batched.particles, kH};
  const AngularBatch<n> batch =
      sweep_detail::inPlaceBatchOf<Kernel>(batched.pool, batchedContext, invH);
  const Index size = static_cast<Index>(batched.pool.size());
  const Index left = sweep_detail::projectBatches<Kernel>(batch, 0, size);
  EXPECT_EQ(left, 40u);  // five batches of eight; the caller projects the rest
  for (Index c = 0; c < size; ++c) {
    sweep_detail::projectInPlace<Kernel>(scalar.pool, c, scalar.particles, invH);
    if (c >= left) sweep_detail::projectInPlace<Kernel>(batched.pool, c, batched.particles, invH);
  }
  int moved = 0;
  for (Index c = 0; c < size; ++c) {
    // The polynomial arctangent (relative error ~2e-7) and FMA contraction against libm's atan2
    // in float: agreement to a few ulps of the O(1) multipliers and the 0.1 m constraints'
    // coordinates.
    EXPECT_NEAR(batched.pool.lambda[c], scalar.pool.lambda[c],
                2e-5f * std::max(1.0f, std::abs(scalar.pool.lambda[c])))
        << c;
    for (Index i = n * c; i < n * c + n; ++i) {
      EXPECT_LT((batched.particles.p[i] - scalar.particles.p[i]).norm(), 2e-6f) << c << ' ' << i;
      moved += (scalar.particles.p[i] - scalar.particles.x[i]).norm() > 1e-4f;
      if (scalar.particles.w[i] == 0) {
        EXPECT_EQ(batched.particles.p[i], batched.particles.x[i]);
      }
    }
  }
  // The degenerate (and, for angles, the straight) constraint is left alone by both.
  for (int k : {Fixture<n>::kDegenerate, Fixture<n>::kStraight}) {
    if (n == 4 && k == Fixture<n>::kStraight) continue;
    for (Index i = n * k; i < n * k + n; ++i)
      EXPECT_EQ(batched.particles.p[i], batched.particles.x[i]) << k;
  }
  EXPECT_GT(moved, int(n) * 15);  // the comparison is not between two unchanged states
}

// The Jacobi form, plain and accelerated: the same slots and multipliers as jacobiOne.
template <class Kernel>
void expectJacobiMatchesScalar(Real carry) {
  constexpr std::size_t n = Kernel::kArity;
  if (!angularBatchesAvailable()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  Fixture<n, std::is_same_v<Kernel, IsometricBendKernel>> batched, scalar;
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
  SweepContext context{scalar.particles, kH};
  SweepContext batchedContext{batched.particles, kH};
  const AngularJacobiBatch<n> batch =
      sweep_detail::jacobiBatchOf<Kernel>(batched.pool, batchedContext, factors, invH);
  const Index size = static_cast<Index>(batched.pool.size());
  const Index left = sweep_detail::projectJacobiBatches<Kernel>(batch, 0, size);
  EXPECT_EQ(left, 40u);
  for (Index c = 0; c < size; ++c) {
    sweep_detail::jacobiOne<Kernel>(scalar.pool, c, context, factors, invH);
    if (c >= left) sweep_detail::jacobiOne<Kernel>(batched.pool, c, batchedContext, factors, invH);
  }
  int written = 0;
  for (Index c = 0; c < size; ++c) {
    EXPECT_NEAR(batched.pool.lambda[c], scalar.pool.lambda[c],
                2e-5f * std::max(1.0f, std::abs(scalar.pool.lambda[c])))
        << c;
    for (Index s = n * c; s < n * c + n; ++s) {
      EXPECT_LT((batched.pool.correction[s] - scalar.pool.correction[s]).norm(), 2e-6f)
          << c << ' ' << s;
      written += scalar.pool.correction[s].norm() > 1e-4f;
    }
  }
  EXPECT_GT(written, int(n) * 15);
  EXPECT_EQ(batched.particles.p, batched.particles.x);  // Jacobi only writes slots
}

TEST(AngularBatch, HingesMatchScalarKernelInPlace) {
  expectInPlaceMatchesScalar<DihedralKernel>();
}
TEST(AngularBatch, IsometricHingesMatchScalarKernelInPlace) {
  expectInPlaceMatchesScalar<IsometricBendKernel>();
}
TEST(AngularBatch, IsometricHingesMatchScalarKernelInJacobi) {
  expectJacobiMatchesScalar<IsometricBendKernel>(0);
}
TEST(AngularBatch, IsometricHingesMatchScalarKernelInAcceleratedJacobi) {
  expectJacobiMatchesScalar<IsometricBendKernel>(0.6f);
}
TEST(AngularBatch, AnglesMatchScalarKernelInPlace) {
  expectInPlaceMatchesScalar<AngleKernel>();
}
TEST(AngularBatch, HingesMatchScalarKernelInJacobi) {
  expectJacobiMatchesScalar<DihedralKernel>(0);
}
TEST(AngularBatch, AnglesMatchScalarKernelInJacobi) {
  expectJacobiMatchesScalar<AngleKernel>(0);
}
TEST(AngularBatch, HingesMatchScalarKernelInAcceleratedJacobi) {
  expectJacobiMatchesScalar<DihedralKernel>(0.6f);
}
TEST(AngularBatch, AnglesMatchScalarKernelInAcceleratedJacobi) {
  expectJacobiMatchesScalar<AngleKernel>(0.6f);
}
#endif

// Five sweeps of a real pool (coloring, mass splitting, shared particles) with the batches and
// five with the generic sweep, from the same bent state, end at the same positions and
// multipliers.
template <class Kernel, std::size_t N>
void expectPoolMatchesGenericSweep(World& world, ConstraintPool<N> ConstraintPools::*member,
                                   SolverKind kind) {
  WorldState& state = world.impl().state;
  ConstraintPool<N> batchedPool = state.constraints.*member, scalarPool = batchedPool;
  ASSERT_GT(scalarPool.size(), 100u);
  ParticlePool batchedParticles = state.particles, scalarParticles = state.particles;
  // The object is bent: the constraints have work to do.
  Real largestError = 0;
  for (std::size_t c = 0; c < scalarPool.size(); ++c) {
    Points<N> x, grad;
    for (std::size_t k = 0; k < N; ++k) x[k] = scalarParticles.p[scalarPool.particles[c][k]];
    Real value;
    if constexpr (std::is_same_v<Kernel, IsometricBendKernel>)
      value = Kernel::value(x, scalarPool.weights[c], grad);
    else
      value = Kernel::value(x, grad);
    largestError = std::max(largestError, std::abs(value - scalarPool.rest[c]));
  }
  EXPECT_GT(largestError, 0.02f) << toString(kind);
  SweepContext batchedContext{batchedParticles, Real(1.0 / 60)};
  SweepContext scalarContext{scalarParticles, Real(1.0 / 60)};
  for (int sweep = 0; sweep < 5; ++sweep) {
    solveSweep<Kernel, kAngularBatch>(kind, batchedPool, batchedContext);
    solveSweep<Kernel, kGenericSweep>(kind, scalarPool, scalarContext);
  }
  Real most = 0, moved = 0;
  for (std::size_t i = 0; i < scalarParticles.size(); ++i) {
    most = std::max(most, (batchedParticles.p[i] - scalarParticles.p[i]).norm());
    moved = std::max(moved, (scalarParticles.p[i] - state.particles.p[i]).norm());
  }
  // Float rounding of O(1) m coordinates, a few ulps, carried through five sweeps; a tangled
  // rope's sweeps move particles by metres, and its rounding grows with the corrections.
  EXPECT_LT(most, 1e-5f * std::max(Real(1), moved)) << toString(kind) << ", largest move " << moved;
  EXPECT_GT(moved, 1e-4f) << toString(kind);
  for (std::size_t c = 0; c < scalarPool.size(); ++c)
    EXPECT_NEAR(batchedPool.lambda[c], scalarPool.lambda[c],
                1e-4f * std::max(Real(1), std::abs(scalarPool.lambda[c])))
        << toString(kind) << ' ' << c;
}

// A cloth with bend and shear draped for a second from a pinned edge; a helix rope with bend and
// twist falling from one pinned end.
TEST(AngularBatch, ClothAndRopePoolsMatchTheGenericSweep) {
  if (!angularBatchesAvailable()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  for (SolverKind kind : {SolverKind::ColoredGaussSeidel, SolverKind::Jacobi}) {
    GridSpec spec;
    spec.resolution = {24, 24};
    spec.size = {0.5f, 0.5f};
    ObjectDef cloth = gridCloth(spec);
    cloth.pins = {0, 23};
    cloth.material.bending = cloth.material.shear = true;
    cloth.material.bendCompliance = 0.1f;
    cloth.material.shearCompliance = 1e-4f;
    cloth.material.stretchCompliance = 1e-5f;  // soft enough that the shear angles move
    std::vector<Vec3> helix;
    for (int i = 0; i < 200; ++i) {
      const double t = 0.3 * i;
      helix.emplace_back(Real(std::cos(t) * 0.2), Real(1 + 0.005 * i), Real(std::sin(t) * 0.2));
    }
    ObjectDef rope = polylineRope(helix);
    rope.pins = {0};
    rope.material.bending = rope.material.twist = true;
    rope.material.bendCompliance = rope.material.twistCompliance = 0.01f;
    World world;
    SolverSettings settings;
    settings.kind = kind;
    // The second's history, not the sweeps compared, depends on this: with the cloth's contacts
    // against its pinned corners weighed, the state reached is one from which five sweeps move
    // particles by up to 10 m, and the rounding grows beyond the bound.
    settings.supportedInverseMassScale = 1;
    world.setSolver(settings);
    world.setThreads(1);
    world.addCloth(cloth);
    world.addRope(rope);
    for (int i = 0; i < 60; ++i) world.step(1.0 / 60);
    expectPoolMatchesGenericSweep<DihedralKernel>(world, &ConstraintPools::bend, kind);
    expectPoolMatchesGenericSweep<AngleKernel>(world, &ConstraintPools::shear, kind);
    expectPoolMatchesGenericSweep<AngleKernel>(world, &ConstraintPools::curveBend, kind);
    expectPoolMatchesGenericSweep<DihedralKernel>(world, &ConstraintPools::twist, kind);
    // The same cloth alone with its flat hinges in the isometric form (beside the rope, the
    // sheet's fall tangles it, and five sweeps of a tangle amplify rounding beyond the bound).
    ObjectDef isometric = cloth;
    isometric.material.bendModel = BendModel::Isometric;
    World flat;
    flat.setSolver(settings);
    flat.setThreads(1);
    flat.addCloth(isometric);
    for (int i = 0; i < 60; ++i) flat.step(1.0 / 60);
    expectPoolMatchesGenericSweep<IsometricBendKernel>(flat, &ConstraintPools::isometricBend, kind);
  }
}

// Jacobi by colors (solveJacobi, for soft angular pools stored in color order) against the slot
// path it replaces: five sweeps from the same bent state end in the same bits, positions and
// multipliers, at one and two threads. The pool must hold enough constraints to take the color
// path; a hard pool, whose accelerated sweeps keep their history in the slots, never takes it.
template <class Kernel, std::size_t N>
void expectColorsGiveTheSlotBits(World& world, ConstraintPool<N> ConstraintPools::*member) {
  WorldState& state = world.impl().state;
  const ConstraintPool<N>& pool = state.constraints.*member;
  ASSERT_GE(pool.size(), sweep_detail::kColorJacobiMinimum);
  ASSERT_FALSE(pool.correctionSum.empty());
  ASSERT_TRUE(pool.coloring.inPlace);
  for (int threads : {1, 2}) {
    ConstraintPool<N> colorPool = pool, slotPool = pool;
    ParticlePool colorParticles = state.particles, slotParticles = state.particles;
    SweepContext colorContext{colorParticles, Real(1.0 / 60)};
    SweepContext slotContext{slotParticles, Real(1.0 / 60)};
    tbb::task_arena arena(threads);
    arena.execute([&] {
      for (int sweep = 0; sweep < 5; ++sweep) {
        solveJacobi<Kernel, kAngularBatch>(colorPool, colorContext, JacobiPath::Automatic);
        solveJacobi<Kernel, kAngularBatch>(slotPool, slotContext, JacobiPath::Slots);
      }
    });
    Real moved = 0;
    std::size_t differing = 0;
    for (std::size_t i = 0; i < slotParticles.size(); ++i) {
      moved = std::max(moved, (slotParticles.p[i] - state.particles.p[i]).norm());
      differing +=
          std::memcmp(colorParticles.p[i].data(), slotParticles.p[i].data(), sizeof(Vec3)) != 0;
    }
    EXPECT_GT(moved, 1e-5f) << "the sweeps had work to do";
    EXPECT_EQ(differing, 0u) << threads << " threads";
    EXPECT_EQ(std::memcmp(colorPool.lambda.data(), slotPool.lambda.data(),
                          sizeof(Real) * slotPool.lambda.size()),
              0)
        << threads << " threads";
    for (const Vec3& sum : colorPool.correctionSum) ASSERT_EQ(sum, Vec3::Zero());
  }
}

TEST(AngularBatch, JacobiByColorsGivesTheSlotPathsBits) {
  if (!angularBatchesAvailable()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  for (BendModel model : {BendModel::Dihedral, BendModel::Isometric}) {
    GridSpec spec;
    spec.resolution = {48, 48};
    spec.size = {0.8f, 0.8f};
    ObjectDef cloth = gridCloth(spec);
    cloth.pins = {0, 47};  // pins in the hinges: read, never written
    cloth.material.bending = cloth.material.shear = true;
    cloth.material.bendModel = model;
    cloth.material.bendCompliance = 0.1f;
    cloth.material.shearCompliance = 1e-4f;
    World world;
    SolverSettings settings;
    settings.kind = SolverKind::Multigrid;  // the pools are stored in color order
    world.setSolver(settings);
    world.addCloth(cloth);
    for (int i = 0; i < 20; ++i) world.step(1.0 / 60);
    if (model == BendModel::Isometric) {
      expectColorsGiveTheSlotBits<IsometricBendKernel>(world, &ConstraintPools::isometricBend);
    } else {
      expectColorsGiveTheSlotBits<DihedralKernel>(world, &ConstraintPools::bend);
      expectColorsGiveTheSlotBits<AngleKernel>(world, &ConstraintPools::shear);
    }
  }
  // Hard hinges are accelerated with a history in their slots: they keep the slot path.
  GridSpec spec;
  spec.resolution = {48, 48};
  ObjectDef hard = gridCloth(spec);
  hard.material.bending = true;
  World world;
  SolverSettings settings;
  settings.kind = SolverKind::Multigrid;
  world.setSolver(settings);
  world.addCloth(hard);
  world.step(1.0 / 60);
  EXPECT_TRUE(world.impl().state.constraints.bend.correctionSum.empty());
}

}  // namespace
}  // namespace nucleon
