#include "systems/setup/build_hierarchy.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <initializer_list>
#include <span>

namespace nucleon {
namespace {

// Work is done in object-local indices (0 … particleCount − 1); arrays indexed by particle are
// sized to the whole object, so that a level needs no index map.
using Edge = std::array<Index, 2>;

// Sorted neighbour lists of a level's graph as CSR over the object's particles; particles off the
// level have empty rows. `edges` must be sorted by (i, j) with i < j: every row then comes out
// ascending (the smaller neighbours, from the edges before the row's own, then the larger ones).
struct Adjacency {
  std::vector<Index> offset;
  std::vector<Index> neighbour;

  std::span<const Index> of(Index i) const {
    return {neighbour.data() + offset[i], neighbour.data() + offset[i + 1]};
  }
};

Adjacency buildAdjacency(const std::vector<Edge>& edges, std::size_t particleCount) {
  Adjacency out;
  out.offset.assign(particleCount + 1, 0);
  for (const Edge& e : edges) {
    ++out.offset[e[0] + 1];
    ++out.offset[e[1] + 1];
  }
  for (std::size_t i = 0; i < particleCount; ++i) out.offset[i + 1] += out.offset[i];
  out.neighbour.resize(out.offset[particleCount]);
  std::vector<Index> fill(out.offset.begin(), out.offset.end() - 1);
  for (const Edge& e : edges) {
    out.neighbour[fill[e[0]]++] = e[1];
    out.neighbour[fill[e[1]]++] = e[0];
  }
  return out;
}

double restDistance(const std::vector<Vec3>& rest, Index first, Index a, Index b) {
  return (rest[first + a].cast<double>() - rest[first + b].cast<double>()).norm();
}

// Stores the level's graph: global pairs in color order, rest lengths and color offsets. Greedy
// edge coloring in (i, j) order, each edge taking the lowest color free at both its ends: at most
// 2Δ − 1 colors for the largest degree Δ, kept as one bit set per particle.
std::vector<Index> storeGraph(HierarchyLevel& level, const std::vector<Edge>& edges,
                              const Adjacency& adjacency, const std::vector<Vec3>& rest,
                              Index first, std::size_t particleCount) {
  std::size_t maxDegree = 0;
  for (std::size_t i = 0; i < particleCount; ++i)
    maxDegree = std::max<std::size_t>(maxDegree, adjacency.offset[i + 1] - adjacency.offset[i]);
  const std::size_t words = maxDegree == 0 ? 1 : (2 * maxDegree - 1 + 63) / 64;
  std::vector<std::uint64_t> used(particleCount * words, 0);
  std::vector<Index> color(edges.size());
  Index colors = 0;
  for (std::size_t e = 0; e < edges.size(); ++e) {
    std::uint64_t* a = &used[edges[e][0] * words];
    std::uint64_t* b = &used[edges[e][1] * words];
    std::size_t word = 0;
    while (~(a[word] | b[word]) == 0) ++word;  // ends: fewer than 2Δ − 1 colors are taken
    const std::uint64_t free = ~(a[word] | b[word]);
    const int bit = std::countr_zero(free);
    const Index c = static_cast<Index>(word * 64 + static_cast<std::size_t>(bit));
    a[word] |= std::uint64_t{1} << bit;
    b[word] |= std::uint64_t{1} << bit;
    color[e] = c;
    colors = std::max(colors, c + 1);
  }
  // Counting sort by color, stable: within a color the edges keep their (i, j) order.
  level.colorOffset.assign(colors + 1, 0);
  for (Index c : color) ++level.colorOffset[c + 1];
  for (Index c = 0; c < colors; ++c) level.colorOffset[c + 1] += level.colorOffset[c];
  std::vector<Index> fill(level.colorOffset.begin(), level.colorOffset.end() - 1);
  level.edges.resize(edges.size());
  level.restLength.resize(edges.size());
  std::vector<Index> slotOf(edges.size());
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const Index slot = fill[color[e]]++;
    slotOf[e] = slot;
    level.edges[slot] = {first + edges[e][0], first + edges[e][1]};
    level.restLength[slot] = static_cast<Real>(restDistance(rest, first, edges[e][0], edges[e][1]));
  }
  return slotOf;
}

// A coarse edge's path through the finer level: its particles (object-local) from one end to
// the other, the first repeated in front of a path of fewer than three edges, and its rest length.
struct Path {
  std::array<Index, 4> particle{};
  double rest = 0;
};

// Stores the paths of a coarse level's edges (`paths` in the sorted order of its edge list,
// slotOf mapping that order to the color order) as global indices, and their rest lengths.
void storePaths(HierarchyLevel& level, const std::vector<Path>& paths,
                const std::vector<Index>& slotOf, Index first) {
  level.path.resize(paths.size());
  level.pathRest.resize(paths.size());
  for (std::size_t e = 0; e < paths.size(); ++e) {
    for (std::size_t k = 0; k < 4; ++k) level.path[slotOf[e]][k] = first + paths[e].particle[k];
    level.pathRest[slotOf[e]] = static_cast<Real>(paths[e].rest);
  }
}

// A regular grid as shapes.h's gridCloth lays it out: vertex (i, j) is j·columns + i, every
// vertex is joined to its right and upper neighbours, and every edge joins vertices at most one
// row and one column apart (the cells' diagonals). Returns the column count, or 0 for any other
// mesh. The column count is one of vertex 0's neighbours, so at most a few candidates are tried.
Index gridColumns(const std::vector<Edge>& sortedEdges, const Adjacency& adjacency,
                  std::size_t particleCount) {
  if (particleCount < 4) return 0;
  for (Index columns : adjacency.of(0)) {
    if (columns < 2 || particleCount % columns != 0 || particleCount / columns < 2) continue;
    const std::size_t rows = particleCount / columns;
    std::size_t axisEdges = 0;
    bool grid = true;
    for (const Edge& e : sortedEdges) {
      const long long di = static_cast<long long>(e[1] % columns) - e[0] % columns;
      const Index dj = e[1] / columns - e[0] / columns;
      if (dj > 1 || di < -1 || di > 1) {
        grid = false;
        break;
      }
      axisEdges += (dj == 0 && di == 1) || (dj == 1 && di == 0);
    }
    // Edges are distinct, so counting the axis edges counts that every one of them is there.
    if (grid && axisEdges == (columns - 1) * rows + columns * (rows - 1)) return columns;
  }
  return 0;
}

// Every other entry of a level's kept rows (or columns), and the last: the next level's.
std::vector<Index> decimate(const std::vector<Index>& kept) {
  std::vector<Index> next;
  for (std::size_t r = 0; r < kept.size(); r += 2) next.push_back(kept[r]);
  if (next.back() != kept.back()) next.push_back(kept.back());
  return next;
}

ObjectHierarchy buildObjectHierarchy(const ObjectRecord& object, Index objectIndex,
                                     const ParticlePool& particles,
                                     const HierarchySettings& settings) {
  const std::size_t n = object.particleCount;
  const Index first = object.firstParticle;
  const std::vector<Vec3>& rest = particles.restPosition;
  const Index k = static_cast<Index>(std::max(settings.coarseNeighbours, 1));

  ObjectHierarchy out;
  out.object = objectIndex;
  out.firstParticle = first;
  out.particleCount = object.particleCount;

  // Level 0: every particle; the object's edges, sorted (the complex stores each edge ascending).
  std::vector<Index> members(n);
  for (Index i = 0; i < n; ++i) members[i] = i;
  std::vector<Edge> edges(object.complex.edges.vertices.begin(),
                          object.complex.edges.vertices.end());
  for (Edge& e : edges)
    if (e[0] > e[1]) std::swap(e[0], e[1]);
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());

  // Regular grids are decimated two to one along each axis, keeping the last row and column
  // (Müller 2008 §4.1: "regular grids can use coarser grids directly"): the greedy selection,
  // which visits a grid's particles row by row, leaves coarse particles in uneven staircases.
  const Index columns =
      settings.decimateGrids ? gridColumns(edges, buildAdjacency(edges, n), n) : Index(0);
  std::vector<Index> keptColumns, keptRows;
  std::vector<char> columnKept, rowKept;
  if (columns > 0) {
    for (Index c = 0; c < columns; ++c) keptColumns.push_back(c);
    for (Index r = 0; r < n / columns; ++r) keptRows.push_back(r);
  }

  std::vector<char> coarse(n, 0);
  std::vector<Index> coarseNeighbours(n, 0);
  // seen[b] == stamp: b is already in the row being built. One stamp per row over all levels.
  std::vector<std::uint64_t> seen(n, 0);
  std::uint64_t stamp = 0;
  struct RowEntry {
    Index partner;
    Path path;
  };
  std::vector<RowEntry> row;
  std::vector<Index> rowSlot(n, 0);
  std::vector<Path> paths;
  std::vector<double> raw;
  for (;;) {
    HierarchyLevel& level = out.levels.emplace_back();
    level.particles.resize(members.size());
    for (std::size_t m = 0; m < members.size(); ++m) level.particles[m] = first + members[m];
    const Adjacency adjacency = buildAdjacency(edges, n);
    const std::vector<Index> slotOf = storeGraph(level, edges, adjacency, rest, first, n);
    if (out.levels.size() > 1) storePaths(level, paths, slotOf, first);
    level.parentOffset = {0};
    if (members.size() <= settings.smallestLevel) break;

    if (columns > 0) {
      // Grid: the next level's rows and columns, and the pins. A particle the decimation leaves
      // with fewer than k coarse neighbours (next to an off-lattice pin, whose links replace
      // the lattice's) stays coarse, so that every fine particle has k parents as in the greedy
      // selection; making one coarse only adds coarse neighbours to the others, so one pass in
      // index order settles them all.
      keptColumns = decimate(keptColumns);
      keptRows = decimate(keptRows);
      columnKept.assign(columns, 0);
      rowKept.assign(n / columns, 0);
      for (Index c : keptColumns) columnKept[c] = 1;
      for (Index r : keptRows) rowKept[r] = 1;
      for (Index i : members)
        coarse[i] =
            (columnKept[i % columns] && rowKept[i / columns]) || particles.w[first + i] == 0;
      for (Index i : members) {
        if (coarse[i]) continue;
        const auto around = adjacency.of(i);
        if (static_cast<Index>(std::count_if(around.begin(), around.end(),
                                             [&](Index j) { return coarse[j] != 0; })) < k)
          coarse[i] = 1;
      }
    } else {
      // Greedy selection (Müller 2008 §4.1), in index order so that it is deterministic.
      for (Index i : members) {
        coarse[i] = 1;
        coarseNeighbours[i] = adjacency.offset[i + 1] - adjacency.offset[i];
      }
      for (Index i : members) {
        if (particles.w[first + i] == 0 || coarseNeighbours[i] < k) continue;
        const auto around = adjacency.of(i);
        const bool keeps = std::all_of(around.begin(), around.end(), [&](Index j) {
          return coarse[j] || coarseNeighbours[j] > k;  // j fine: keeps ≥ k without i
        });
        if (!keeps) continue;
        coarse[i] = 0;
        for (Index j : around) --coarseNeighbours[j];
      }
    }
    std::vector<Index> next;
    for (Index i : members)
      if (coarse[i]) next.push_back(i);
    if (static_cast<double>(next.size()) >
        (1 - settings.minimumShrink) * static_cast<double>(members.size()))
      break;

    // Parents of the fine particles: their coarse neighbours, Müller's inverse-distance weights.
    for (Index f : members) {
      if (coarse[f]) continue;
      level.fine.push_back(first + f);
      double farthest = 0;
      for (Index j : adjacency.of(f))
        if (coarse[j]) farthest = std::max(farthest, restDistance(rest, first, f, j));
      double sum = 0;
      raw.clear();
      for (Index j : adjacency.of(f)) {
        if (!coarse[j]) continue;
        const double d = restDistance(rest, first, f, j);
        const double w = farthest > 0 ? 1 / (d / farthest + settings.weightEpsilon) : 1;
        level.parent.push_back(first + j);
        raw.push_back(w);
        sum += w;
      }
      for (double w : raw) level.weight.push_back(static_cast<Real>(w / sum));
      level.parentOffset.push_back(static_cast<Index>(level.parent.size()));
    }

    // The next level's graph (Müller 2008 §4.2): coarse a and b are joined if they are neighbours
    // here or share a fine neighbour here, and (settings.linkThroughFineEdges) if they have fine
    // neighbours that are neighbours of each other. Rows are built per a, keeping b > a, so that
    // the edge list comes out sorted by (a, b). Each keeps the path of this level's edges between
    // its two particles with the least rest length (the straightest, where several join them):
    // each step of a path is an edge here, whose rest length is its particles' rest distance.
    std::vector<Edge> nextEdges;
    paths.clear();
    for (Index a : next) {
      row.clear();
      ++stamp;
      auto add = [&](Index b, std::initializer_list<Index> via) {
        if (b <= a || !coarse[b]) return;
        // a, the particles via, b; a repeated in front up to four.
        Path path;
        std::size_t k = 3 - via.size();
        for (std::size_t pad = 0; pad < k; ++pad) path.particle[pad] = a;
        for (Index v : via) path.particle[k++] = v;
        path.particle[3] = b;
        for (std::size_t step = 2 - via.size(); step < 3; ++step)
          path.rest += restDistance(rest, first, path.particle[step], path.particle[step + 1]);
        if (seen[b] != stamp) {
          seen[b] = stamp;
          rowSlot[b] = static_cast<Index>(row.size());
          row.push_back({b, path});
        } else if (path.rest < row[rowSlot[b]].path.rest) {
          row[rowSlot[b]].path = path;
        }
      };
      for (Index f : adjacency.of(a)) {
        if (coarse[f]) {
          add(f, {});
          continue;
        }
        for (Index b : adjacency.of(f)) {
          add(b, {f});
          if (settings.linkThroughFineEdges && !coarse[b])
            for (Index c : adjacency.of(b)) add(c, {f, b});
        }
      }
      // A limit between two particles that never move (inverse mass 0) constrains nothing; a
      // pinned row would otherwise join each of its pins to most of the others within levels.
      std::sort(row.begin(), row.end(),
                [](const RowEntry& x, const RowEntry& y) { return x.partner < y.partner; });
      const bool aHeld = particles.w[first + a] == 0;
      for (const RowEntry& entry : row)
        if (!aHeld || particles.w[first + entry.partner] != 0) {
          nextEdges.push_back({a, entry.partner});
          paths.push_back(entry.path);
        }
    }
    for (Index i : members) coarse[i] = 0;
    members = std::move(next);
    edges = std::move(nextEdges);
  }
  return out;
}

}  // namespace

void buildLevelHierarchies(LevelHierarchies& out, const std::vector<ObjectRecord>& objects,
                           const ParticlePool& particles, const HierarchySettings& settings) {
  out.objects.clear();
  for (std::size_t o = 0; o < objects.size(); ++o) {
    const ObjectRecord& object = objects[o];
    const bool deformable = object.kind == ObjectKind::Cloth || object.kind == ObjectKind::Rope ||
                            object.kind == ObjectKind::Solid;
    // A rigid body (rigidity 1) is held rigid by shape matching after every round: its edges
    // stay at rest length, and coarse corrections prolonged to its particles would only move its
    // momentum (a spinning rigid ball gained 1% of it in half a second).
    if (!deformable || object.complex.edges.size() == 0 || object.material.rigidity >= 1) continue;
    out.objects.push_back(buildObjectHierarchy(object, static_cast<Index>(o), particles, settings));
    // A material with a strain limit (Material::stretchLimit) may stretch that far between any
    // two of its points: every coarse limit, and the rest length of the path it is compared
    // with, grows by the same factor, so the cascade grips where the material is at its limit.
    const Real strain = object.material.longRangeStrain();
    if (strain > 0)
      for (std::size_t l = 1; l < out.objects.back().levels.size(); ++l) {
        HierarchyLevel& level = out.objects.back().levels[l];
        for (Real& length : level.restLength) length *= 1 + strain;
        for (Real& length : level.pathRest) length *= 1 + strain;
      }
  }
  out.coarseEdges = 0;
  for (ObjectHierarchy& hierarchy : out.objects)
    for (std::size_t l = 1; l < hierarchy.levels.size(); ++l) {
      hierarchy.levels[l].scratchBase = static_cast<Index>(out.coarseEdges);
      out.coarseEdges += hierarchy.levels[l].edges.size();
    }
}

void attachLevelTethers(LevelHierarchies& hierarchies, const TetherConstraints& tethers,
                        std::size_t particleCount) {
  // The pool's tethers grouped by free particle (CSR), in pool order within a particle.
  std::vector<Index> offset(particleCount + 1, 0), order(tethers.size());
  for (std::size_t c = 0; c < tethers.size(); ++c) ++offset[tethers.particles[c][0] + 1];
  for (std::size_t i = 0; i < particleCount; ++i) offset[i + 1] += offset[i];
  std::vector<Index> fill(offset.begin(), offset.end() - 1);
  for (std::size_t c = 0; c < tethers.size(); ++c)
    order[fill[tethers.particles[c][0]]++] = static_cast<Index>(c);
  for (ObjectHierarchy& hierarchy : hierarchies.objects)
    for (std::size_t l = 0; l < hierarchy.levels.size(); ++l) {
      HierarchyLevel& level = hierarchy.levels[l];
      level.tetherOffset.clear();
      level.tetherPin.clear();
      level.tetherLimit.clear();
      if (l == 0 || tethers.size() == 0) continue;
      level.tetherOffset.reserve(level.particles.size() + 1);
      level.tetherOffset.push_back(0);
      for (Index i : level.particles) {
        for (Index k = offset[i]; k < offset[i + 1]; ++k) {
          level.tetherPin.push_back(tethers.particles[order[k]][1]);
          level.tetherLimit.push_back(tethers.rest[order[k]]);
        }
        level.tetherOffset.push_back(static_cast<Index>(level.tetherPin.size()));
      }
      if (level.tetherPin.empty()) level.tetherOffset.clear();
    }
}

}  // namespace nucleon
