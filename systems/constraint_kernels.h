// Constraint kernels: each evaluates one constraint function C(x) and its gradients ∇_k C for the
// N particles it acts on. They are pure functions of positions; projectConstraint turns any of
// them into an XPBD correction, and the sweeps decide how corrections are applied.
//
// Degenerate configurations (coincident points, a collinear angle, a zero-area triangle of a
// hinge) return zero gradients: the projection then makes no correction instead of a NaN.
#pragma once

#include <array>
#include <cmath>
#include <numbers>

#include "nucleon/types.h"

namespace nucleon {

template <std::size_t N>
using Points = std::array<Vec3, N>;

namespace kernel_detail {
constexpr Real kTiny = Real(1e-12);
// Wraps an angle difference to (−π, π] so a constraint never winds the long way round.
inline Real wrapAngle(Real a) {
  constexpr Real pi = std::numbers::pi_v<Real>;
  while (a > pi) a -= 2 * pi;
  while (a <= -pi) a += 2 * pi;
  return a;
}
}  // namespace kernel_detail

// Type 2: the angle θ ∈ [0, π] at x2 between the 1-simplices (x2, x0) and (x2, x1).
//   θ = atan2(‖u × v‖, u · v),  u = x0 − x2, v = x1 − x2
//   ∇_x0 θ = −t_u / ‖u‖,  ∇_x1 θ = −t_v / ‖v‖,  ∇_x2 θ = −∇_x0 θ − ∇_x1 θ,
// where t_u is the unit vector normal to u in the plane of u and v, pointing towards v (and t_v
// likewise). Bend for curves (θ0 = π for a straight rope), shear for the corners of triangles.
struct AngleKernel {
  static constexpr std::size_t kArity = 3;
  static constexpr bool kAngular = true;
  static Real value(const Points<3>& x, Points<3>& grad) {
    const Vec3 u = x[0] - x[2], v = x[1] - x[2];
    const Real lu = u.norm(), lv = v.norm();
    grad = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    if (lu < kernel_detail::kTiny || lv < kernel_detail::kTiny) return std::numbers::pi_v<Real>;
    const Vec3 uh = u / lu, vh = v / lv;
    const Real sine = uh.cross(vh).norm(), cosine = uh.dot(vh);
    const Real theta = std::atan2(sine, cosine);
    if (sine < Real(1e-6)) return theta;  // collinear: no plane, no defined gradient direction
    const Vec3 tu = (vh - cosine * uh) / sine, tv = (uh - cosine * vh) / sine;
    grad[0] = -tu / lu;
    grad[1] = -tv / lv;
    grad[2] = -grad[0] - grad[1];
    return theta;
  }
};

// Type 3: the dihedral angle φ ∈ (−π, π] of the hinge of triangles (x0, x1, x2) and (x1, x0, x3)
// on the shared edge e = x1 − x0; φ = 0 when the two are coplanar and unfolded.
//   n1 = (x1 − x0) × (x2 − x0),  n2 = (x3 − x0) × (x1 − x0)   (both normals of a flat sheet agree)
//   φ = atan2((n1 × n2) · ê, n1 · n2)
// Gradients (Bridson et al. 2003; Wardetzky et al. 2007, "discrete shells"): the wing vertices
// move the angle along their face normals scaled by edge length over face area,
//   ∇_x2 φ = −‖e‖ n1/‖n1‖²,  ∇_x3 φ = −‖e‖ n2/‖n2‖²,
// and the edge ends take the rest in proportion to where x2 and x3 project onto the edge
// (s_k = (x_k − x0)·e/‖e‖²):
//   ∇_x0 φ = −(1 − s2) ∇_x2 φ − (1 − s3) ∇_x3 φ,   ∇_x1 φ = −s2 ∇_x2 φ − s3 ∇_x3 φ,
// so the four sum to zero (translation invariance).
struct DihedralKernel {
  static constexpr std::size_t kArity = 4;
  static constexpr bool kAngular = true;
  static Real value(const Points<4>& x, Points<4>& grad) {
    const Vec3 e = x[1] - x[0];
    const Vec3 n1 = e.cross(x[2] - x[0]), n2 = (x[3] - x[0]).cross(e);
    const Real le = e.norm(), a1 = n1.squaredNorm(), a2 = n2.squaredNorm();
    grad = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    if (le < kernel_detail::kTiny || a1 < kernel_detail::kTiny || a2 < kernel_detail::kTiny)
      return 0;
    const Vec3 eh = e / le;
    const Real phi = std::atan2(n1.cross(n2).dot(eh), n1.dot(n2));
    // Heights of x2 and x3 over the edge enter through n/‖n‖²; the edge ends get the
    // barycentric share of where x2 and x3 project onto the edge.
    const Vec3 g2 = -le * n1 / a1, g3 = -le * n2 / a2;
    const Real s2 = (x[2] - x[0]).dot(eh) / le, s3 = (x[3] - x[0]).dot(eh) / le;
    grad[2] = g2;
    grad[3] = g3;
    grad[0] = -(1 - s2) * g2 - (1 - s3) * g3;
    grad[1] = -s2 * g2 - s3 * g3;
    return phi;
  }
};

// Volume: the signed volume of the tetrahedron (x0, x1, x2, x3),
//   V = (x1 − x0) × (x2 − x0) · (x3 − x0) / 6,
//   ∇_x1 V = (x2 − x0) × (x3 − x0) / 6, ∇_x2 V = (x3 − x0) × (x1 − x0) / 6,
//   ∇_x3 V = (x1 − x0) × (x2 − x0) / 6, ∇_x0 V = −(∇_x1 + ∇_x2 + ∇_x3).
struct VolumeKernel {
  static constexpr std::size_t kArity = 4;
  static constexpr bool kAngular = false;
  static Real value(const Points<4>& x, Points<4>& grad) {
    const Vec3 a = x[1] - x[0], b = x[2] - x[0], c = x[3] - x[0];
    grad[1] = b.cross(c) / 6;
    grad[2] = c.cross(a) / 6;
    grad[3] = a.cross(b) / 6;
    grad[0] = -grad[1] - grad[2] - grad[3];
    return a.cross(b).dot(c) / 6;
  }
};

// One XPBD projection of C = value(x) − rest for any kernel (Macklin et al. 2016, eq. 18):
//   Δλ = (−C − α̃ λ) / (Σ_k w_k ‖∇_k C‖² + α̃),  α̃ = α / h²,   Δx_k = w_k ∇_k C Δλ.
// Angular constraints take C modulo 2π. Returns Δλ; dx is zero when nothing can move.
template <class Kernel>
Real projectConstraint(const Points<Kernel::kArity>& x, const std::array<Real, Kernel::kArity>& w,
                       Real rest, Real alphaTilde, Real lambda, Points<Kernel::kArity>& dx) {
  Points<Kernel::kArity> grad;
  Real c = Kernel::value(x, grad) - rest;
  if constexpr (Kernel::kAngular) c = kernel_detail::wrapAngle(c);
  Real denominator = alphaTilde;
  for (std::size_t k = 0; k < Kernel::kArity; ++k) denominator += w[k] * grad[k].squaredNorm();
  for (auto& d : dx) d.setZero();
  if (denominator < kernel_detail::kTiny) return 0;
  const Real dLambda = (-c - alphaTilde * lambda) / denominator;
  for (std::size_t k = 0; k < Kernel::kArity; ++k) dx[k] = (w[k] * dLambda) * grad[k];
  return dLambda;
}

}  // namespace nucleon
