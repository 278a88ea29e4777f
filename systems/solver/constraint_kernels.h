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

// Kernels run once per constraint per sweep: they must inline into the sweep loop, which GCC's
// heuristics do not always do for functions of this size.
#define NUCLEON_KERNEL [[gnu::always_inline]] inline

namespace kernel_detail {
constexpr Real kTiny = Real(1e-12);
// Wraps an angle difference to (−π, π] so a constraint never winds the long way round.
NUCLEON_KERNEL Real wrapAngle(Real a) {
  constexpr Real pi = std::numbers::pi_v<Real>;
  while (a > pi) a -= 2 * pi;
  while (a <= -pi) a += 2 * pi;
  return a;
}
// Whether a projection takes the compression compliance (α̃ below rest) or the stretch one. The
// multiplier an undamped step reaches, λ + Δλ = (s λ − C) / (s + α̃) with s = Σ w ‖∇C‖², has the
// sign of s λ − C whichever α̃ it uses, so the side is chosen by that sign: the branch the
// constraint force ends on, and at the boundary both compliances give the same step (Δλ = −λ).
// Choosing by the sign of C alone would, for a stiff-stretch, soft-compression edge that a sweep
// carried just below its rest length, take the soft α̃ with a large tension λ and return all of
// that tension at once as a push (Δλ ≈ −λ): the edge is thrown back out stretched, and a drape
// with soft compression blew up. With λ = 0 (the first projection of a substep) this is the sign
// of C. A damped step (γ = τ/h, rate term v = ∇C·(x − x_n)) reaches
// ((1 + γ) s λ − C − γ v) / ((1 + γ) s + α̃): its side is the sign of that numerator, which for
// γ = 0 (and v = 0) is C < s λ exactly, the test the undamped lanes make.
NUCLEON_KERNEL bool belowRest(Real constraint, Real stiffness, Real lambda, Real gamma = 0,
                              Real rate = 0) {
  return constraint + gamma * rate < (1 + gamma) * stiffness * lambda;
}
}  // namespace kernel_detail

// Type 1: the distance between two points (stretch of edges).
//   C = ‖x0 − x1‖,  ∇_x0 C = n = (x0 − x1)/‖x0 − x1‖,  ∇_x1 C = −n.
// Coincident points have no direction: zero gradients, no correction.
struct DistanceKernel {
  static constexpr std::size_t kArity = 2;
  static constexpr bool kAngular = false;
  static constexpr bool kUnitGradients = true;  // ‖∇_k C‖ = 1 wherever C is differentiable
  NUCLEON_KERNEL static Real value(const Points<2>& x, Points<2>& grad) {
    const Vec3 d = x[0] - x[1];
    const Real length = d.norm();
    if (length < kernel_detail::kTiny) {
      grad = {Vec3::Zero(), Vec3::Zero()};
      return 0;
    }
    grad[0] = d * (1 / length);
    grad[1] = -grad[0];
    return length;
  }
};

// Tether (long-range attachment): the distance of x0 from a pin x1, limited from above only:
// C = ‖x0 − x1‖ − L ≤ 0 is satisfied, and only C > 0 is corrected (kUnilateral).
struct TetherKernel : DistanceKernel {
  static constexpr bool kUnilateral = true;
};

// Type 2: the angle θ ∈ [0, π] at x2 between the 1-simplices (x2, x0) and (x2, x1).
//   θ = atan2(‖u × v‖, u · v),  u = x0 − x2, v = x1 − x2
//   ∇_x0 θ = −t_u / ‖u‖,  ∇_x1 θ = −t_v / ‖v‖,  ∇_x2 θ = −∇_x0 θ − ∇_x1 θ,
// where t_u is the unit vector normal to u in the plane of u and v, pointing towards v (and t_v
// likewise). Bend for curves (θ0 = π for a straight rope), shear for the corners of triangles.
struct AngleKernel {
  static constexpr std::size_t kArity = 3;
  static constexpr bool kAngular = true;
  NUCLEON_KERNEL static Real value(const Points<3>& x, Points<3>& grad) {
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
  NUCLEON_KERNEL static Real value(const Points<4>& x, Points<4>& grad) {
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

// Type 3 in the isometric form, for hinges flat at rest (Bergou, Wardetzky, Harmon, Zorin and
// Grinspun 2006, "A quadratic bending model for inextensible surfaces"): the hinge of
// DihedralKernel with constant weights k (`weightsOf`, from the rest shape),
//   v = Σ_k k_k x_k,  C = ‖v‖,  ∇_x_k C = k_k v/‖v‖.
// The weights are the cotangent weights of the two triangles over the edge's rest length L
// (Wardetzky et al. 2007): with cot_Ai the cotangent of triangle (x0, x1, x2) at x_i and cot_Bi
// that of (x1, x0, x3),
//   k = (cot_A1 + cot_B1, cot_A0 + cot_B0, −cot_A0 − cot_A1, −cot_B0 − cot_B1) / L.
// They sum to zero and annihilate every flat (affine) image of the rest hinge, so C = 0 there;
// folding the hinge by φ about its edge without stretching gives ‖v‖ = 2 L sin(|φ|/2), so
// C = 2 sin(|φ|/2): the dihedral angle's energy to second order, with ∇C of the dihedral's
// length at φ = 0. A flat hinge (v = 0) has no direction: zero gradients, no correction.
struct IsometricBendKernel {
  static constexpr std::size_t kArity = 4;
  static constexpr bool kAngular = false;
  static constexpr bool kWeighted = true;  // value() takes the constraint's weights
  NUCLEON_KERNEL static Real value(const Points<4>& x, const std::array<Real, 4>& k,
                                   Points<4>& grad) {
    const Vec3 v = k[0] * x[0] + k[1] * x[1] + k[2] * x[2] + k[3] * x[3];
    const Real length = v.norm();
    if (length < kernel_detail::kTiny) {
      for (Vec3& g : grad) g.setZero();
      return length;
    }
    const Vec3 direction = v / length;
    for (std::size_t i = 0; i < 4; ++i) grad[i] = k[i] * direction;
    return length;
  }

  // The weights of a hinge from its rest positions; false where a triangle has no height over the
  // edge (below 1e-6 of its length) or the edge has no length.
  static bool weightsOf(const Points<4>& rest, std::array<Real, 4>& k) {
    const Vec3 e = rest[1] - rest[0];
    const Real length = e.norm();
    if (!(length > kernel_detail::kTiny)) return false;
    // The cotangent of the angle between two rays from one corner: (a·b)/‖a × b‖.
    auto cotangent = [](const Vec3& a, const Vec3& b, Real& cot) {
      const Real sine = a.cross(b).norm();
      if (!(sine > Real(1e-6) * a.norm() * b.norm())) return false;
      cot = a.dot(b) / sine;
      return true;
    };
    Real a0, a1, b0, b1;
    if (!cotangent(e, rest[2] - rest[0], a0) || !cotangent(-e, rest[2] - rest[1], a1) ||
        !cotangent(e, rest[3] - rest[0], b0) || !cotangent(-e, rest[3] - rest[1], b1))
      return false;
    k = {(a1 + b1) / length, (a0 + b0) / length, -(a0 + a1) / length, -(b0 + b1) / length};
    return true;
  }
};

// Volume: the signed volume of the tetrahedron (x0, x1, x2, x3),
//   V = (x1 − x0) × (x2 − x0) · (x3 − x0) / 6,
//   ∇_x1 V = (x2 − x0) × (x3 − x0) / 6, ∇_x2 V = (x3 − x0) × (x1 − x0) / 6,
//   ∇_x3 V = (x1 − x0) × (x2 − x0) / 6, ∇_x0 V = −(∇_x1 + ∇_x2 + ∇_x3).
struct VolumeKernel {
  static constexpr std::size_t kArity = 4;
  static constexpr bool kAngular = false;
  NUCLEON_KERNEL static Real value(const Points<4>& x, Points<4>& grad) {
    const Vec3 a = x[1] - x[0], b = x[2] - x[0], c = x[3] - x[0];
    grad[1] = b.cross(c) / 6;
    grad[2] = c.cross(a) / 6;
    grad[3] = a.cross(b) / 6;
    grad[0] = -grad[1] - grad[2] - grad[3];
    return a.cross(b).dot(c) / 6;
  }
};

// What one projection needs besides positions and inverse masses.
struct ProjectionTerms {
  Real rest = 0;             // C's rest value
  Real alphaTilde = 0;       // α / h² on the stretch side
  Real alphaTildeBelow = 0;  // α / h² on the compression side (kernel_detail::belowRest)
  Real gamma = 0;            // τ / h, the damping time over the substep
  Real lambda = 0;           // multiplier accumulated in this substep
};

// How the projection treats a family's C: an angle (wrapped to (−π, π]), an inequality C ≤ 0
// (unilateral), a function with unit gradients (a distance: the denominator skips the norms).
struct ProjectionForm {
  bool angular = false;
  bool unilateral = false;
  bool unitGradients = false;
};

template <class Kernel>
constexpr ProjectionForm projectionFormOf() {
  ProjectionForm form;
  form.angular = Kernel::kAngular;
  form.unilateral = requires {
    requires Kernel::kUnilateral;
  };
  form.unitGradients = requires {
    requires Kernel::kUnitGradients;
  };
  return form;
}

// One XPBD projection of C = value − rest with stiffness-proportional damping (Macklin et al.
// 2016, eqs. 18 and 26; our γ = τ/h is their α̃β̃/h for a Rayleigh damping time τ):
//   Δλ = (−C − α̃ λ − γ ∇C·(x − x_n)) / ((1 + γ) Σ_k w_k ‖∇_k C‖² + α̃),   Δx_k = w_k ∇_k C Δλ,
// for the n particles of a constraint whose kernel gave `value` and ∇_k C = grad[k], where x_n
// are the positions at the start of the substep (`start`, read only when γ > 0). Angular
// constraints take C modulo 2π. Returns Δλ; dx is zero when nothing can move. Every family,
// built-in or registered, projects through this one function; the built-ins pass n and `form` as
// constants, which the compiler folds.
NUCLEON_KERNEL Real projectEvaluated(Real value, const Vec3* grad, const Vec3* x, const Vec3* start,
                                     const Real* w, std::size_t n, const ProjectionTerms& terms,
                                     ProjectionForm form, Vec3* dx) {
  Real c = value - terms.rest;
  if (form.angular) c = kernel_detail::wrapAngle(c);
  if (form.unilateral) {
    // An inequality C ≤ 0: inactive while satisfied, and its multiplier never pushes.
    if (c <= 0) {
      for (std::size_t k = 0; k < n; ++k) dx[k].setZero();
      return 0;
    }
  }
  Real stiffness = 0, velocity = 0;
  if (form.unitGradients) {
    // Unit gradients skip the norms: the denominator then does not wait on them.
    if (grad[0].isZero(0))
      stiffness = 0;  // the kernel's degenerate case
    else
      for (std::size_t k = 0; k < n; ++k) stiffness += w[k];
  } else {
    for (std::size_t k = 0; k < n; ++k) stiffness += w[k] * grad[k].squaredNorm();
  }
  if (terms.gamma > 0)
    for (std::size_t k = 0; k < n; ++k) velocity += grad[k].dot(x[k] - start[k]);
  // The compliance of the side the multiplier ends on (see kernel_detail::belowRest).
  const Real alphaTilde =
      kernel_detail::belowRest(c, stiffness, terms.lambda, terms.gamma, velocity)
          ? terms.alphaTildeBelow
          : terms.alphaTilde;
  const Real denominator = (1 + terms.gamma) * stiffness + alphaTilde;
  for (std::size_t k = 0; k < n; ++k) dx[k].setZero();
  if (stiffness < kernel_detail::kTiny) return 0;
  const Real dLambda = (-c - alphaTilde * terms.lambda - terms.gamma * velocity) / denominator;
  for (std::size_t k = 0; k < n; ++k) dx[k] = (w[k] * dLambda) * grad[k];
  return dLambda;
}

// The same for a built-in kernel: evaluates C = Kernel::value(x) − rest and projects it.
template <class Kernel>
NUCLEON_KERNEL Real projectConstraint(const Points<Kernel::kArity>& x,
                                      const Points<Kernel::kArity>& start,
                                      const std::array<Real, Kernel::kArity>& w,
                                      const ProjectionTerms& terms, Points<Kernel::kArity>& dx) {
  Points<Kernel::kArity> grad;
  const Real value = Kernel::value(x, grad);
  return projectEvaluated(value, grad.data(), x.data(), start.data(), w.data(), Kernel::kArity,
                          terms, projectionFormOf<Kernel>(), dx.data());
}

}  // namespace nucleon
