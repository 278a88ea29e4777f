#include "systems/setup/geodesic_distance.h"

#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

namespace nucleon {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The distance at c of a source at distances da from a and db from b, unfolded into the plane of
// triangle (a, b, c) on the side of ab away from c; +∞ when the segment from the source to c
// misses ab (then the straight path does not run through this triangle) or when no point has
// those distances (the two values come from different unfoldings).
double unfoldedDistance(const Vec3d& a, const Vec3d& b, const Vec3d& c, double da, double db) {
  const Vec3d edge = b - a;
  const double length = edge.norm();
  if (!(length > 0)) return kInfinity;
  const Vec3d along = edge / length;
  const Vec3d toC = c - a;
  const double cx = toC.dot(along);
  const double cy = (toC - cx * along).norm();
  if (!(cy > 1e-12 * length)) return kInfinity;  // degenerate triangle
  // Source s = (sx, sy) with |s| = da and |s − b| = db; sy ≤ 0 puts it across ab from c.
  const double sx = (da * da - db * db + length * length) / (2 * length);
  double sy2 = da * da - sx * sx;
  if (sy2 < -1e-9 * length * length) return kInfinity;
  const double sy = -std::sqrt(std::max(sy2, 0.0));
  // Where the segment s → c meets the line of ab: it must lie on the edge itself.
  const double t = -sy / (cy - sy);
  const double crossing = sx + t * (cx - sx);
  const double slack = 1e-9 * length;
  if (crossing < -slack || crossing > length + slack) return kInfinity;
  return std::hypot(cx - sx, cy - sy);
}

Index otherEnd(const Simplex<1>& e, Index v) {
  return e[0] == v ? e[1] : e[0];
}

Index thirdVertex(const Simplex<2>& t, Index a, Index b) {
  for (Index v : t)
    if (v != a && v != b) return v;
  return t[0];
}

}  // namespace

void geodesicDistances(const SimplicialComplex& complex, std::span<const Vec3> rest,
                       std::span<const Index> sources, std::span<const std::uint8_t> allowed,
                       GeodesicField& field) {
  const std::size_t n = complex.vertexCount();
  field.distance.assign(n, kInfinity);
  field.source.assign(n, 0);
  std::vector<std::uint8_t> settled(n, 0);
  auto position = [&](Index v) -> Vec3d { return rest[v].cast<double>(); };
  auto open = [&](Index v) { return !settled[v] && (allowed.empty() || allowed[v] != 0); };

  using Entry = std::pair<double, Index>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  auto offer = [&](Index v, double d, Index source) {
    if (!(d < field.distance[v])) return;
    field.distance[v] = d;
    field.source[v] = source;
    queue.push({d, v});
  };
  for (Index s : sources)
    if (s < n) {
      field.distance[s] = 0;
      field.source[s] = s;
      queue.push({0.0, s});
    }

  const auto& edges = complex.edges;
  const auto& triangles = complex.triangles.vertices;
  const bool hasTriangles = !triangles.empty() && !edges.parentOffset.empty();
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (settled[v] || d != field.distance[v]) continue;  // stale entry
    settled[v] = 1;
    const Vec3d pv = position(v);
    for (const SignedFace& e : complex.points.parentsOf(v)) {
      const Index u = otherEnd(edges.vertices[e.face], v);
      if (open(u)) offer(u, d + (position(u) - pv).norm(), field.source[v]);
      // Triangles whose other settled vertex shares v's source offer their third vertex the
      // unfolded straight path (only the last of the two to settle does this, so once each).
      if (!hasTriangles || !settled[u] || u == v || field.source[u] != field.source[v]) continue;
      for (const SignedFace& t : edges.parentsOf(e.face)) {
        const Index c = thirdVertex(triangles[t.face], v, u);
        if (!open(c)) continue;
        offer(c, unfoldedDistance(pv, position(u), position(c), d, field.distance[u]),
              field.source[v]);
      }
    }
  }
}

}  // namespace nucleon
