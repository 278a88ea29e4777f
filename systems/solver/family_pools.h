// From a constraint family to its pools and their kernels, derived from the family table
// (NUCLEON_CONSTRAINT_FAMILIES in nucleon/constraint_family.h): the one place that maps them.
#pragma once

#include "components/constraint_pools.h"
#include "systems/solver/constraint_kernels.h"
#include "systems/solver/constraint_sweeps.h"
#include "systems/solver/sweep_paths.h"

namespace nucleon {

// A pool's kernel and sweep paths, as a tag for generic lambdas.
template <class KernelType, unsigned PathSet>
struct PoolKernel {
  using Kernel = KernelType;
  static constexpr unsigned kPaths = PathSet;
};

// Calls f(pool, PoolKernel<Kernel, paths>{}) for each pool of `family`: the table's pools of a
// built-in family, the registered pool of a user family (Kernel = UserKernel).
template <class Pools, class F>
void forEachPoolOf(ConstraintFamily family, Pools& pools, F&& f) {
  switch (family) {
#define NUCLEON_POOL(member, arity, KernelName, paths) \
  f(pools.member, PoolKernel<KernelName, (paths)>{});
#define NUCLEON_FAMILY_POOLS(enumerator, name, poolList) \
  case ConstraintFamily::enumerator:                     \
    poolList break;
    NUCLEON_CONSTRAINT_FAMILIES(NUCLEON_FAMILY_POOLS)
#undef NUCLEON_FAMILY_POOLS
#undef NUCLEON_POOL
    default: {
      const std::size_t u = familyIndex(family) - kBuiltinFamilyCount;
      if (u < pools.user.size()) f(pools.user[u], PoolKernel<UserKernel, kGenericSweep>{});
    }
  }
}

// Calls f(pool, PoolKernel<Kernel, paths>{}) for every pool, built-in and registered.
template <class Pools, class F>
void forEachPoolWithKernel(Pools& pools, F&& f) {
  for (std::size_t family = 0; family < pools.familyCount(); ++family)
    forEachPoolOf(static_cast<ConstraintFamily>(family), pools, f);
}

}  // namespace nucleon
