// The pool of one constraint family that an embedding program registered
// (nucleon/user_constraint.h): the family's definition, the constraints' particles and rest data
// with a run-time arity, their parameters, and the same derived state as a built-in pool.
#pragma once

#include <vector>

#include "components/constraint_pool.h"
#include "nucleon/user_constraint.h"

namespace nucleon {

struct UserConstraintSettings : ConstraintParameters {
  UserConstraintFamilyDef family;
  std::vector<Index> particles;  // `family.arity` global particle indices per constraint
  std::vector<Real> rest;        // `family.restSize` values per constraint
};

struct UserConstraintPool : UserConstraintSettings, ConstraintSolveState {
  std::size_t size() const { return this->compliance.size(); }
  std::size_t arity() const { return family.arity; }
  Index particle(std::size_t c, std::size_t k) const { return particles[c * family.arity + k]; }
  const Real* restOf(std::size_t c) const { return rest.data() + c * family.restSize; }

  // Keeps the constraints c for which keep(c) holds, in their order.
  template <class Keep>
  void retain(Keep keep) {
    const std::size_t arity = family.arity, restSize = family.restSize;
    std::size_t kept = 0;
    for (std::size_t c = 0; c < size(); ++c) {
      if (!keep(c)) continue;
      for (std::size_t j = 0; j < arity; ++j)
        particles[kept * arity + j] = particles[c * arity + j];
      for (std::size_t j = 0; j < restSize; ++j) rest[kept * restSize + j] = rest[c * restSize + j];
      compliance[kept] = compliance[c];
      compressionCompliance[kept] = compressionCompliance[c];
      damping[kept] = damping[c];
      lambda[kept] = lambda[c];
      ++kept;
    }
    particles.resize(kept * arity);
    rest.resize(kept * restSize);
    compliance.resize(kept);
    compressionCompliance.resize(kept);
    damping.resize(kept);
    lambda.resize(kept);
  }

  // Reorders the constraints so that the one at order[k] moves to k (colored Gauss–Seidel stores
  // a pool in color order).
  void permute(const std::vector<Index>& order) {
    auto apply = [&](auto& column, std::size_t width) {
      auto old = column;
      for (std::size_t k = 0; k < order.size(); ++k)
        for (std::size_t j = 0; j < width; ++j) column[k * width + j] = old[order[k] * width + j];
    };
    apply(particles, family.arity);
    apply(rest, family.restSize);
    apply(compliance, 1);
    apply(compressionCompliance, 1);
    apply(damping, 1);
    apply(lambda, 1);
  }
};

}  // namespace nucleon
