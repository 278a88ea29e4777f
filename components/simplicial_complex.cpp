#include "components/simplicial_complex.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace nucleon {
namespace {

template <int K>
std::string describe(const char* what, std::size_t i, const Simplex<K>& s) {
  std::ostringstream out;
  out << what << ' ' << i << " (";
  for (int j = 0; j <= K; ++j) out << (j ? " " : "") << s[j];
  out << ')';
  return out.str();
}

// Sorts s ascending and returns the parity of the permutation (+1 even, −1 odd).
template <std::size_t N>
int sortWithParity(std::array<Index, N>& s) {
  int parity = 1;
  for (std::size_t i = 1; i < N; ++i)  // insertion sort: N ≤ 4, and every swap flips the parity
    for (std::size_t j = i; j > 0 && s[j - 1] > s[j]; --j) {
      std::swap(s[j - 1], s[j]);
      parity = -parity;
    }
  return parity;
}

template <int K>
void validateTop(std::size_t vertexCount, std::span<const Simplex<K>> simplices, const char* name) {
  if (vertexCount == 0) throw MeshError("mesh has no vertices");
  if (simplices.empty()) throw MeshError(std::string("mesh has no ") + name + "s");
  std::vector<Simplex<K>> sorted(simplices.begin(), simplices.end());
  for (std::size_t i = 0; i < simplices.size(); ++i) {
    for (int j = 0; j <= K; ++j)
      if (simplices[i][j] >= vertexCount)
        throw MeshError(describe<K>(name, i, simplices[i]) + " uses vertex " +
                        std::to_string(simplices[i][j]) + " but the mesh has only " +
                        std::to_string(vertexCount) + " vertices");
    sortWithParity(sorted[i]);
    for (int j = 0; j < K; ++j)
      if (sorted[i][j] == sorted[i][j + 1])
        throw MeshError(describe<K>(name, i, simplices[i]) + " repeats vertex " +
                        std::to_string(sorted[i][j]));
  }
  std::vector<std::size_t> order(simplices.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return sorted[a] != sorted[b] ? sorted[a] < sorted[b] : a < b;
  });
  for (std::size_t i = 1; i < order.size(); ++i)
    if (sorted[order[i]] == sorted[order[i - 1]])
      throw MeshError(describe<K>(name, order[i], simplices[order[i]]) + " repeats " + name + " " +
                      std::to_string(order[i - 1]));
}

// Generates the (K−1)-faces of the K-simplices in `top`, fills top.boundary and the faces'
// co-boundary. Faces are deduplicated by sorting, so the result does not depend on hashing.
template <int K>
void buildFaces(SimplexPool<K>& top, SimplexPool<K - 1>& faces, std::size_t vertexCount) {
  struct Entry {
    Simplex<K - 1> key;
    Index parent;
    std::int8_t slot;
    std::int8_t sign;
  };
  std::vector<Entry> entries;
  entries.reserve(top.size() * (K + 1));
  for (Index s = 0; s < top.size(); ++s)
    for (int i = 0; i <= K; ++i) {
      Entry e{{}, s, static_cast<std::int8_t>(i), 0};
      for (int j = 0, m = 0; j <= K; ++j)
        if (j != i) e.key[m++] = top.vertices[s][j];
      e.sign = static_cast<std::int8_t>(((i & 1) ? -1 : 1) * sortWithParity(e.key));
      entries.push_back(e);
    }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    if (a.key != b.key) return a.key < b.key;
    return a.parent != b.parent ? a.parent < b.parent : a.slot < b.slot;
  });

  top.boundary.assign(top.size(), {});
  if constexpr (K == 1) {
    // Points are every vertex 0..n−1, used or not, so that point index = vertex index.
    faces.vertices.resize(vertexCount);
    for (Index i = 0; i < vertexCount; ++i) faces.vertices[i] = {i};
  } else {
    faces.vertices.clear();
  }
  faces.parentOffset.assign(1, 0);
  faces.parents.clear();
  faces.parents.reserve(entries.size());
  Index face = 0;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const bool newFace = i == 0 || entries[i].key != entries[i - 1].key;
    if constexpr (K == 1) {
      face = entries[i].key[0];
      if (newFace)  // close the CSR rows of all vertices up to this one (unused vertices: empty)
        while (faces.parentOffset.size() <= face)
          faces.parentOffset.push_back(faces.parents.size());
    } else if (newFace) {
      if (i != 0) faces.parentOffset.push_back(static_cast<Index>(faces.parents.size()));
      face = static_cast<Index>(faces.vertices.size());
      faces.vertices.push_back(entries[i].key);
    }
    top.boundary[entries[i].parent][entries[i].slot] = {face, entries[i].sign};
    faces.parents.push_back({entries[i].parent, entries[i].sign});
  }
  while (faces.parentOffset.size() <= faces.vertices.size())
    faces.parentOffset.push_back(static_cast<Index>(faces.parents.size()));
}

template <int K>
void noParents(SimplexPool<K>& pool) {
  pool.parentOffset.assign(pool.size() + 1, 0);
  pool.parents.clear();
}

// Counts faces of the top simplices that are shared by more than two parents, and interior faces
// whose two parents induce the same orientation on them (a non-orientable or flipped region).
template <int K>
void auditTopology(const SimplexPool<K>& faces, ComplexReport& report) {
  for (Index f = 0; f < faces.size(); ++f) {
    const auto parents = faces.parentsOf(f);
    if (parents.size() > 2) ++report.nonManifoldFaces;
    if (parents.size() == 2 && parents[0].sign == parents[1].sign) ++report.inconsistentOrientation;
  }
}

}  // namespace

SimplicialComplex buildFromPoints(std::size_t vertexCount) {
  if (vertexCount == 0) throw MeshError("point set is empty");
  SimplicialComplex c;
  c.dimension = 0;
  c.points.vertices.resize(vertexCount);
  for (Index i = 0; i < vertexCount; ++i) c.points.vertices[i] = {i};
  noParents(c.points);
  noParents(c.edges);
  noParents(c.triangles);
  noParents(c.tets);
  return c;
}

SimplicialComplex buildFromEdges(std::size_t vertexCount, std::span<const Simplex<1>> edges) {
  validateTop<1>(vertexCount, edges, "edge");
  SimplicialComplex c;
  c.dimension = 1;
  c.edges.vertices.assign(edges.begin(), edges.end());
  buildFaces<1>(c.edges, c.points, vertexCount);
  noParents(c.edges);
  noParents(c.triangles);
  noParents(c.tets);
  return c;
}

SimplicialComplex buildFromTriangles(std::size_t vertexCount,
                                     std::span<const Simplex<2>> triangles) {
  validateTop<2>(vertexCount, triangles, "triangle");
  SimplicialComplex c;
  c.dimension = 2;
  c.triangles.vertices.assign(triangles.begin(), triangles.end());
  buildFaces<2>(c.triangles, c.edges, vertexCount);
  buildFaces<1>(c.edges, c.points, vertexCount);
  noParents(c.triangles);
  noParents(c.tets);
  auditTopology(c.edges, c.report);
  return c;
}

SimplicialComplex buildFromTets(std::size_t vertexCount, std::span<const Simplex<3>> tets) {
  validateTop<3>(vertexCount, tets, "tetrahedron");
  SimplicialComplex c;
  c.dimension = 3;
  c.tets.vertices.assign(tets.begin(), tets.end());
  buildFaces<3>(c.tets, c.triangles, vertexCount);
  buildFaces<2>(c.triangles, c.edges, vertexCount);
  buildFaces<1>(c.edges, c.points, vertexCount);
  noParents(c.tets);
  auditTopology(c.triangles, c.report);
  return c;
}

namespace {
template <int K>
std::vector<Simplex<K>> singleParentFaces(const SimplexPool<K>& faces) {
  std::vector<Simplex<K>> out;
  for (Index f = 0; f < faces.size(); ++f) {
    const auto parents = faces.parentsOf(f);
    if (parents.size() != 1) continue;
    Simplex<K> s = faces.vertices[f];
    if (parents[0].sign < 0) std::swap(s[0], s[1]);  // one transposition flips the orientation
    out.push_back(s);
  }
  return out;
}
}  // namespace

std::vector<Simplex<1>> SimplicialComplex::boundaryEdges() const {
  return dimension == 2 ? singleParentFaces(edges) : std::vector<Simplex<1>>{};
}

std::vector<Simplex<2>> SimplicialComplex::boundaryTriangles() const {
  return dimension == 3 ? singleParentFaces(triangles) : std::vector<Simplex<2>>{};
}

void auditGeometry(SimplicialComplex& c, std::span<const Vec3> positions,
                   double relativeTolerance) {
  if (positions.size() < c.vertexCount())
    throw MeshError("fewer positions than vertices in the complex");
  auto at = [&](Index i) { return positions[i].cast<double>().eval(); };
  double meanLength = 0;
  for (const auto& e : c.edges.vertices) meanLength += (at(e[1]) - at(e[0])).norm();
  if (!c.edges.vertices.empty()) meanLength /= static_cast<double>(c.edges.size());
  std::size_t degenerate = 0, inverted = 0;
  switch (c.dimension) {
    case 1:
      for (const auto& e : c.edges.vertices)
        if ((at(e[1]) - at(e[0])).norm() <= relativeTolerance * meanLength) ++degenerate;
      break;
    case 2:
      for (const auto& t : c.triangles.vertices) {
        const double area = 0.5 * (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0])).norm();
        if (area <= relativeTolerance * meanLength * meanLength) ++degenerate;
      }
      break;
    case 3:
      for (const auto& t : c.tets.vertices) {
        const double volume =
            (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0])).dot(at(t[3]) - at(t[0])) / 6.0;
        const double threshold = relativeTolerance * meanLength * meanLength * meanLength;
        if (std::abs(volume) <= threshold)
          ++degenerate;
        else if (volume < 0)
          ++inverted;
      }
      break;
    default:
      break;
  }
  c.report.degenerateSimplices = degenerate;
  c.report.invertedSimplices = inverted;
}

}  // namespace nucleon
