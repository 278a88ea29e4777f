#include "systems/setup/build_constraints.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <queue>
#include <tuple>
#include <vector>

#include "systems/setup/geodesic_distance.h"
#include "systems/solver/constraint_kernels.h"

namespace nucleon {
namespace {

// A constraint's particles in the object's rest shape, and their global indices.
template <std::size_t N>
struct RestConstraint {
  Points<N> x;
  std::array<Index, N> global;
  RestConstraint(const std::array<Index, N>& local, std::span<const Vec3> rest, Index first) {
    for (std::size_t k = 0; k < N; ++k) {
      x[k] = rest[local[k]];
      global[k] = first + local[k];
    }
  }
};

template <class Kernel, std::size_t N>
void appendMeasured(ConstraintPool<N>& pool, const std::array<Index, N>& local,
                    std::span<const Vec3> rest, Index first, Real compliance, Real damping) {
  const RestConstraint<N> r(local, rest, first);
  Points<N> grad;
  pool.append(r.global, Kernel::value(r.x, grad), compliance, compliance, damping);
}

// A hinge flat at rest in the isometric form (IsometricBendKernel); false, and nothing appended,
// where its rest shape is bent (beyond 1e-3 rad, where C = 2 sin(|φ|/2) would no longer be zero
// at rest: that hinge keeps the dihedral angle) or a triangle has no height over the edge.
bool appendIsometric(ConstraintPool<4>& pool, const std::array<Index, 4>& local,
                     std::span<const Vec3> rest, Index first, const Material& m) {
  const RestConstraint<4> r(local, rest, first);
  Points<4> grad;
  std::array<Real, 4> weights;
  if (std::abs(DihedralKernel::value(r.x, grad)) > Real(1e-3) ||
      !IsometricBendKernel::weightsOf(r.x, weights))
    return false;
  pool.append(r.global, 0, m.bendCompliance, m.bendCompliance, m.damping, weights);
  return true;
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
    if (m.bendModel == BendModel::Isometric &&
        appendIsometric(pools.isometricBend, {a, b, x2, x3}, rest, first, m))
      continue;
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

// Long-range attachments (Kim, Chentanez and Müller 2012): each free vertex is tethered to the
// attachment points with its geodesic distance in the rest shape as the limit: the longest reach
// the vertex has while the material between stays unstretched, or stretched by no more than
// `strain` (Material::stretchLimit), whose factor 1 + strain every limit carries.
//
// Tethering each vertex to its nearest pin only splits a cloth held at separate points: along
// the line where the nearest pin changes, neighbours hang from different pins, only the
// unconverged stretch sweeps hold them together, and the seam opens (a 128² cloth hung from two
// corners by 10 colored sweeps: edges across it at 0.65 mean strain against 0.13 elsewhere, the
// worst at six times its length). As in the paper, a vertex is therefore tethered to several
// attachment points, with a bounded count:
//  - Pins joined by edges form one cluster (a pinned row, a clamped patch). Within a cluster
//    the nearest pin of neighbouring vertices is the same or a neighbouring pin, so it opens no
//    seam, and the nearest pin of each cluster is enough: a pinned row of 128 vertices gives one
//    tether per vertex, not 128.
//  - A vertex takes its kMaxClusters nearest clusters. Across a seam both sides then share the
//    tethers of every cluster meeting there; four is the most that meet at a point of the
//    common layouts (the middle of a cloth held at its four corners, where three left a
//    strain of 2.4 and four 0.8). Farther clusters are not cut off by their path length: on
//    the taut top edge of a cloth hung from two corners the far pin's limit binds even next to
//    the near pin, and every cut tried moved the peak strain to the cut (1.6–2.4 against 0.94).
//  - A cluster whose pin is closer to the nearest pin than kSpread times the vertex's path to
//    it adds little: seen from the vertex the two pins are about 14° apart or less, and their
//    limits are nearly concentric spheres whose radii differ by at most the pins' distance. It
//    is left out, which drops most tethers of a row of separate hooks (every fourth vertex of a
//    128² cloth: 1.5 tethers per vertex instead of 4, max strain 0.52 instead of 0.79) and none
//    of pins at the corners.
// One Dijkstra run from all pins settles each vertex once per cluster, nearest first, up to
// kMaxClusters of them. It is exact: a cluster's shortest path to v passes only through vertices
// that also have that cluster among their nearest (else v would have kMaxClusters nearer ones).
// Each vertex keeps its best candidate path per cluster and skips a longer one, as plain
// Dijkstra does, and skips any path longer than kMaxClusters paths from other clusters, so the
// run costs about kMaxClusters plain ones however many pins there are.
constexpr std::size_t kMaxClusters = 4;
constexpr double kSpread = 0.25;

void appendTethers(ConstraintPools& pools, const SimplicialComplex& c, std::span<const Vec3> rest,
                   std::span<const Index> pins, Index first, double strain) {
  const std::size_t n = c.vertexCount();
  const auto& edges = c.edges.vertices;
  auto length = [&](Index u, Index v) { return (rest[u] - rest[v]).cast<double>().norm(); };

  // Clusters: connected components of the pins along edges whose ends are both pinned.
  constexpr Index kNone = std::numeric_limits<Index>::max();
  std::vector<Index> cluster(n, kNone), stack;
  std::vector<bool> pinned(n, false);
  for (Index pin : pins) pinned[pin] = true;
  Index clusters = 0;
  for (Index pin : pins) {
    if (cluster[pin] != kNone) continue;
    cluster[pin] = clusters;
    stack.assign(1, pin);
    while (!stack.empty()) {
      const Index v = stack.back();
      stack.pop_back();
      for (const SignedFace& e : c.points.parentsOf(v)) {
        const Index u = otherEnd(edges[e.face], v);
        if (pinned[u] && cluster[u] == kNone) {
          cluster[u] = clusters;
          stack.push_back(u);
        }
      }
    }
    ++clusters;
  }

  // Per vertex, up to `slots` paths from distinct clusters: the shortest known so far, final
  // once settled. A queue entry (length, vertex, pin) is current while its vertex still holds
  // that path; ties break on the indices, so the result does not depend on the queue.
  const std::size_t slots = std::min<std::size_t>(kMaxClusters, clusters);
  struct Path {
    double length;
    Index pin;
    bool settled;
  };
  std::vector<Path> paths(n * slots);
  std::vector<std::uint8_t> count(n, 0);
  auto find = [&](Index v, Index k) -> Path* {
    for (std::size_t s = 0; s < count[v]; ++s)
      if (cluster[paths[v * slots + s].pin] == k) return &paths[v * slots + s];
    return nullptr;
  };
  using Entry = std::tuple<double, Index, Index>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  // Offers v a path of length d from `pin`; true if v keeps it.
  auto offer = [&](Index v, double d, Index pin) {
    const Index k = cluster[pin];
    Path* same = find(v, k);
    if (same) {
      if (same->settled || same->length <= d) return false;
      *same = {d, pin, false};
      return true;
    }
    if (count[v] < slots) {
      paths[v * slots + count[v]++] = {d, pin, false};
      return true;
    }
    // Full: the path replaces the longest open one if shorter. Settled paths are never longer
    // than d, so if none is open, v already has its nearest clusters.
    Path* longest = nullptr;
    for (std::size_t s = 0; s < slots; ++s) {
      Path& p = paths[v * slots + s];
      if (!p.settled && (!longest || p.length > longest->length)) longest = &p;
    }
    if (!longest || longest->length <= d) return false;
    *longest = {d, pin, false};
    return true;
  };
  for (Index pin : pins)
    if (offer(pin, 0.0, pin)) queue.push({0.0, pin, pin});
  while (!queue.empty()) {
    const auto [d, v, pin] = queue.top();
    queue.pop();
    Path* path = find(v, cluster[pin]);
    if (!path || path->settled || path->length != d || path->pin != pin) continue;  // stale
    path->settled = true;
    for (const SignedFace& e : c.points.parentsOf(v)) {
      const Index u = otherEnd(edges[e.face], v);
      const double du = d + length(u, v);
      if (offer(u, du, pin)) queue.push({du, u, pin});
    }
  }

  // The limits: a path along edges overshoots the geodesic (by 8% on a grid whose diagonals
  // alternate, by 41% along the diagonal they all miss), and a tether that much too long leaves
  // the cloth that much longer: cloth_hang_256 under 10 colored sweeps hung at 16% mean strain
  // with path limits and 8% with straight ones. So the paths pick each vertex's clusters and the
  // limit is the geodesic distance to the cluster's nearest pin, spread through the vertices
  // that keep that cluster; never below the straight distance in the rest shape, a bound that
  // no motion keeping the edge lengths can exceed.
  std::vector<std::vector<Index>> members(clusters), clusterPins(clusters);
  for (Index pin : pins) clusterPins[cluster[pin]].push_back(pin);
  for (Index v = 0; v < n; ++v)
    for (std::size_t s = 0; s < count[v]; ++s)
      members[cluster[paths[v * slots + s].pin]].push_back(v);
  std::vector<std::uint8_t> allowed(n, 0);
  GeodesicField field;
  for (Index k = 0; k < clusters; ++k) {
    if (members[k].empty()) continue;
    for (Index v : members[k]) allowed[v] = 1;
    geodesicDistances(c, rest, clusterPins[k], allowed, field);
    for (Index v : members[k]) {
      allowed[v] = 0;
      Path* path = find(v, k);
      if (!path || !std::isfinite(field.distance[v])) continue;
      path->pin = field.source[v];
      path->length = std::max(field.distance[v], length(v, path->pin));
    }
  }

  for (Index v = 0; v < n; ++v) {
    if (pinned[v]) continue;
    Path* begin = paths.data() + v * slots;
    std::sort(begin, begin + count[v], [](const Path& a, const Path& b) {
      return a.length < b.length || (a.length == b.length && a.pin < b.pin);
    });
    for (const Path* p = begin; p != begin + count[v]; ++p)
      if (p == begin || length(p->pin, begin->pin) > kSpread * begin->length)
        pools.tether.append({first + v, first + p->pin},
                            static_cast<Real>(p->length * (1 + strain)), 0, 0, 0);
  }
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
      if (m.tethers && m.longRangeStrain() >= 0 && !pins.empty())
        appendTethers(pools, complex, rest, pins, first, m.longRangeStrain());
      break;
    case ObjectKind::Rope:
      appendRopeConstraints(pools, complex, rest, first, m);
      if (m.tethers && m.longRangeStrain() >= 0 && !pins.empty())
        appendTethers(pools, complex, rest, pins, first, m.longRangeStrain());
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
