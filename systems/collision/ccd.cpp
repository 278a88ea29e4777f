// Conservative advancement with certified separating planes (ccd.h states the method).
//
// Rounding error bound (Higham 2002, "Accuracy and Stability of Numerical Algorithms", §3.1,
// γ_n = n u / (1 − n u)), for inputs with |coordinate| ≤ M and a direction with |n_j| ≤ 1:
//   V = fl(P0 − Q0), W = fl(P1 − Q1): |·| ≤ 2M, error ≤ 2Mu each;
//   D = fl(W − V): |·| ≤ 4M, error ≤ 4Mu + 2Mu + 2Mu = 8Mu;
//   α = fl(n·V): γ_3 Σ|n_j||V_j| ≤ 18Mu, plus Σ|n_j| 2Mu = 6Mu from V's error: 24Mu;
//   β = fl(n·D): γ_3 · 12M = 36Mu, plus Σ|n_j| 8Mu = 24Mu: 60Mu;
//   g = fl(α + fl(t β)), t ∈ [0, 1]: |tβ| ≤ 12M rounds by 12Mu, the sum (≤ 18M) by 18Mu, and
//   t times β's error adds at most 60Mu: in all 24 + 60 + 12 + 18 = 114Mu to first order.
// kRoundingFactor = 256 covers that bound with room for the second-order terms.
#include "systems/collision/ccd.h"

#include <algorithm>
#include <cmath>

#include "systems/collision/primitive_distance.h"

namespace nucleon {
namespace {

constexpr double kUnitRoundoff = 0x1p-53;
constexpr double kRoundingFactor = 256;
// Rounds a positive threshold up past the few roundings of its own computation (|n|, d |n|, +).
constexpr double kRoundUp = 1 + 0x1p-40;
// Attempts to halve a step whose far end fails its check before giving up on the plane.
constexpr int kStepShrinks = 4;

double maxAbs(const Vec3d& v) {
  return std::max({std::abs(v.x()), std::abs(v.y()), std::abs(v.z())});
}

// The closest point to the origin of conv{X_0..X_{K−1}}: the vertex set of the difference
// polytope (ccd.h), K = 1 vertex–vertex, 2 vertex–edge, 3 vertex–face, 4 edge–edge with the
// vertices ordered a−c, a−d, b−c, b−d.
template <int K>
Vec3d closestToOrigin(const Vec3d (&x)[K]) {
  const Vec3d origin = Vec3d::Zero();
  if constexpr (K == 1) {
    return x[0];
  } else if constexpr (K == 2) {
    const double s = closestOnSegment(origin, x[0], x[1]);
    return x[0] + s * (x[1] - x[0]);
  } else if constexpr (K == 3) {
    const auto w = closestOnTriangle(origin, x[0], x[1], x[2]);
    return w[0] * x[0] + w[1] * x[1] + w[2] * x[2];
  } else {
    // F(s, w) = (a−c) + s ((b−c) − (a−c)) − w ((a−c) − (a−d)): the segment from a−c to b−c
    // against the segment from 0 to (a−c) − (a−d).
    const Vec3d toB = x[2] - x[0], toD = x[0] - x[1];
    const auto sw = closestBetweenSegments(x[0], x[2], origin, toD);
    return x[0] + sw[0] * toB - sw[1] * toD;
  }
}

template <int K>
CcdResult advance(const Vec3d (&start)[K], const Vec3d (&end)[K], double inputBound,
                  double distance, const CcdSettings& settings) {
  if (!(distance >= 0) || !std::isfinite(distance) || !std::isfinite(inputBound)) return {true, 0};
  const double rounding = kRoundingFactor * kUnitRoundoff * inputBound + 1e-300;

  Vec3d motion[K];
  double extent = 0;
  for (int i = 0; i < K; ++i) {
    motion[i] = end[i] - start[i];
    extent = std::max({extent, maxAbs(start[i]), maxAbs(end[i])});
  }

  // Swept bounding boxes: every value of F lies in conv{start_i, end_i}, so a coordinate whose
  // range over those points misses [−d, d] separates the pair over the whole step.
  const double reach = distance * kRoundUp + rounding;
  for (int axis = 0; axis < 3; ++axis) {
    double lo = start[0][axis], hi = start[0][axis];
    for (int i = 0; i < K; ++i) {
      lo = std::min({lo, start[i][axis], end[i][axis]});
      hi = std::max({hi, start[i][axis], end[i][axis]});
    }
    if (lo > reach || hi < -reach) return {false, 1};
  }

  const double accept = distance + settings.tolerance * extent;
  double t = 0;
  for (int iteration = 0; iteration < settings.maxIterations; ++iteration) {
    Vec3d now[K];
    for (int i = 0; i < K; ++i) now[i] = start[i] + t * motion[i];
    const Vec3d closest = closestToOrigin<K>(now);
    const double scale = maxAbs(closest);
    if (!(scale > 0) || closest.norm() <= accept) return {true, t};

    // The plane n·F = d|n| with n ∝ closest, scaled so that |n_j| ≤ 1 as the error bound assumes.
    const Vec3d n = closest / scale;
    const double normUp = std::sqrt(n.squaredNorm()) * kRoundUp;
    const double threshold = (distance * normUp + rounding) * kRoundUp;
    double offset[K], slope[K];
    double next = 1;
    for (int i = 0; i < K; ++i) {
      offset[i] = n.dot(start[i]);
      slope[i] = n.dot(motion[i]);
      // The plane must separate at t itself; otherwise the closest point estimate is worse than
      // the rounding bound (a degenerate primitive) and the answer is a conservative hit.
      if (!(offset[i] + t * slope[i] > threshold)) return {true, t};
      // Where this vertex's lower bound reaches the threshold, less a rounding bound of slack so
      // that the far end passes its check below.
      if (slope[i] < 0) next = std::min(next, (offset[i] - threshold - rounding) / -slope[i]);
    }
    if (!(next > t)) {
      double exact = 1;
      for (int i = 0; i < K; ++i)
        if (slope[i] < 0) exact = std::min(exact, (offset[i] - threshold) / -slope[i]);
      next = t + 0.5 * (exact - t);
    }
    // Each bound is linear in t, so holding at both ends of [t, next] certifies all of it.
    bool certified = false;
    for (int shrink = 0; shrink < kStepShrinks && next > t; ++shrink) {
      certified = true;
      for (int i = 0; i < K; ++i) certified = certified && offset[i] + next * slope[i] > threshold;
      if (certified) break;
      next = t + 0.5 * (next - t);
    }
    if (!certified || !(next > t)) return {true, t};
    if (next >= 1) return {false, 1};
    t = next;
  }
  return {true, t};
}

double maxAbsOf(std::initializer_list<const Vec3d*> points) {
  double bound = 0;
  for (const Vec3d* p : points) bound = std::max(bound, maxAbs(*p));
  return bound;
}

}  // namespace

CcdResult vertexFaceCcd(const Vec3d& p0, const Vec3d& a0, const Vec3d& b0, const Vec3d& c0,
                        const Vec3d& p1, const Vec3d& a1, const Vec3d& b1, const Vec3d& c1,
                        double distance, const CcdSettings& settings) {
  const Vec3d start[3] = {p0 - a0, p0 - b0, p0 - c0};
  const Vec3d end[3] = {p1 - a1, p1 - b1, p1 - c1};
  return advance<3>(start, end, maxAbsOf({&p0, &a0, &b0, &c0, &p1, &a1, &b1, &c1}), distance,
                    settings);
}

CcdResult edgeEdgeCcd(const Vec3d& a0, const Vec3d& b0, const Vec3d& c0, const Vec3d& d0,
                      const Vec3d& a1, const Vec3d& b1, const Vec3d& c1, const Vec3d& d1,
                      double distance, const CcdSettings& settings) {
  const Vec3d start[4] = {a0 - c0, a0 - d0, b0 - c0, b0 - d0};
  const Vec3d end[4] = {a1 - c1, a1 - d1, b1 - c1, b1 - d1};
  return advance<4>(start, end, maxAbsOf({&a0, &b0, &c0, &d0, &a1, &b1, &c1, &d1}), distance,
                    settings);
}

CcdResult vertexEdgeCcd(const Vec3d& p0, const Vec3d& a0, const Vec3d& b0, const Vec3d& p1,
                        const Vec3d& a1, const Vec3d& b1, double distance,
                        const CcdSettings& settings) {
  const Vec3d start[2] = {p0 - a0, p0 - b0};
  const Vec3d end[2] = {p1 - a1, p1 - b1};
  return advance<2>(start, end, maxAbsOf({&p0, &a0, &b0, &p1, &a1, &b1}), distance, settings);
}

CcdResult vertexVertexCcd(const Vec3d& p0, const Vec3d& q0, const Vec3d& p1, const Vec3d& q1,
                          double distance, const CcdSettings& settings) {
  const Vec3d start[1] = {p0 - q0};
  const Vec3d end[1] = {p1 - q1};
  return advance<1>(start, end, maxAbsOf({&p0, &q0, &p1, &q1}), distance, settings);
}

}  // namespace nucleon
