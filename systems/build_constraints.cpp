#include "systems/build_constraints.h"

#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <vector>

#include "systems/constraint_kernels.h"

namespace nucleon {
namespace {

template <class Kernel, std::size_t N>
void appendMeasured(ConstraintPool<N>& pool, const std::array<Index, N>& local,
                    std::span<const Vec3> rest, Index first, Real compliance, Real damping) {
  Points<N> x, grad;
  std::array<Index, N> global;
  for (std::size_t k = 0; k < N; ++k) {
    x[k] = rest[local[k]];
    global[k] = first + local[k];
  }
  pool.append(global, Kernel::value(x, grad), compliance, compliance, damping);
}

// The vertex of triangle t that is neither a nor b.
Index opposite(const Simplex<2>& t, Index a, Index b) {
  for (Index v : t)
    if (v != a && v != b) return v;
  return a;
}

// The other end of edge e from vertex v.
Index otherEnd(const Simplex<1>& e, Index v) {
  return e[0] == v ? e[1] : e[0];
}

// True if the triangle (a, b, c) is too thin to define a plane: its area is below 1e-6 of the
// product of its two sides at b.
bool straight(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 u = a - b, v = c - b;
  return u.cross(v).norm() <= Real(1e-6) * u.norm() * v.norm();
}

void appendClothConstraints(ConstraintPools& pools, const SimplicialComplex& c,
                            std::span<const Vec3> rest, Index first, const Material& m) {
  if (m.shear)
    for (const Simplex<2>& t : c.triangles.vertices)
      for (int corner = 0; corner < 3; ++corner)
        appendMeasured<AngleKernel>(pools.shear,
                                    {t[(corner + 1) % 3], t[(corner + 2) % 3], t[corner]}, rest,
                                    first, m.shearCompliance, m.damping);
  if (!m.bending) return;
  // Hinges: for each interior edge (a, b), the triangle that runs a → b gives x2 and the one that
  // runs b → a gives x3, matching DihedralKernel's (x0, x1, x2), (x1, x0, x3).
  for (Index e = 0; e < c.edges.size(); ++e) {
    const auto parents = c.edges.parentsOf(e);
    if (parents.size() != 2) continue;
    const auto [a, b] = c.edges.vertices[e];
    const bool firstForward = parents[0].sign > 0;
    const Index x2 = opposite(c.triangles.vertices[parents[firstForward ? 0 : 1].face], a, b);
    const Index x3 = opposite(c.triangles.vertices[parents[firstForward ? 1 : 0].face], a, b);
    appendMeasured<DihedralKernel>(pools.bend, {a, b, x2, x3}, rest, first, m.bendCompliance,
                                   m.damping);
  }
}

void appendRopeConstraints(ConstraintPools& pools, const SimplicialComplex& c,
                           std::span<const Vec3> rest, Index first, const Material& m) {
  const auto& edges = c.edges.vertices;
  if (m.bending)
    for (Index v = 0; v < c.points.size(); ++v) {
      const auto incident = c.points.parentsOf(v);
      for (std::size_t i = 0; i < incident.size(); ++i)
        for (std::size_t j = i + 1; j < incident.size(); ++j)
          appendMeasured<AngleKernel>(
              pools.curveBend,
              {otherEnd(edges[incident[i].face], v), otherEnd(edges[incident[j].face], v), v}, rest,
              first, m.bendCompliance, m.damping);
    }
  if (m.twist)
    for (const Simplex<1>& middle : edges) {
      const auto [b, cEnd] = middle;
      for (const SignedFace& before : c.points.parentsOf(b))
        for (const SignedFace& after : c.points.parentsOf(cEnd)) {
          const Index a = otherEnd(edges[before.face], b), d = otherEnd(edges[after.face], cEnd);
          if (a == cEnd || d == b || a == d) continue;
          if (straight(rest[a], rest[b], rest[cEnd]) || straight(rest[b], rest[cEnd], rest[d]))
            continue;
          appendMeasured<DihedralKernel>(pools.twist, {b, cEnd, a, d}, rest, first,
                                         m.twistCompliance, m.damping);
        }
    }
}

// Path lengths along the edges from the nearest pin (Dijkstra from all pins at once). A path
// along edges is never shorter than the geodesic, so the limit never holds a vertex closer than
// the rest shape allows; on a triangulated grid it exceeds the straight distance by at most ~8%.
void appendTethers(ConstraintPools& pools, const SimplicialComplex& c, std::span<const Vec3> rest,
                   std::span<const Index> pins, Index first) {
  const std::size_t n = c.vertexCount();
  std::vector<double> distance(n, std::numeric_limits<double>::infinity());
  std::vector<Index> source(n, 0);
  using Entry = std::pair<double, Index>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (Index pin : pins) {
    distance[pin] = 0;
    source[pin] = pin;
    queue.push({0.0, pin});
  }
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > distance[v]) continue;
    for (const SignedFace& e : c.points.parentsOf(v)) {
      const Index u = otherEnd(c.edges.vertices[e.face], v);
      const double du = d + (rest[u] - rest[v]).cast<double>().norm();
      if (du < distance[u]) {
        distance[u] = du;
        source[u] = source[v];
        queue.push({du, u});
      }
    }
  }
  std::vector<bool> pinned(n, false);
  for (Index pin : pins) pinned[pin] = true;
  for (Index v = 0; v < n; ++v)
    if (!pinned[v] && std::isfinite(distance[v]))
      pools.tether.append({first + v, first + source[v]}, static_cast<Real>(distance[v]), 0, 0, 0);
}

}  // namespace

void appendObjectConstraints(ConstraintPools& pools, ObjectKind kind,
                             const SimplicialComplex& complex, std::span<const Vec3> rest,
                             std::span<const Index> pins, Index first, const Material& m) {
  if (kind == ObjectKind::Collider || kind == ObjectKind::Particles) return;
  for (const Simplex<1>& e : complex.edges.vertices) {
    Points<2> x = {rest[e[0]], rest[e[1]]}, grad;
    pools.stretch.append({first + e[0], first + e[1]}, DistanceKernel::value(x, grad),
                         m.stretchCompliance, m.compressionCompliance, m.damping);
  }
  switch (kind) {
    case ObjectKind::Cloth:
      appendClothConstraints(pools, complex, rest, first, m);
      if (m.tethers && m.stretchCompliance == 0 && !pins.empty())
        appendTethers(pools, complex, rest, pins, first);
      break;
    case ObjectKind::Rope:
      appendRopeConstraints(pools, complex, rest, first, m);
      if (m.tethers && m.stretchCompliance == 0 && !pins.empty())
        appendTethers(pools, complex, rest, pins, first);
      break;
    case ObjectKind::Solid:
      for (const Simplex<3>& t : complex.tets.vertices)
        appendMeasured<VolumeKernel>(pools.volume, t, rest, first, m.volumeCompliance, m.damping);
      break;
    default:
      break;
  }
}

}  // namespace nucleon
