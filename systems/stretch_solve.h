// Type 1 (stretch) constraint: kernel and sweeps.
#pragma once

#include "components/particles.h"
#include "components/stretch_constraints.h"

namespace nucleon {

struct StretchCorrection {
  Vec3 dxi = Vec3::Zero();
  Vec3 dxj = Vec3::Zero();
  Real dLambda = 0;
};

// One XPBD projection of C(x) = ‖xi − xj‖ − L0, with ∇_xi C = n = (xi − xj)/‖xi − xj‖ = −∇_xj C.
//   Δλ = (−C − α̃ λ) / (wi + wj + α̃),   α̃ = α / h²   (Macklin et al. 2016, eq. 18)
//   Δxi = wi Δλ n,  Δxj = −wj Δλ n
// α is the stretch compliance when C > 0 and the compression compliance when C < 0. A pair of
// coincident points (no defined direction) or two immovable points gives no correction.
inline StretchCorrection stretchCorrection(const Vec3& xi, const Vec3& xj, Real wi, Real wj,
                                           Real restLength, Real stretchCompliance,
                                           Real compressionCompliance, Real lambda, Real invH2) {
  StretchCorrection out;
  const Vec3 d = xi - xj;
  const Real length = d.norm();
  const Real c = length - restLength;
  const Real alpha = (c > 0 ? stretchCompliance : compressionCompliance) * invH2;
  const Real denominator = wi + wj + alpha;
  if (length < Real(1e-12) || denominator < Real(1e-12)) return out;
  out.dLambda = (-c - alpha * lambda) / denominator;
  const Vec3 n = d / length;
  out.dxi = (wi * out.dLambda) * n;
  out.dxj = (-wj * out.dLambda) * n;
  return out;
}

// One Gauss–Seidel sweep over all stretch constraints in pool order, moving particles.p in place:
// the sequential reference, with the best convergence per sweep.
void solveStretchGaussSeidel(StretchConstraints& constraints, ParticlePool& particles, Real h);

// One Jacobi sweep: every constraint's correction from the same p (parallel over constraints),
// then the averaged gather (parallel over particles). Needs constraints.incidence.
void solveStretchJacobi(StretchConstraints& constraints, ParticlePool& particles, Real h,
                        Real relaxation);

// One colored Gauss–Seidel sweep: colors in sequence, each color's constraints in parallel with
// direct writes (no two share a particle). Needs constraints.coloring.
void solveStretchColored(StretchConstraints& constraints, ParticlePool& particles, Real h);

}  // namespace nucleon
