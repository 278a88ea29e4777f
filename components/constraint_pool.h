// A pool of one constraint family acting on N particles each, as structure of arrays. Every
// built-in family has this shape; the kernel that gives a family its meaning lives in
// systems/solver/constraint_kernels.h, so a sweep is one loop for any of them.
//
// A pool is two records: what the user set (ConstraintSettings: particles, rest value,
// compliances, damping), which only a topology change alters, and what the backends derive from
// it (ConstraintSolveState: coloring, incidence, Jacobi and vertex scratch, λ), which
// systems/setup/build_derived_tables.h rebuilds and the sweeps write. The pool inherits both, so
// a kernel reads pool.rest[c] and pool.lambda[c] alike.
#pragma once

#include <array>
#include <utility>
#include <vector>

#include "components/constraint_graph.h"
#include "nucleon/types.h"

namespace nucleon {

// What every constraint pool stores besides its particles and rest data, one entry per
// constraint: the user's parameters.
struct ConstraintParameters {
  // XPBD compliance α (inverse stiffness; 0 = hard) on the stretch side (C ≥ 0 for a constraint
  // that carries no force yet) and on the compression side (kernel_detail::belowRest, the side
  // the multiplier ends on). Cloth resists stretching but buckles, so stretch gives the two
  // directions their own α; the other families store the same value twice.
  std::vector<Real> compliance;
  std::vector<Real> compressionCompliance;
  // Stiffness-proportional (Rayleigh) damping time τ in seconds: the constraint force is
  // −(C + τ dC/dt)/α, so τ damps motion along ∇C without touching rigid motion.
  std::vector<Real> damping;
};

template <std::size_t N>
struct ConstraintSettings : ConstraintParameters {
  static constexpr std::size_t kArity = N;
  std::vector<std::array<Index, N>> particles;  // global particle indices, kernel order
  std::vector<Real> rest;                       // C's rest value from the object's rest shape
  // Constant weights per constraint, for the kernels that take them (IsometricBendKernel: one
  // per particle); empty in every other pool.
  std::vector<std::array<Real, N>> weights;
};

// What the backends derive for a pool of any arity.
struct ConstraintSolveState {
  std::vector<Real> lambda;  // XPBD multiplier, reset every substep
  ParticleIncidence incidence;
  ConstraintColoring coloring;
  std::vector<Vec3> correction;  // Jacobi scratch, arity per constraint
  // Jacobi: each constraint's multiplier step in the last sweep; for a compliant or damped
  // constraint the carried part included (the Chebyshev history of its λ, constraint_sweeps.h).
  // Distance families and registered ones only.
  std::vector<Real> lambdaMove;
  // Jacobi mass splitting: per particle, w_i times the number of this pool's constraints on i.
  std::vector<Real> splitInverseMass;
  bool undamped = true;  // no constraint has damping: the batched distance path applies
};

// What the backends derive for a built-in pool of arity N: the common state, plus the tables of
// the batched and vertex-centric paths.
template <std::size_t N>
struct BuiltinSolveState : ConstraintSolveState {
  // The inverse mass of each constraint's particles, in pool order, for batched kernels that load
  // them with the constraint instead of gathering them per particle.
  std::vector<std::array<Real, N>> endInverseMass;
  // Vertex-centric Jacobi (systems/solver/jacobi_vertex.h), for two-particle pools whose
  // constraints are all hard and undamped (`vertexJacobi`): the slot rows, and per particle the
  // move of the family's last Jacobi sweep, the Chebyshev history (blocks of eight particles as
  // x×8, y×8, z×8), and per lane of the rows the multiplier steps of the substep's vertex
  // sweeps so far, summed (`vertexLambdaPending`: some are not yet in λ; bookVertexMultipliers,
  // constraint_sweeps.h, adds them).
  // `vertexHistory` says which history is current: the per-particle moves (the last sweep took
  // the vertex path) or the correction slots (it took the slot path).
  VertexSlotRows vertexRows;
  std::vector<Real> vertexMove;
  std::vector<Real> vertexLaneLambda;
  bool vertexJacobi = false;
  bool vertexHistory = false;
  bool vertexLambdaPending = false;
  // Jacobi by colors (solveJacobi, constraint_sweeps.h), for angular pools stored in color order
  // whose constraints are all soft (none keeps a history in its slots): per particle, the sum of
  // its constraints' corrections within a sweep, zero between sweeps. Empty where the slot path
  // runs.
  std::vector<Vec3> correctionSum;
};

template <std::size_t N>
struct ConstraintPool : ConstraintSettings<N>, BuiltinSolveState<N> {
  static constexpr std::size_t kArity = N;

  std::size_t size() const { return this->particles.size(); }
  std::size_t arity() const { return N; }
  Index particle(std::size_t c, std::size_t k) const { return this->particles[c][k]; }

  // Reorders the constraints so that the one at order[k] moves to k. The step stores each pool
  // in coloring order, so that a color is a contiguous range in memory as well.
  void permute(const std::vector<Index>& order) {
    auto apply = [&](auto& column) {
      auto old = column;
      for (std::size_t k = 0; k < order.size(); ++k) column[k] = old[order[k]];
    };
    apply(this->particles);
    apply(this->rest);
    apply(this->compliance);
    apply(this->compressionCompliance);
    apply(this->damping);
    apply(this->lambda);
    if (!this->weights.empty()) apply(this->weights);
  }

  // Keeps the constraints c for which keep(c) holds, in their order (a tear or a removed object
  // takes constraints out; the derived tables are rebuilt afterwards).
  template <class Keep>
  void retain(Keep keep) {
    std::size_t kept = 0;
    for (std::size_t c = 0; c < size(); ++c) {
      if (!keep(c)) continue;
      this->particles[kept] = this->particles[c];
      this->rest[kept] = this->rest[c];
      this->compliance[kept] = this->compliance[c];
      this->compressionCompliance[kept] = this->compressionCompliance[c];
      this->damping[kept] = this->damping[c];
      this->lambda[kept] = this->lambda[c];
      if (!this->weights.empty()) this->weights[kept] = this->weights[c];
      ++kept;
    }
    this->particles.resize(kept);
    this->rest.resize(kept);
    this->compliance.resize(kept);
    this->compressionCompliance.resize(kept);
    this->damping.resize(kept);
    this->lambda.resize(kept);
    if (!this->weights.empty()) this->weights.resize(kept);
  }

  void append(const std::array<Index, N>& p, Real restValue, Real alpha, Real alphaCompression,
              Real dampingTime) {
    this->particles.push_back(p);
    this->rest.push_back(restValue);
    this->compliance.push_back(alpha);
    this->compressionCompliance.push_back(alphaCompression);
    this->damping.push_back(dampingTime);
    this->lambda.push_back(0);
  }

  // The same for a pool whose kernel takes weights (every constraint of it has them).
  void append(const std::array<Index, N>& p, Real restValue, Real alpha, Real alphaCompression,
              Real dampingTime, const std::array<Real, N>& constraintWeights) {
    append(p, restValue, alpha, alphaCompression, dampingTime);
    this->weights.push_back(constraintWeights);
  }
};

using StretchConstraints = ConstraintPool<2>;   // type 1: distance between two points
using AngleConstraints = ConstraintPool<3>;     // type 2: shear of triangles, bend of curves
using DihedralConstraints = ConstraintPool<4>;  // type 3: bend of cloth, twist of curves
using VolumeConstraints = ConstraintPool<4>;    // signed volume of a tetrahedron
using TetherConstraints = ConstraintPool<2>;    // long-range attachment: distance ≤ rest

}  // namespace nucleon
