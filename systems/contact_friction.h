// Position-based Coulomb friction for a particle just pushed out of a static surface (Macklin et
// al. 2014, §6): the tangential part of the substep's motion is undone if it is below μ_s times
// the penetration depth (sticking), otherwise shortened by μ_k times the depth (sliding).
#pragma once

#include <algorithm>

#include "nucleon/types.h"

namespace nucleon {

// p: the particle's position after the push-out; x: its position at the start of the substep;
// normal: the unit surface normal at the contact; depth: how far the push-out moved it.
inline void applyContactFriction(Vec3& p, const Vec3& x, const Vec3& normal, Real depth,
                                 Real staticFriction, Real friction) {
  const Vec3 motion = p - x;
  const Vec3 slide = motion - normal * normal.dot(motion);
  const Real length = slide.norm();
  if (length <= staticFriction * depth)
    p -= slide;
  else
    p -= slide * std::min(Real(1), friction * depth / length);
}

}  // namespace nucleon
