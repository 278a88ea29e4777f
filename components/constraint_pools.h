// Every constraint pool of a world: one per built-in pool of the family table
// (NUCLEON_CONSTRAINT_FAMILIES in nucleon/constraint_family.h), then one per family an embedding
// program registered.
#pragma once

#include <vector>

#include "components/attachment_pool.h"
#include "components/constraint_pool.h"
#include "components/liquid_pool.h"
#include "components/pressure_pool.h"
#include "components/shape_match_pool.h"
#include "components/user_constraint_pool.h"
#include "nucleon/constraint_family.h"

namespace nucleon {

struct ConstraintPools {
#define NUCLEON_POOL(member, arity, Kernel, paths) ConstraintPool<arity> member;
#define NUCLEON_FAMILY_POOLS(enumerator, name, pools) pools
  NUCLEON_CONSTRAINT_FAMILIES(NUCLEON_FAMILY_POOLS)
#undef NUCLEON_FAMILY_POOLS
#undef NUCLEON_POOL

  // The pools of the families without table pools: one constraint per pressured surface, per
  // attachment and per rigid cluster.
  PressurePool pressure;
  AttachmentPool attachments;
  ShapeMatchPool shapeMatching;
  LiquidPool liquid;  // one density constraint per liquid particle

  // Registered families, in registration order: family kBuiltinFamilyCount + i is user[i].
  std::vector<UserConstraintPool> user;

  std::size_t familyCount() const {
    return kBuiltinFamilyCount + user.size();
  }

  // Calls f(pool) for every built-in pool, in table order.
  template <class F>
  void forEachBuiltin(F&& f) {
#define NUCLEON_POOL(member, arity, Kernel, paths) f(member);
#define NUCLEON_FAMILY_POOLS(enumerator, name, pools) pools
    NUCLEON_CONSTRAINT_FAMILIES(NUCLEON_FAMILY_POOLS)
#undef NUCLEON_FAMILY_POOLS
#undef NUCLEON_POOL
  }

  template <class F>
  void forEachBuiltin(F&& f) const {
#define NUCLEON_POOL(member, arity, Kernel, paths) f(member);
#define NUCLEON_FAMILY_POOLS(enumerator, name, pools) pools
    NUCLEON_CONSTRAINT_FAMILIES(NUCLEON_FAMILY_POOLS)
#undef NUCLEON_FAMILY_POOLS
#undef NUCLEON_POOL
  }

  // Calls f(pool) for every pool, built-in and registered.
  template <class F>
  void forEach(F&& f) {
    forEachBuiltin(f);
    for (UserConstraintPool& pool : user) f(pool);
  }
  template <class F>
  void forEach(F&& f) const {
    forEachBuiltin(f);
    for (const UserConstraintPool& pool : user) f(pool);
  }

  std::size_t count(ConstraintFamily family) const {
    std::size_t total = 0;
    switch (family) {
#define NUCLEON_POOL(member, arity, Kernel, paths) total += member.size();
#define NUCLEON_FAMILY_POOLS(enumerator, name, pools) \
  case ConstraintFamily::enumerator:                  \
    pools break;
      NUCLEON_CONSTRAINT_FAMILIES(NUCLEON_FAMILY_POOLS)
#undef NUCLEON_FAMILY_POOLS
#undef NUCLEON_POOL
      default: {
        const std::size_t u = familyIndex(family) - kBuiltinFamilyCount;
        if (u < user.size()) total = user[u].size();
      }
    }
    if (family == ConstraintFamily::Pressure) total = pressure.size();
    if (family == ConstraintFamily::Attachment) total = attachments.size();
    if (family == ConstraintFamily::Rigidity) total = shapeMatching.size();
    if (family == ConstraintFamily::Density) total = liquid.size();
    return total;
  }
};

}  // namespace nucleon
