// Type 1 constraints (stretch) between pairs of particles, as structure of arrays.
//
// One entry per edge of every object that resists stretching. Compliance is split: cloth resists
// stretching strongly but buckles under compression, so the two directions have their own α.
#pragma once

#include <array>
#include <vector>

#include "components/constraint_graph.h"
#include "nucleon/types.h"

namespace nucleon {

struct StretchConstraints {
  std::vector<std::array<Index, 2>> particles;  // global particle indices
  std::vector<Real> restLength;                 // L0 from the object's rest shape
  std::vector<Real> stretchCompliance;          // α when L > L0 (m/N); 0 = inextensible
  std::vector<Real> compressionCompliance;      // α when L < L0
  std::vector<Real> lambda;                     // XPBD multiplier, reset every substep

  // Derived from `particles` when the topology changes (systems/constraint_graph_build.h).
  ParticleIncidence incidence;   // for the Jacobi gather
  ConstraintColoring coloring;   // for colored Gauss–Seidel
  std::vector<Vec3> correction;  // Jacobi scratch: one Δx per (constraint, end), 2 per constraint

  std::size_t size() const { return particles.size(); }

  void append(Index i, Index j, Real rest, Real stretchAlpha, Real compressionAlpha) {
    particles.push_back({i, j});
    restLength.push_back(rest);
    stretchCompliance.push_back(stretchAlpha);
    compressionCompliance.push_back(compressionAlpha);
    lambda.push_back(0);
  }
};

}  // namespace nucleon
