// Constraint kernels against their definitions: gradients against central finite differences
// (random and near-degenerate configurations), conservation of linear and angular momentum by a
// projection with unequal masses, and return to the rest value after a perturbation.
#include <gtest/gtest.h>

#include <random>

#include "nucleon/constraint_family.h"
#include "systems/solver/constraint_kernels.h"

using namespace nucleon;

namespace {

template <class Kernel>
using P = Points<Kernel::kArity>;

// A hard, undamped projection towards `rest`.
template <class Kernel>
Real project(const P<Kernel>& x, const std::array<Real, Kernel::kArity>& w, Real rest,
             P<Kernel>& dx) {
  ProjectionTerms terms;
  terms.rest = rest;
  return projectConstraint<Kernel>(x, x, w, terms, dx);
}

template <class Kernel>
P<Kernel> randomPoints(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1, 1);
  P<Kernel> x;
  for (auto& p : x) p = Vec3(u(rng), u(rng), u(rng));
  return x;
}

// Central differences with step 1e-3 in float: truncation O(h²) ≈ 1e-6, rounding ≈ ε/h ≈ 1e-4
// relative to C; the tolerance 3e-3·max(1, |g|) covers both with margin.
template <class Kernel>
void expectGradientMatchesFiniteDifferences(const P<Kernel>& x, const char* what) {
  P<Kernel> grad, unused;
  Kernel::value(x, grad);
  const Real h = Real(1e-3);
  for (std::size_t k = 0; k < Kernel::kArity; ++k)
    for (int axis = 0; axis < 3; ++axis) {
      P<Kernel> plus = x, minus = x;
      plus[k][axis] += h;
      minus[k][axis] -= h;
      Real difference = Kernel::value(plus, unused) - Kernel::value(minus, unused);
      if constexpr (Kernel::kAngular) {  // an angle crossing ±π wraps
        while (difference > Real(3)) difference -= Real(2 * std::numbers::pi);
        while (difference < Real(-3)) difference += Real(2 * std::numbers::pi);
      }
      const Real fd = difference / (2 * h);
      EXPECT_NEAR(grad[k][axis], fd, 3e-3 * std::max(Real(1), std::abs(fd)))
          << what << ": particle " << k << " axis " << axis;
    }
}

// Well-shaped random configurations: far from the kernels' singular sets, where finite
// differences are meaningful.
template <class Kernel>
bool wellShaped(const P<Kernel>& x) {
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j)
      if ((x[i] - x[j]).norm() < Real(0.2)) return false;
  P<Kernel> grad;
  const Real v = Kernel::value(x, grad);
  if constexpr (std::is_same_v<Kernel, AngleKernel>) return v > Real(0.2) && v < Real(2.9);
  if constexpr (std::is_same_v<Kernel, DihedralKernel>) {
    const Vec3 e = x[1] - x[0];
    return e.cross(x[2] - x[0]).norm() > Real(0.2) && e.cross(x[3] - x[0]).norm() > Real(0.2) &&
           std::abs(v) < Real(2.9);
  }
  return true;
}

template <class Kernel>
void checkRandomGradients() {
  std::mt19937 rng(12345);
  int checked = 0;
  while (checked < 200) {
    const P<Kernel> x = randomPoints<Kernel>(rng);
    if (!wellShaped<Kernel>(x)) continue;
    expectGradientMatchesFiniteDifferences<Kernel>(x, "random");
    ++checked;
  }
}

template <class Kernel>
void expectFinite(const P<Kernel>& x) {
  P<Kernel> grad, dx;
  const Real v = Kernel::value(x, grad);
  EXPECT_TRUE(std::isfinite(v));
  for (const Vec3& g : grad) EXPECT_TRUE(g.allFinite());
  std::array<Real, Kernel::kArity> w;
  w.fill(1);
  const Real dLambda = project<Kernel>(x, w, Real(0.5), dx);
  EXPECT_TRUE(std::isfinite(dLambda));
  for (const Vec3& d : dx) EXPECT_TRUE(d.allFinite());
}

// Σ m_k Δx_k = 0 and Σ x_k × m_k Δx_k = 0 for a constraint invariant under translation and
// rotation; checked with masses that differ by an order of magnitude.
template <class Kernel>
void expectMomentumConserved(const P<Kernel>& x, Real rest) {
  std::array<Real, Kernel::kArity> w;
  const Real masses[] = {1.0f, 2.5f, 0.3f, 4.0f};
  for (std::size_t k = 0; k < w.size(); ++k) w[k] = 1 / masses[k];
  P<Kernel> dx;
  project<Kernel>(x, w, rest, dx);
  Vec3 linear = Vec3::Zero(), angular = Vec3::Zero();
  Real scale = 0;
  for (std::size_t k = 0; k < w.size(); ++k) {
    linear += masses[k] * dx[k];
    angular += x[k].cross(masses[k] * dx[k]);
    scale += masses[k] * dx[k].norm();
  }
  ASSERT_GT(scale, Real(1e-4));  // the projection did move the particles
  EXPECT_LT(linear.norm(), 1e-5 * scale);
  EXPECT_LT(angular.norm(), 1e-5 * scale * 4);  // |x| ≤ √3 in these configurations
}

// Repeated hard projections from a perturbed configuration bring C back to 0.
template <class Kernel>
void expectReturnsToRest(P<Kernel> x, Real rest) {
  std::array<Real, Kernel::kArity> w = {};
  w.fill(1);
  w[0] = Real(0.5);
  P<Kernel> grad, dx;
  for (int i = 0; i < 50; ++i) {
    project<Kernel>(x, w, rest, dx);
    for (std::size_t k = 0; k < x.size(); ++k) x[k] += dx[k];
  }
  Real c = Kernel::value(x, grad) - rest;
  EXPECT_NEAR(c, 0, 1e-4);
}

}  // namespace

TEST(DistanceKernel, GradientMatchesFiniteDifferences) {
  checkRandomGradients<DistanceKernel>();
}
TEST(AngleKernel, GradientMatchesFiniteDifferences) {
  checkRandomGradients<AngleKernel>();
}
// Kernels with weights (IsometricBendKernel): random flat hinges give the weights, random
// displacements of them the configurations. Central differences with step 1e-4 m in float: C is
// the norm of a linear map of x, whose curvature is at most (largest weight)²/‖v‖ (‖v‖ ≥ 0.05 m
// here, weights up to ~50/m): truncation ≈ h² k²/‖v‖ and rounding ≈ 1e-7 ‖v‖/h stay below
// 2e-3 of the largest weight.
template <class Kernel>
void checkWeightedGradients() {
  std::mt19937 random(5);
  std::uniform_real_distribution<float> unit(-1, 1);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 origin(unit(random), unit(random), unit(random));
    const Vec3 axis = Vec3(unit(random), unit(random), unit(random)).normalized();
    const Vec3 side = axis.unitOrthogonal();
    const float length = 0.1f + 0.05f * unit(random);
    const Points<4> rest = {origin, origin + length * axis,
                            origin + (0.5f + 0.7f * unit(random)) * length * axis + 0.08f * side,
                            origin + (0.5f + 0.7f * unit(random)) * length * axis - 0.06f * side};
    std::array<Real, 4> k{};
    ASSERT_TRUE(Kernel::weightsOf(rest, k));
    Points<4> x = rest, grad, unused;
    for (Vec3& p : x) p += 0.03f * Vec3(unit(random), unit(random), unit(random));
    if (Kernel::value(x, k, grad) < 0.05f) continue;  // near v = 0 the norm has a kink
    ++checked;
    const Real h = Real(1e-4);
    Real largest = 0;
    for (Real weight : k) largest = std::max(largest, std::abs(weight));
    for (int particle = 0; particle < 4; ++particle)
      for (int axisIndex = 0; axisIndex < 3; ++axisIndex) {
        Points<4> plus = x, minus = x;
        plus[particle][axisIndex] += h;
        minus[particle][axisIndex] -= h;
        const Real fd =
            (Kernel::value(plus, k, unused) - Kernel::value(minus, k, unused)) / (2 * h);
        EXPECT_NEAR(grad[particle][axisIndex], fd, 2e-3f * largest)
            << "trial " << trial << " particle " << particle << " axis " << axisIndex;
      }
  }
  EXPECT_GT(checked, 100);
}

// Either check, by whether the kernel takes weights.
template <class Kernel>
void checkGradients() {
  if constexpr (requires { Kernel::kWeighted; })
    checkWeightedGradients<Kernel>();
  else
    checkRandomGradients<Kernel>();
}

TEST(DihedralKernel, GradientMatchesFiniteDifferences) {
  checkRandomGradients<DihedralKernel>();
}
TEST(IsometricBendKernel, GradientMatchesFiniteDifferences) {
  checkWeightedGradients<IsometricBendKernel>();
}
TEST(VolumeKernel, GradientMatchesFiniteDifferences) {
  checkRandomGradients<VolumeKernel>();
}

// Every kernel of the family table, whatever families it holds: a family added to the table is
// checked here without a new test.
TEST(FamilyTable, EveryKernelsGradientMatchesFiniteDifferences) {
  int kernels = 0;
#define NUCLEON_POOL(member, arity, Kernel, paths)                          \
  {                                                                         \
    SCOPED_TRACE(#member);                                                  \
    static_assert(Kernel::kArity == (arity), "the table's arity is wrong"); \
    checkGradients<Kernel>();                                               \
    ++kernels;                                                              \
  }
#define NUCLEON_FAMILY_POOLS(enumerator, name, pools) pools
  NUCLEON_CONSTRAINT_FAMILIES(NUCLEON_FAMILY_POOLS)
#undef NUCLEON_FAMILY_POOLS
#undef NUCLEON_POOL
  EXPECT_EQ(kernels, 8);  // the pools of the six built-in families (bend has three)
}

TEST(DihedralKernel, FlatHingeHasZeroAngleAndAWellDefinedGradient) {
  const Points<4> flat = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.3f, 1, 0), Vec3(0.6f, -1, 0)};
  Points<4> grad;
  EXPECT_NEAR(DihedralKernel::value(flat, grad), 0, 1e-6);
  expectGradientMatchesFiniteDifferences<DihedralKernel>(flat, "flat");
  // Folding x3 up by 90° gives ±π/2.
  const Points<4> folded = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.3f, 1, 0), Vec3(0.6f, 0, 1)};
  EXPECT_NEAR(std::abs(DihedralKernel::value(folded, grad)), std::numbers::pi / 2, 1e-5);
}

TEST(Kernels, NearDegenerateConfigurationsGiveNoNaN) {
  // Collinear and coincident points for the angle.
  expectFinite<AngleKernel>({Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(1, 0, 0)});
  expectFinite<AngleKernel>({Vec3(1, 0, 0), Vec3(1, 1e-7f, 0), Vec3(0, 0, 0)});
  expectFinite<AngleKernel>({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, 0)});
  // A hinge whose wing collapses onto the edge, and a zero-length edge.
  expectFinite<DihedralKernel>({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5f, 1e-8f, 0), Vec3(0, 1, 0)});
  expectFinite<DihedralKernel>({Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0)});
  // A nearly inverted (flat) tet and a fully collapsed one.
  expectFinite<VolumeKernel>(
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.3f, 0.3f, 1e-7f)});
  expectFinite<VolumeKernel>({Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0, 0)});
  // Stretch on coincident and nearly coincident points.
  expectFinite<DistanceKernel>({Vec3(1, 1, 1), Vec3(1, 1, 1)});
  expectFinite<DistanceKernel>({Vec3(1, 1, 1), Vec3(1, 1, 1 + 1e-7f)});
}

TEST(Kernels, ProjectionConservesLinearAndAngularMomentum) {
  expectMomentumConserved<AngleKernel>({Vec3(1, 0, 0), Vec3(0.2f, 0.9f, 0.1f), Vec3(0, 0, 0)},
                                       Real(2.0));
  expectMomentumConserved<DihedralKernel>(
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.3f, 1, 0.2f), Vec3(0.6f, -1, 0.4f)}, Real(0.3));
  expectMomentumConserved<VolumeKernel>(
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.2f, 0.3f, 1)}, Real(0.25));
  expectMomentumConserved<DistanceKernel>({Vec3(0.1f, 0.2f, 0.3f), Vec3(1.0f, -0.5f, 0.7f)},
                                          Real(0.5));
}

TEST(Kernels, EachFamilyReturnsToItsRestValue) {
  expectReturnsToRest<AngleKernel>({Vec3(1, 0.1f, 0), Vec3(-1, 0.3f, 0.1f), Vec3(0, 0, 0)},
                                   Real(2.5));
  expectReturnsToRest<DihedralKernel>(
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.3f, 1, 0.3f), Vec3(0.6f, -1, 0.2f)}, Real(0));
  expectReturnsToRest<VolumeKernel>(
      {Vec3(0, 0, 0), Vec3(1.2f, 0, 0), Vec3(0, 0.8f, 0), Vec3(0.1f, 0.1f, 1.3f)}, Real(1.0 / 6.0));
  expectReturnsToRest<DistanceKernel>({Vec3(0, 0, 0), Vec3(2, 0.5f, 0)}, Real(1));
  // A distance is linear along its gradient: one hard projection is exact.
  const Points<2> pair = {Vec3(0, 0, 0), Vec3(2, 0, 0)};
  Points<2> dx;
  project<DistanceKernel>(pair, {1, 1}, 1, dx);
  EXPECT_NEAR((pair[0] + dx[0] - pair[1] - dx[1]).norm(), 1, 1e-6);
}

// The compliance is chosen by the side the constraint force ends on; with no multiplier yet (the
// first projection of a substep) that is the sign of C: a hard stretch compliance with a huge
// compression compliance removes all of an extension and barely resists a compression (cloth that
// buckles).
TEST(Kernels, StretchAndCompressionUseTheirOwnCompliance) {
  const Points<2> stretched = {Vec3(0, 0, 0), Vec3(2, 0, 0)};
  const Points<2> compressed = {Vec3(0, 0, 0), Vec3(0.5f, 0, 0)};
  ProjectionTerms terms;
  terms.rest = 1;
  terms.alphaTilde = 0;         // hard against stretching
  terms.alphaTildeBelow = 1e6;  // nearly free in compression (cloth buckles)
  Points<2> dx;
  projectConstraint<DistanceKernel>(stretched, stretched, {1, 1}, terms, dx);
  EXPECT_NEAR((dx[1] - dx[0]).norm(), 1, 1e-6);  // the whole excess removed
  projectConstraint<DistanceKernel>(compressed, compressed, {1, 1}, terms, dx);
  EXPECT_LT((dx[1] - dx[0]).norm(), 1e-5);  // 0.5 / (2 + 1e6): barely pushed apart
}

// An edge that carries tension (λ < 0 from earlier sweeps of the substep) and that a sweep carried
// just short of its rest length is still on the stretch side: the step puts it back at its rest
// length and keeps most of the tension. Choosing the compliance by the sign of C alone took the
// soft compression compliance there, and the step λ + Δλ = (s λ − C)/(s + α̃) ≈ 0 returned the
// whole tension as a push: here 0.5 per end, the edge thrown out to about twice its length.
TEST(Kernels, AnEdgeUnderTensionJustBelowRestKeepsItsStretchCompliance) {
  const Points<2> pair = {Vec3(0, 0, 0), Vec3(0.999f, 0, 0)};
  ProjectionTerms terms;
  terms.rest = 1;
  terms.alphaTilde = 0;
  terms.alphaTildeBelow = 1e6;
  terms.lambda = -0.5f;  // tension: s λ − C = 2 (−0.5) + 0.001 < 0
  Points<2> dx;
  const Real dLambda = projectConstraint<DistanceKernel>(pair, pair, {1, 1}, terms, dx);
  EXPECT_NEAR((pair[1] + dx[1] - pair[0] - dx[0]).norm(), 1, 1e-6);
  EXPECT_NEAR(dLambda, 0.0005f, 1e-6);  // −C / s: the tension eased by what the edge needs
  EXPECT_LT(terms.lambda + dLambda, 0);
  // Without the tension the same edge is compressed and barely resisted.
  terms.lambda = 0;
  projectConstraint<DistanceKernel>(pair, pair, {1, 1}, terms, dx);
  EXPECT_LT((dx[1] - dx[0]).norm(), 1e-8);
}

// Damped, the step's multiplier is ((1 + γ) s λ − C − γ v) / ((1 + γ) s + α̃), v = ∇C·(x − x_n):
// the side is the sign of that numerator, and where it changes both compliances give the same
// step, so Δλ is continuous in C. Scanned over edge lengths across both candidate boundaries: the
// damped one at C = −0.5, and the undamped one, C = s λ = −0.2, where choosing by it jumped by
// 0.037 between neighbouring samples.
TEST(Kernels, ADampedStepIsContinuousAcrossTheSides) {
  ProjectionTerms terms;
  terms.rest = 1;
  terms.alphaTilde = 0;
  terms.alphaTildeBelow = 1e6f;
  terms.lambda = -0.1f;
  terms.gamma = 3;
  Real previous = 0, largestJump = 0;
  for (int k = 0; k <= 400; ++k) {
    const Real length = Real(0.3) + Real(0.002) * Real(k);  // C from −0.7 to 0.1
    const Points<2> x = {Vec3(0, 0, 0), Vec3(length, 0, 0)};
    const Points<2> start = {Vec3(0, 0, 0), Vec3(length + Real(0.1), 0, 0)};  // v = −0.1
    Points<2> dx;
    const Real dLambda = projectConstraint<DistanceKernel>(x, start, {1, 1}, terms, dx);
    if (k > 0) largestJump = std::max(largestJump, std::abs(dLambda - previous));
    previous = dLambda;
  }
  // Away from the boundary Δλ changes by 0.002 / ((1 + γ) s) = 2.5e-4 per sample at most.
  EXPECT_LT(largestJump, 1e-3);
}

// Damping acts on the velocity along ∇C only: with γ > 0 the correction opposes the motion
// x − x_n that changes C, and a rigid translation (which does not change C) is left alone.
TEST(Kernels, DampingOpposesTheRateOfChangeOfCOnly) {
  const Points<2> start = {Vec3(0, 0, 0), Vec3(1, 0, 0)};
  ProjectionTerms terms;
  terms.rest = 1;
  terms.alphaTilde = terms.alphaTildeBelow = 1;
  terms.gamma = 2;
  Points<2> dx;
  // Moving apart at C = 0.1: without damping Δλ = −0.1 / 3; damping adds −γ·0.1 to the
  // numerator and γ·2 to the denominator: Δλ = −(0.1 + 0.2) / (3·2 + 1).
  const Points<2> apart = {Vec3(0, 0, 0), Vec3(1.1f, 0, 0)};
  const Real dLambda = projectConstraint<DistanceKernel>(apart, start, {1, 1}, terms, dx);
  EXPECT_NEAR(dLambda, -0.3 / 7, 1e-6);
  // Translated together: C and its rate are zero, so nothing moves.
  const Points<2> translated = {Vec3(0, 0.3f, 0), Vec3(1, 0.3f, 0)};
  projectConstraint<DistanceKernel>(translated, start, {1, 1}, terms, dx);
  EXPECT_LT(dx[0].norm() + dx[1].norm(), 1e-7);
}
