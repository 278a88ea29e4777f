// Constraint families of your own: an embedding program registers a family with a world, then
// adds constraints of it to objects. A registered family is colored, swept by every backend
// (Gauss–Seidel, colored Gauss–Seidel, Jacobi and multigrid's fine sweeps) through the same
// generic sweep as the built-in families, scheduled by name, counted in the statistics, and
// deterministic across thread counts like them.
//
//   Real onPlane(const Vec3* x, const Real* rest, Vec3* gradient, const void*) {
//     const Vec3 n(rest[0], rest[1], rest[2]);   // C = n · x − d: x stays on the plane
//     gradient[0] = n;
//     return n.dot(x[0]) - rest[3];
//   }
//   UserConstraintFamilyDef def;
//   def.name = "on-plane";
//   def.arity = 1;
//   def.restSize = 4;
//   def.evaluate = onPlane;
//   ConstraintFamily family = world.registerConstraintFamily(def);
//   world.addConstraint(cloth, family, {{corner}}, {{0, 1, 0, 0.5}});
//
// The solver projects each constraint with XPBD (Macklin et al. 2016, eq. 18 with
// stiffness-proportional damping):
//   Δλ = (−C − α̃ λ − γ ∇C·(x − x_n)) / ((1 + γ) Σ_k w_k ‖∇_k C‖² + α̃),   Δx_k = w_k ∇_k C Δλ,
// with α̃ = α/h² and γ = τ/h, exactly as for a built-in family.
#pragma once

#include <cstddef>
#include <string>

#include "nucleon/types.h"

namespace nucleon {

// Most particles one constraint of a registered family may act on: 1–4 for the usual simplices,
// up to this many for a cluster (shape matching, a rigid group).
constexpr std::size_t kMaxUserConstraintArity = 64;

// Evaluates one constraint: returns C(x) for the constraint's `arity` particle positions x and
// its `restSize` rest values, and writes ∇_k C (k = 0 … arity − 1) to gradient[k]. It must be a
// pure function of its arguments: it runs on many threads at once, and determinism across thread
// counts needs the same bits from the same inputs. A configuration without a defined gradient
// (coincident points) should write zero gradients: the constraint then makes no correction.
using UserConstraintFunction = Real (*)(const Vec3* x, const Real* rest, Vec3* gradient,
                                        const void* userData);

struct UserConstraintFamilyDef {
  std::string name;          // how schedules name it: not empty, not a built-in family's name
  std::size_t arity = 2;     // particles per constraint, 1 … kMaxUserConstraintArity
  std::size_t restSize = 1;  // rest values per constraint, 0 … 64
  UserConstraintFunction evaluate = nullptr;
  const void* userData = nullptr;  // handed to evaluate; must outlive the world
  // C is an angle: the solver wraps it to (−π, π] so a constraint never winds the long way round.
  bool angular = false;
  // C ≤ 0 is satisfied (an inequality, such as a maximum distance): only C > 0 is corrected.
  bool unilateral = false;
  // ‖∇_k C‖ = 1 for every particle wherever C is differentiable (a distance): the solver takes
  // Σ_k w_k for the denominator instead of the norms, and a zero ∇_0 C as degenerate.
  bool unitGradients = false;
  // Jacobi: accelerate the family's constraints with the Chebyshev extrapolation the built-in
  // families take (SolverSettings::chebyshevRho): the hard, undamped ones, and unless `angular`,
  // the compliant or damped ones with their multiplier's history, as the built-in distance
  // family's (ARCHITECTURE.md §3, jacobi). Off by default: the spectral radius estimate is tuned
  // for stretch, and extrapolation against a constraint that converges faster than that (a
  // constraint on one particle is met by one projection) was seen to diverge. While a world
  // holds constraints of a family with this off, the Jacobi sweeps of every family run plain (no
  // Chebyshev acceleration): safe, and slower to converge.
  bool jacobiAcceleration = false;
};

// The compliance and damping of one constraint (ARCHITECTURE.md §2): α in m/N-like units of C
// per unit force (0 = hard), α on the compression side (compressionCompliance, negative: the
// same as `compliance`; a projection takes the side its multiplier ends on, which is the sign of
// C when the constraint carries no force yet), and the Rayleigh damping time τ in seconds.
struct ConstraintCompliance {
  Real compliance = 0;
  Real compressionCompliance = -1;
  Real damping = 0;
};

}  // namespace nucleon
