// Closest points between collision primitives, in double precision: the geometry of a contact's
// normal and interpolation weights (Ericson, Real-Time Collision Detection, 2005, §5.1.5 for a
// point and a triangle, §5.1.9 for two segments). Degenerate primitives (a zero-length edge, a
// zero-area triangle) fall back to their lower-dimensional parts, never to a division by zero.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "nucleon/types.h"

namespace nucleon {

// Parameter of the point of segment ab closest to p, in [0, 1].
inline double closestOnSegment(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  const Vec3d ab = b - a;
  const double len2 = ab.squaredNorm();
  if (!(len2 > 0)) return 0;
  return std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
}

// Barycentric weights (summing to 1) of the point of triangle abc closest to p, by Voronoi
// regions of the vertices, edges and face.
inline std::array<double, 3> closestOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                               const Vec3d& c) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const Vec3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0 && d1 - d3 > 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Vec3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0 && d2 - d6 > 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0 && (d4 - d3) + (d5 - d6) > 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double sum = va + vb + vc;
  if (sum > 0 && std::isfinite(sum)) {
    const double v = vb / sum, w = vc / sum;
    return {1 - v - w, v, w};
  }
  // A degenerate triangle: the closest of its three edges.
  std::array<double, 3> best{1, 0, 0};
  double bestDistance = (p - a).squaredNorm();
  const Vec3d corners[3] = {a, b, c};
  for (int e = 0; e < 3; ++e) {
    const Vec3d& u = corners[e];
    const Vec3d& q = corners[(e + 1) % 3];
    const double t = closestOnSegment(p, u, q);
    const double d = (p - (u + t * (q - u))).squaredNorm();
    if (d < bestDistance) {
      bestDistance = d;
      best = {0, 0, 0};
      best[e] = 1 - t;
      best[(e + 1) % 3] = t;
    }
  }
  return best;
}

// Parameters (s on p1q1, t on p2q2), each in [0, 1], of the closest points of two segments.
inline std::array<double, 2> closestBetweenSegments(const Vec3d& p1, const Vec3d& q1,
                                                    const Vec3d& p2, const Vec3d& q2) {
  const Vec3d d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  if (!(a > 0) && !(e > 0)) return {0, 0};
  if (!(a > 0)) return {0, std::clamp(f / e, 0.0, 1.0)};
  const double c = d1.dot(r);
  if (!(e > 0)) return {std::clamp(-c / a, 0.0, 1.0), 0};
  const double b = d1.dot(d2), denom = a * e - b * b;
  // Parallel segments (denom ≈ 0): any s works; take 0 and let t follow.
  double s = denom > 1e-14 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0) {
    t = 0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1) {
    t = 1;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  return {s, t};
}

}  // namespace nucleon
