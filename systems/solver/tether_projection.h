// Where a free vertex goes when its tethers are projected: onto one limit, or onto two at once.
//
// A vertex's tethers are balls |x − c| ≤ r about pins that no sweep moves. Projecting onto them
// one after the other is alternating projection, which converges linearly at a rate set by the
// angle between the two spheres, and not at all in finitely many steps where they touch: on the
// top edge of a cloth hung from two corners exactly its width apart, each vertex's two balls
// meet in a single point, and with sequential projection that edge held the most stretched
// edges of the cloth (a standalone model of the 256² hanging cloth with the multigrid cascade,
// 120 frames: 19% on the top row; with the pair projection the top row left the eight worst
// edges, and the worst was 15%, at the free bottom corner). The closest point of the two
// balls is found directly instead: it is the projection onto one ball when that lies in the
// other, and otherwise the closest point of the circle where the two spheres meet (a point
// where they touch). A vertex's tethers are then taken two at a time, the projection onto a
// convex set it must satisfy, which any Gauss–Seidel sweep over its block of constraints is.
#pragma once

#include <algorithm>
#include <cmath>

#include "nucleon/types.h"

namespace nucleon {

namespace tether_detail {
constexpr Real kTiny = Real(1e-12);
// A point counts as inside a ball up to this relative slack, so that a projection that lands on
// the sphere, rounded, still counts as inside.
constexpr Real kInsideSlack = Real(1e-6);
}  // namespace tether_detail

// Whether |x − c| ≤ r holds with a margin that rounding cannot cross: then projectOntoTether
// returns x, and projectOntoTetherPair returns x when it holds for both balls. A test on the
// squared distance, without the square root, for sweeps where most vertices are inside.
inline bool surelyInsideTether(const Vec3& x, const Vec3& c, Real r) {
  return (x - c).squaredNorm() < r * r * (1 - 16 * tether_detail::kInsideSlack);
}

// The closest point to x with |x − c| ≤ r.
inline Vec3 projectOntoTether(const Vec3& x, const Vec3& c, Real r) {
  const Vec3 d = x - c;
  const Real length = d.norm();
  if (!(length > r) || length < tether_detail::kTiny) return x;
  return x - d * ((length - r) / length);
}

// The closest point to x with |x − a| ≤ ra and |x − b| ≤ rb. When the balls are disjoint (pins
// that moved apart farther than the two limits allow) it returns the point of the axis between
// them where the two spheres' powers are equal, a compromise that neither limit can reach.
inline Vec3 projectOntoTetherPair(const Vec3& x, const Vec3& a, Real ra, const Vec3& b, Real rb) {
  using tether_detail::kInsideSlack;
  const Vec3 qa = projectOntoTether(x, a, ra);
  if ((qa - b).norm() <= rb * (1 + kInsideSlack)) return qa;
  const Vec3 qb = projectOntoTether(x, b, rb);
  if ((qb - a).norm() <= ra * (1 + kInsideSlack)) return qb;
  // Both spheres' projections leave the other ball: the answer is on the circle where the
  // spheres meet, centre m on the axis at distance s from a, radius ρ = √(ra² − s²).
  const Vec3 axis = b - a;
  const Real distance = axis.norm();
  if (distance < tether_detail::kTiny) return qa;
  const Vec3 u = axis / distance;
  const Real s = (distance * distance + ra * ra - rb * rb) / (2 * distance);
  const Real radius = std::sqrt(std::max(ra * ra - s * s, Real(0)));
  const Vec3 m = a + s * u;
  const Vec3 offset = (x - m) - u * (x - m).dot(u);
  const Real length = offset.norm();
  return length > tether_detail::kTiny ? Vec3(m + offset * (radius / length)) : m;
}

}  // namespace nucleon
