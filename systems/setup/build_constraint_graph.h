// Builds the incidence table and the coloring of a constraint family from its particle tuples.
#pragma once

#include <array>
#include <span>

#include "components/constraint_graph.h"
#include "nucleon/types.h"

namespace nucleon {

// The particle tuples of a pool: constraint c acts on data[c·arity … c·arity + arity).
struct ParticleTuples {
  const Index* data = nullptr;
  std::size_t arity = 0;
  std::size_t count = 0;
  std::size_t size() const { return count; }
  std::span<const Index> operator[](std::size_t c) const { return {data + c * arity, arity}; }
};

// The tuples of a built-in pool of arity N, which stores them as packed arrays.
template <std::size_t N>
ParticleTuples tuplesOf(std::span<const std::array<Index, N>> constraints) {
  static_assert(sizeof(std::array<Index, N>) == N * sizeof(Index), "tuples must be packed");
  return {constraints.empty() ? nullptr : constraints.front().data(), N, constraints.size()};
}

// Per particle, the Jacobi slots (constraint c's particle k is slot c·arity + k) of its
// constraints, in increasing slot order.
ParticleIncidence buildIncidence(const ParticleTuples& constraints, std::size_t particleCount);

// Greedy coloring in constraint order: each constraint takes, among the colors none of its
// particles has yet, the one with the fewest constraints so far, so that colors come out balanced.
// At most kMaxColors colors; a constraint that fits none goes to a last, overflow range that the
// sweep runs serially (ConstraintColoring::overflow). Particles with inverse mass 0 (pins) are
// never written by a sweep, so constraints may share them within a color: thousands of tethers
// to one pin still color like independent constraints.
ConstraintColoring colorConstraints(const ParticleTuples& constraints, std::size_t particleCount,
                                    std::span<const Real> inverseMass = {});

// True if no two constraints of one color share a particle and every constraint appears once.
bool validateColoring(const ConstraintColoring& coloring, const ParticleTuples& constraints,
                      std::size_t particleCount, std::span<const Real> inverseMass = {});

// The same over a built-in pool's tuples.
template <std::size_t N>
ParticleIncidence buildIncidence(std::span<const std::array<Index, N>> constraints,
                                 std::size_t particleCount) {
  return buildIncidence(tuplesOf(constraints), particleCount);
}
template <std::size_t N>
ConstraintColoring colorConstraints(std::span<const std::array<Index, N>> constraints,
                                    std::size_t particleCount,
                                    std::span<const Real> inverseMass = {}) {
  return colorConstraints(tuplesOf(constraints), particleCount, inverseMass);
}
template <std::size_t N>
bool validateColoring(const ConstraintColoring& coloring,
                      std::span<const std::array<Index, N>> constraints, std::size_t particleCount,
                      std::span<const Real> inverseMass = {}) {
  return validateColoring(coloring, tuplesOf(constraints), particleCount, inverseMass);
}

}  // namespace nucleon
