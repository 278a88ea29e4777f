#include "systems/collision/pair_distance_lanes.h"

#include <algorithm>
#include <cmath>

// Built with -fno-math-errno and -fno-trapping-math (CMakeLists.txt), so that the square roots
// and the selects below stay vector instructions: the results are the same IEEE values either
// way. Each kernel is also built for AVX2 and AVX-512 and picked for the CPU at load time; the
// lanes are independent element-wise operations with no fused multiply-add (-ffp-contract=off),
// so every build gives the same bits.

namespace nucleon {
namespace {

struct P3 {
  float x, y, z;
};

[[gnu::always_inline]] inline P3 operator-(P3 a, P3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
[[gnu::always_inline]] inline float dot(P3 a, P3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
[[gnu::always_inline]] inline P3 cross(P3 a, P3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
[[gnu::always_inline]] inline float largest(P3 a) {
  return std::max(std::max(std::abs(a.x), std::abs(a.y)), std::abs(a.z));
}

// Squared distance from p to segment ab: the clamped projection (a zero-length segment
// divides by zero in a lane whose result is then not selected).
[[gnu::always_inline]] inline float pointSegmentSquared(P3 p, P3 a, P3 b) {
  const P3 e = b - a, w = p - a;
  const float ee = dot(e, e);
  const float t = ee > 0 ? std::clamp(dot(w, e) / ee, 0.0f, 1.0f) : 0.0f;
  const P3 d = {w.x - t * e.x, w.y - t * e.y, w.z - t * e.z};
  return dot(d, d);
}

// The sine² below which a triangle's face or the crossing of two edges is skipped: its
// distance is then within sin × (longest edge) of the edges' or the ends' distances, and the
// float rounding of the normal stays far below that.
constexpr float kSkippedSineSquared = 1e-6f;
// How far outside a face (in barycentric weight) its projection still counts as inside: the
// plane's distance is a lower bound on the face's, so erring inwards is safe.
constexpr float kInsideSlack = 1e-5f;

// Squared distance from the origin to triangle abc: the least of its edges' and, where the
// origin projects inside it, its plane's.
[[gnu::always_inline]] inline float originTriangleSquared(P3 a, P3 b, P3 c) {
  const P3 o = {0, 0, 0};
  const float edges = std::min(std::min(pointSegmentSquared(o, a, b), pointSegmentSquared(o, b, c)),
                               pointSegmentSquared(o, c, a));
  const P3 ab = b - a, ac = c - a;
  const P3 n = cross(ab, ac);
  const float nn = dot(n, n);
  // n · ((b − a) × (o − a)) and its turns: nn times the barycentric weights of the projection.
  const float wc = dot(n, cross(ab, o - a)), wa = dot(n, cross(c - b, o - b)),
              wb = dot(n, cross(a - c, o - c));
  const float slack = -kInsideSlack * nn;
  const bool inside = nn > kSkippedSineSquared * dot(ab, ab) * dot(ac, ac) && wa >= slack &&
                      wb >= slack && wc >= slack;
  const float h = dot(n, a);
  const float face = inside ? h * h / nn : edges;
  return std::min(edges, face);
}

// The conditioning and the margin of the closest-feature classification of two edges: the
// lines' closest points are trusted where sin² of the edges' angle is above kClassifySineSquared
// (their float error is then below 1e-4 of an edge for edges no farther apart than a few edge
// lengths), and counted inside or outside an edge only kClassifyMargin clear of its ends.
constexpr float kClassifySineSquared = 1e-4f;
constexpr float kClassifyMargin = 1e-3f;

// Squared distance between segments pq and rs: the least of the four ends' distances to the
// other segment and, where the lines' closest points lie inside both, theirs. `feature`: whether
// the closest points are inside both edges (kEdgeInteriors), at an end of one (kEdgeEnds: the
// lines' closest points lie outside one of them), or too near the border to tell (kUnknown).
[[gnu::always_inline]] inline float segmentSegmentSquared(P3 p, P3 q, P3 r, P3 s, float& feature) {
  const float ends = std::min(std::min(pointSegmentSquared(p, r, s), pointSegmentSquared(q, r, s)),
                              std::min(pointSegmentSquared(r, p, q), pointSegmentSquared(s, p, q)));
  const P3 d1 = q - p, d2 = s - r, w = r - p;
  const P3 n = cross(d1, d2);
  const float nn = dot(n, n), aa = dot(d1, d1), ee = dot(d2, d2);
  // The lines' closest points p + u d1 and r + v d2: u = ((r − p) × d2) · n / |n|², v likewise.
  const float u = dot(cross(w, d2), n) / nn, v = dot(cross(w, d1), n) / nn;
  const bool crossing = nn > kSkippedSineSquared * aa * ee && u >= 0 && u <= 1 && v >= 0 && v <= 1;
  const P3 gap = {w.x + v * d2.x - u * d1.x, w.y + v * d2.y - u * d1.y, w.z + v * d2.z - u * d1.z};
  const float inner = crossing ? dot(gap, gap) : ends;
  const bool conditioned = nn > kClassifySineSquared * aa * ee;
  const float lo = kClassifyMargin, hi = 1 - kClassifyMargin;
  const bool interiors = conditioned && u >= lo && u <= hi && v >= lo && v <= hi;
  const bool outside = conditioned && (u < -lo || u > 1 + lo || v < -lo || v > 1 + lo);
  feature = interiors ? float(kEdgeInteriors) : outside ? float(kEdgeEnds) : float(kUnknownFeature);
  return std::min(ends, inner);
}

[[gnu::always_inline]] inline P3 at(const float (&points)[4][3][kPairLanes], int k, int lane) {
  return {points[k][0][lane], points[k][1][lane], points[k][2][lane]};
}

[[gnu::always_inline]] inline float motionOf(const PairLanes& in, int k, int lane) {
  const P3 u = at(in.end, k, lane) - at(in.start, k, lane);
  return dot(u, u);
}

[[gnu::always_inline]] inline float extentOf(const PairLanes& in, int lane) {
  float most = 0;
  for (int k = 1; k < 4; ++k)
    most = std::max(most, std::max(largest(at(in.start, k, lane)), largest(at(in.end, k, lane))));
  return most;
}

}  // namespace

#if defined(__x86_64__)
#define NUCLEON_LANE_CLONES [[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#else
#define NUCLEON_LANE_CLONES
#endif

NUCLEON_LANE_CLONES void vertexFaceLaneBounds(const PairLanes& in, PairLaneBounds& out) {
#pragma omp simd
  for (int lane = 0; lane < kPairLanes; ++lane) {
    out.startDistance[lane] = std::sqrt(
        originTriangleSquared(at(in.start, 1, lane), at(in.start, 2, lane), at(in.start, 3, lane)));
    out.endDistance[lane] = std::sqrt(
        originTriangleSquared(at(in.end, 1, lane), at(in.end, 2, lane), at(in.end, 3, lane)));
    // The point is particle 0 itself: only the triangle's side moves relative to it.
    out.motion[lane] = std::sqrt(
        std::max(std::max(motionOf(in, 1, lane), motionOf(in, 2, lane)), motionOf(in, 3, lane)));
    out.extent[lane] = extentOf(in, lane);
    out.startFeature[lane] = out.endFeature[lane] = float(kUnknownFeature);
  }
}

NUCLEON_LANE_CLONES void edgeEdgeLaneBounds(const PairLanes& in, PairLaneBounds& out) {
  const P3 o = {0, 0, 0};
#pragma omp simd
  for (int lane = 0; lane < kPairLanes; ++lane) {
    out.startDistance[lane] =
        std::sqrt(segmentSegmentSquared(o, at(in.start, 1, lane), at(in.start, 2, lane),
                                        at(in.start, 3, lane), out.startFeature[lane]));
    out.endDistance[lane] = std::sqrt(segmentSegmentSquared(
        o, at(in.end, 1, lane), at(in.end, 2, lane), at(in.end, 3, lane), out.endFeature[lane]));
    out.motion[lane] = std::sqrt(motionOf(in, 1, lane)) +
                       std::sqrt(std::max(motionOf(in, 2, lane), motionOf(in, 3, lane)));
    out.extent[lane] = extentOf(in, lane);
  }
}

}  // namespace nucleon
