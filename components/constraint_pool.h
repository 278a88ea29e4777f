// A pool of one constraint family acting on N particles each, as structure of arrays: the shape
// every family but stretch uses (stretch has two compliances and its own pool). The kernel that
// gives the family its meaning lives in systems/constraint_kernels.h.
#pragma once

#include <array>
#include <vector>

#include "components/constraint_graph.h"
#include "nucleon/types.h"

namespace nucleon {

template <std::size_t N>
struct ConstraintPool {
  static constexpr std::size_t kArity = N;
  std::vector<std::array<Index, N>> particles;  // global particle indices, kernel order
  std::vector<Real> rest;                       // C's rest value from the object's rest shape
  std::vector<Real> compliance;                 // XPBD α; 0 = hard
  std::vector<Real> lambda;                     // XPBD multiplier, reset every substep

  // Derived when the topology changes (systems/constraint_graph_build.h).
  ParticleIncidence incidence;
  ConstraintColoring coloring;
  std::vector<Vec3> correction;  // Jacobi scratch, N per constraint

  std::size_t size() const { return particles.size(); }
  void append(const std::array<Index, N>& p, Real restValue, Real alpha) {
    particles.push_back(p);
    rest.push_back(restValue);
    compliance.push_back(alpha);
    lambda.push_back(0);
  }
};

using BendConstraints = ConstraintPool<4>;    // type 3: dihedral angle of two triangles
using VolumeConstraints = ConstraintPool<4>;  // signed volume of a tetrahedron

}  // namespace nucleon
