// Constraint kernels against their definitions: gradients against central finite differences
// (random and near-degenerate configurations), conservation of linear and angular momentum by a
// projection with unequal masses, and return to the rest value after a perturbation.
#include <gtest/gtest.h>

#include <random>

#include "systems/constraint_kernels.h"
#include "systems/stretch_solve.h"

using namespace nucleon;

namespace {

template <class Kernel>
using P = Points<Kernel::kArity>;

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
  const Real dLambda = projectConstraint<Kernel>(x, w, Real(0.5), 0, 0, dx);
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
  projectConstraint<Kernel>(x, w, rest, 0, 0, dx);
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
    projectConstraint<Kernel>(x, w, rest, 0, 0, dx);
    for (std::size_t k = 0; k < x.size(); ++k) x[k] += dx[k];
  }
  Real c = Kernel::value(x, grad) - rest;
  EXPECT_NEAR(c, 0, 1e-4);
}

}  // namespace

TEST(AngleKernel, GradientMatchesFiniteDifferences) {
  checkRandomGradients<AngleKernel>();
}
TEST(DihedralKernel, GradientMatchesFiniteDifferences) {
  checkRandomGradients<DihedralKernel>();
}
TEST(VolumeKernel, GradientMatchesFiniteDifferences) {
  checkRandomGradients<VolumeKernel>();
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
  // Stretch on coincident points.
  const StretchCorrection s = stretchCorrection(Vec3(1, 1, 1), Vec3(1, 1, 1), 1, 1, 1, 0, 0, 0, 1);
  EXPECT_TRUE(s.dxi.allFinite() && s.dxj.allFinite() && std::isfinite(s.dLambda));
}

TEST(Kernels, ProjectionConservesLinearAndAngularMomentum) {
  expectMomentumConserved<AngleKernel>({Vec3(1, 0, 0), Vec3(0.2f, 0.9f, 0.1f), Vec3(0, 0, 0)},
                                       Real(2.0));
  expectMomentumConserved<DihedralKernel>(
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.3f, 1, 0.2f), Vec3(0.6f, -1, 0.4f)}, Real(0.3));
  expectMomentumConserved<VolumeKernel>(
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.2f, 0.3f, 1)}, Real(0.25));
  // Stretch: Σ m Δx = 0 along the edge, and the correction is parallel to it (no torque).
  const Vec3 xi(0.1f, 0.2f, 0.3f), xj(1.0f, -0.5f, 0.7f);
  const Real wi = 1 / 1.0f, wj = 1 / 4.0f;
  const StretchCorrection s = stretchCorrection(xi, xj, wi, wj, 0.5f, 0, 0, 0, 3600);
  EXPECT_LT((s.dxi / wi + s.dxj / wj).norm(), 1e-6);
  EXPECT_LT((xi.cross(s.dxi / wi) + xj.cross(s.dxj / wj)).norm(), 1e-6);
}

TEST(Kernels, EachFamilyReturnsToItsRestValue) {
  expectReturnsToRest<AngleKernel>({Vec3(1, 0.1f, 0), Vec3(-1, 0.3f, 0.1f), Vec3(0, 0, 0)},
                                   Real(2.5));
  expectReturnsToRest<DihedralKernel>(
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.3f, 1, 0.3f), Vec3(0.6f, -1, 0.2f)}, Real(0));
  expectReturnsToRest<VolumeKernel>(
      {Vec3(0, 0, 0), Vec3(1.2f, 0, 0), Vec3(0, 0.8f, 0), Vec3(0.1f, 0.1f, 1.3f)}, Real(1.0 / 6.0));
  // Stretch: a pair pulled to twice its rest length returns in one hard projection.
  Vec3 a(0, 0, 0), b(2, 0, 0);
  const StretchCorrection s = stretchCorrection(a, b, 1, 1, 1, 0, 0, 0, 3600);
  a += s.dxi;
  b += s.dxj;
  EXPECT_NEAR((a - b).norm(), 1, 1e-6);
}
