#include "systems/topology/tear_cloth.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <span>
#include <unordered_map>

#include "systems/diagnostics/triangle_intersections.h"
#include "systems/setup/build_constraints.h"

namespace nucleon {

namespace {

// Over-stretch clocks are compared with some room, so that a time of k steps is reached after k
// steps despite the rounding of the summed step lengths.
constexpr double kClockRoom = 1e-6;
// A split moves the two copies apart along the torn edge by this share of its rest length: lips
// that start exactly coincident would touch, and the exact intersection count (which knows
// vertices, not their copies) would count every pair of triangles that meet only there.
constexpr double kOpeningShare = 1e-3;

std::uint64_t edgeKey(Index a, Index b) {
  return a < b ? (std::uint64_t{a} << 32 | b) : (std::uint64_t{b} << 32 | a);
}

Vec3d at(const std::vector<Vec3>& x, Index i) {
  return x[i].cast<double>();
}

// The triangles around each local vertex of a cloth being torn.
using Fans = std::vector<std::vector<Index>>;

// Whether vertex v of the triangles lies on the boundary: one of its edges borders one triangle.
bool onBoundary(const std::vector<std::array<Index, 3>>& triangles, const std::vector<Index>& fan,
                Index v) {
  std::vector<std::pair<Index, int>> seen;
  for (Index t : fan)
    for (Index u : triangles[t]) {
      if (u == v) continue;
      auto it = std::find_if(seen.begin(), seen.end(), [&](const auto& s) { return s.first == u; });
      if (it == seen.end())
        seen.emplace_back(u, 1);
      else
        ++it->second;
    }
  return std::any_of(seen.begin(), seen.end(), [](const auto& s) { return s.second == 1; });
}

struct Split {
  std::vector<Index> keep, move;  // triangles that keep the vertex, and those its copy takes
  double keepArea = 0, moveArea = 0;
  bool byPlane = true;  // false: the fallback at the widest gap
  // Where the vertex and its copy go, and their masses.
  Vec3d keepAt = Vec3d::Zero(), copyAt = Vec3d::Zero();
  double keepMass = 0, copyMass = 0;
};

// The split of vertex v by the plane through it perpendicular to its edge to u (positions now):
// the triangles whose centroid lies on u's side keep v, the others take the copy. The crack then
// opens across the tension that stretched the edge, as a brittle sheet's does. When the plane
// leaves one side empty (an edge standing out of the sheet, a vertex pulled out like a tent's
// pole: every triangle then lies behind it), the fan is cut at the widest gap between its
// triangles' centroids along the edge instead, which separates the triangles pulled along with
// the edge from the rest. Areas are the rest shape's, which the lumped masses come from.
Split splitOf(const std::vector<std::array<Index, 3>>& triangles, const std::vector<Index>& fan,
              Index v, Index u, const std::vector<Vec3>& x, const std::vector<Vec3>& rest,
              Index first) {
  const Vec3d xv = at(x, first + v), d = at(x, first + u) - xv;
  std::vector<double> along(fan.size());
  for (std::size_t k = 0; k < fan.size(); ++k) {
    Vec3d centroid = Vec3d::Zero();
    for (Index i : triangles[fan[k]]) centroid += at(x, first + i);
    along[k] = (centroid / 3 - xv).dot(d);
  }
  double threshold = 0;
  Split s;
  const auto [lo, hi] = std::minmax_element(along.begin(), along.end());
  if (!along.empty() && !(*lo <= 0 && *hi > 0)) {
    std::vector<double> sorted = along;
    std::sort(sorted.begin(), sorted.end());
    double widest = -1;
    for (std::size_t k = 1; k < sorted.size(); ++k)
      if (sorted[k] - sorted[k - 1] > widest) {
        widest = sorted[k] - sorted[k - 1];
        threshold = (sorted[k] + sorted[k - 1]) / 2;
      }
    s.byPlane = false;
  }
  for (std::size_t k = 0; k < fan.size(); ++k) {
    const auto& tri = triangles[fan[k]];
    const Vec3d r0 = at(rest, first + tri[0]);
    const double area =
        (at(rest, first + tri[1]) - r0).cross(at(rest, first + tri[2]) - r0).norm() / 2;
    if (along[k] > threshold) {
      s.keep.push_back(fan[k]);
      s.keepArea += area;
    } else {
      s.move.push_back(fan[k]);
      s.moveArea += area;
    }
  }
  return s;
}

// The masses and places of a split vertex and its copy. Mass by the lumped shares of each copy's
// triangles, so that the sum stays the original's (and, with the original's velocity, so does the
// momentum); apart along the edge by kOpeningShare of its rest length, weighted so that the centre
// of mass stays.
void place(Split& s, Index v, Index u, const ParticlePool& particles, Index first) {
  const Index g = first + v;
  const double mass = 1.0 / double(particles.w[g]);
  s.keepMass = mass * s.keepArea / (s.keepArea + s.moveArea);
  s.copyMass = mass - s.keepMass;
  const Vec3d direction = (at(particles.x, first + u) - at(particles.x, g)).normalized();
  const double opening =
      kOpeningShare *
      (at(particles.restPosition, g) - at(particles.restPosition, first + u)).norm();
  const Vec3d start = at(particles.x, g);
  s.keepAt = start + direction * (opening * s.copyMass / mass);
  s.copyAt = start - direction * (opening * s.keepMass / mass);
}

// Whether a triangle that keeps v and one that takes its copy, once they share no vertex, would
// intersect: neighbours folded onto each other about v are legal while they share it, but after
// the split the crossing fail-safe would find them crossing at the start of every substep and
// stop them there for good (the exact intersection count would count them too). Such a split
// waits until the fold has opened.
bool splitTangles(const std::vector<std::array<Index, 3>>& triangles, const Split& s, Index v,
                  const std::vector<Vec3>& x, Index first) {
  const auto corners = [&](Index t, const Vec3d& vAt) {
    Triangle3d out;
    for (int k = 0; k < 3; ++k)
      out[k] = triangles[t][k] == v ? vAt : at(x, first + triangles[t][k]);
    return out;
  };
  for (Index a : s.keep)
    for (Index b : s.move) {
      bool adjacent = false;
      for (Index i : triangles[a])
        if (i != v && std::find(triangles[b].begin(), triangles[b].end(), i) != triangles[b].end())
          adjacent = true;
      if (!adjacent && trianglesIntersect(corners(a, s.keepAt), corners(b, s.copyAt))) return true;
    }
  return false;
}

// Edges at v that a triangle of each group borders: the edges the split cuts.
std::size_t cutEdges(const std::vector<std::array<Index, 3>>& triangles, const Split& s, Index v) {
  std::vector<Index> keepSide, cut;
  for (Index t : s.keep)
    for (Index u : triangles[t])
      if (u != v) keepSide.push_back(u);
  for (Index t : s.move)
    for (Index u : triangles[t])
      if (u != v && std::find(keepSide.begin(), keepSide.end(), u) != keepSide.end() &&
          std::find(cut.begin(), cut.end(), u) == cut.end())
        cut.push_back(u);
  return cut.size();
}

struct Candidate {
  double strain;
  Index edge;
};

// One cloth's tears after a step; returns the vertices split.
std::size_t tearObject(ObjectRecord& record, std::uint32_t object, ParticlePool& particles,
                       ConstraintPools& pools, double dt, TearReport& report) {
  const Tear& tear = record.material.tear;
  TearState& state = record.tear;
  const Index first = record.firstParticle;
  const auto& edges = record.complex.edges.vertices;
  if (state.overTime.size() != edges.size()) state.overTime.assign(edges.size(), 0.0);
  std::vector<Candidate> candidates;
  for (Index e = 0; e < edges.size(); ++e) {
    const Index i = first + edges[e][0], j = first + edges[e][1];
    const double rest = (at(particles.restPosition, i) - at(particles.restPosition, j)).norm();
    const double strain =
        rest > 0 ? (at(particles.x, i) - at(particles.x, j)).norm() / rest - 1.0 : 0.0;
    if (!(strain > double(tear.strain))) {
      state.overTime[e] = 0;
      continue;
    }
    state.overTime[e] += dt;
    if (state.overTime[e] >= double(tear.time) - kClockRoom * dt) candidates.push_back({strain, e});
  }
  if (candidates.empty()) return 0;
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return a.strain != b.strain ? a.strain > b.strain : a.edge < b.edge;
  });

  const Index n = record.particleCount;
  std::vector<std::array<Index, 3>> triangles(record.complex.triangles.vertices.begin(),
                                              record.complex.triangles.vertices.end());
  Fans fans(n);
  for (Index t = 0; t < triangles.size(); ++t)
    for (Index v : triangles[t]) fans[v].push_back(t);
  // Over-stretched edges per vertex: where the stress concentrates (a crack's tip).
  std::vector<int> overStretched(n, 0);
  for (const Candidate& c : candidates) {
    ++overStretched[edges[c.edge][0]];
    ++overStretched[edges[c.edge][1]];
  }
  std::vector<std::uint8_t> touched(n, 0);
  std::vector<Index> splitFrom;  // per new vertex, the vertex it was split from
  for (const Candidate& candidate : candidates) {
    const Index a = edges[candidate.edge][0], b = edges[candidate.edge][1];
    if (touched[a] || touched[b]) continue;  // its fan changed: judged again after the next step
    // Which end splits: a free one whose plane leaves triangles on both sides (else one the
    // fallback splits); of two, the one on the boundary (a crack's tip lies on its lips, and a
    // crack starts at the cloth's border rather than as a slit inside), then the one with more
    // over-stretched edges.
    Index chosen = n;
    Split split;
    int bestRank = -1;
    for (const auto& [v, u] : {std::pair{a, b}, std::pair{b, a}}) {
      if (particles.w[first + v] <= 0) continue;  // pins and animated pins never split
      Split s = splitOf(triangles, fans[v], v, u, particles.x, particles.restPosition, first);
      if (s.keep.empty() || s.move.empty() || !(s.keepArea > 0) || !(s.moveArea > 0)) continue;
      place(s, v, u, particles, first);
      if (splitTangles(triangles, s, v, particles.x, first)) continue;
      const int rank = (s.byPlane ? 1 << 21 : 0) +
                       (onBoundary(triangles, fans[v], v) ? 1 << 20 : 0) + overStretched[v];
      if (rank > bestRank) bestRank = rank, chosen = v, split = std::move(s);
    }
    if (chosen == n) continue;
    if (state.spareParticles == 0) {
      ++report.refusedTears;
      continue;
    }
    const Index copy = record.particleCount;
    const Index g = first + chosen, gc = first + copy;
    report.tornEdges += cutEdges(triangles, split, chosen);
    ++report.newVertices;
    particles.x[gc] = split.copyAt.cast<Real>();
    particles.x[g] = split.keepAt.cast<Real>();
    particles.p[g] = particles.x[g];
    particles.p[gc] = particles.x[gc];
    particles.v[gc] = particles.v[g];
    particles.restPosition[gc] = particles.restPosition[g];
    particles.w[g] = static_cast<Real>(1.0 / split.keepMass);
    particles.w[gc] = static_cast<Real>(1.0 / split.copyMass);
    particles.phase[gc] = object;
    for (Index t : split.move)
      for (Index& v : triangles[t])
        if (v == chosen) v = copy;
    fans[chosen] = split.keep;
    fans.push_back(split.move);
    touched[chosen] = 1;
    touched.push_back(1);
    overStretched.push_back(0);
    splitFrom.push_back(chosen);
    ++record.particleCount;
    --state.spareParticles;
  }
  if (splitFrom.empty()) return 0;

  // The new complex; each edge keeps the clock of the edge it came from.
  std::unordered_map<std::uint64_t, double> clock;
  for (Index e = 0; e < edges.size(); ++e)
    clock[edgeKey(edges[e][0], edges[e][1])] = state.overTime[e];
  record.complex = buildFromTriangles(record.particleCount, triangles);
  record.surface = triangles;
  record.closed = false;
  const auto before = [&](Index v) { return v < n ? v : splitFrom[v - n]; };
  const auto& cut = record.complex.edges.vertices;
  state.overTime.assign(cut.size(), 0.0);
  for (Index e = 0; e < cut.size(); ++e)
    if (auto it = clock.find(edgeKey(before(cut[e][0]), before(cut[e][1]))); it != clock.end())
      state.overTime[e] = it->second;
  if (state.origin.empty()) {
    state.origin.resize(n);
    std::iota(state.origin.begin(), state.origin.end(), Index(0));
    state.opened.assign(n, 0);
  }
  for (Index k = 0; k < splitFrom.size(); ++k) {
    state.origin.push_back(state.origin[splitFrom[k]]);
    state.opened.push_back(0);
    state.opened[splitFrom[k]] = 0;  // coincident with its new copy again
  }

  rebuildTornConstraints(record, object, particles, pools);
  return splitFrom.size();
}

}  // namespace

// Tethers too: their limits are geodesic, and a path around the cut is longer than the one
// across it was.
void rebuildTornConstraints(const ObjectRecord& record, std::uint32_t object,
                            const ParticlePool& particles, ConstraintPools& pools) {
  pools.forEachBuiltin([&](auto& pool) {
    pool.retain([&](std::size_t c) { return particles.phase[pool.particles[c][0]] != object; });
  });
  const Index first = record.firstParticle;
  std::vector<Index> held;
  for (Index v = 0; v < record.particleCount; ++v)
    if (particles.w[first + v] == 0) held.push_back(v);
  appendObjectConstraints(
      pools, record.kind, record.complex,
      std::span<const Vec3>(particles.restPosition).subspan(first, record.particleCount), held,
      first, record.material);
}

Index tearSpareParticles(const Tear& tear, std::size_t vertexCount) {
  if (!tear.enabled()) return 0;
  if (tear.maxNewVertices >= 0) return static_cast<Index>(tear.maxNewVertices);
  return static_cast<Index>(std::max<std::size_t>(64, vertexCount / 4));
}

bool tearCloths(std::vector<ObjectRecord>& objects, ParticlePool& particles, ConstraintPools& pools,
                double dt, TearReport& report) {
  std::size_t splits = 0;
  for (std::uint32_t o = 0; o < objects.size(); ++o) {
    ObjectRecord& record = objects[o];
    if (record.kind != ObjectKind::Cloth || !record.material.tear.enabled()) continue;
    splits += tearObject(record, o, particles, pools, dt, report);
  }
  report.tearSteps += splits > 0;
  return splits > 0;
}

void openTornLips(std::vector<ObjectRecord>& objects, const ParticlePool& particles,
                  CollisionPrimitives& primitives) {
  for (ObjectRecord& record : objects) {
    TearState& state = record.tear;
    if (state.origin.empty()) continue;
    const Index first = record.firstParticle;
    // Self-contact distance: both primitives' radii.
    const double reach = 2 * double(record.material.thickness);
    // The copies of each original, grouped (an original is its own origin).
    std::unordered_map<Index, std::vector<Index>> copies;
    for (Index v = 0; v < state.origin.size(); ++v)
      if (state.origin[v] != v) copies[state.origin[v]].push_back(v);
    for (auto& [root, group] : copies) {
      group.push_back(root);
      for (Index v : group) {
        if (state.opened[v]) continue;
        const bool apart = std::all_of(group.begin(), group.end(), [&](Index u) {
          return u == v || (at(particles.x, first + u) - at(particles.x, first + v)).norm() > reach;
        });
        if (!apart) continue;
        state.opened[v] = 1;
        if (primitives.particleOrigin.empty())
          primitives.particleOrigin.assign(particles.size(), CollisionPrimitives::kNoOrigin);
        primitives.particleOrigin[first + v] = first + root;
      }
    }
  }
}

}  // namespace nucleon
