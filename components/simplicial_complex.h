// The simplicial complex: one representation for every kind of matter (ARCHITECTURE.md §1).
//
// A k-simplex is an oriented list of k+1 vertex indices, local to its object (the object's first
// particle is added to make a particle index). The top simplices keep the orientation they were
// given; lower simplices are generated as faces and stored in canonical (ascending) order. Each
// k-simplex knows its k+1 boundary faces with their induced signs, and each face knows its parents
// (co-boundary) through a CSR table, so "the two triangles of this edge" is a lookup.
//
// Orientation follows the usual convention: swapping two vertices flips the sign, and
// ∂[v0..vk] = Σ_i (−1)^i [v0..v̂i..vk].
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "nucleon/errors.h"
#include "nucleon/types.h"

namespace nucleon {

template <int K>
using Simplex = std::array<Index, K + 1>;

// A face reference with the sign of the face in its parent's boundary.
struct SignedFace {
  Index face;
  std::int8_t sign;
};

// Pool of k-simplices with their boundary and co-boundary relations.
template <int K>
struct SimplexPool {
  std::vector<Simplex<K>> vertices;                     // oriented vertex lists
  std::vector<std::array<SignedFace, K + 1>> boundary;  // faces in the (k−1)-pool (empty for k = 0)
  // Co-boundary: parents in the (k+1)-pool of simplex s are parents[parentOffset[s] ..
  // parentOffset[s+1]), in increasing parent order, with the sign s has in each parent's boundary.
  std::vector<Index> parentOffset;
  std::vector<SignedFace> parents;

  std::size_t size() const { return vertices.size(); }
  std::span<const SignedFace> parentsOf(Index s) const {
    return {parents.data() + parentOffset[s], parents.data() + parentOffset[s + 1]};
  }
};

// Problems that leave a usable complex but that a caller may want to reject or warn about.
struct ComplexReport {
  std::size_t nonManifoldFaces = 0;         // (k−1)-faces with more than two top-level parents
  std::size_t inconsistentOrientation = 0;  // interior faces whose two parents induce the same sign
  std::size_t degenerateSimplices = 0;      // zero length / area / volume (from auditGeometry)
  std::size_t invertedSimplices = 0;        // tets with negative signed volume (from auditGeometry)
  bool clean() const {
    return nonManifoldFaces == 0 && inconsistentOrientation == 0 && degenerateSimplices == 0 &&
           invertedSimplices == 0;
  }
};

struct SimplicialComplex {
  int dimension = 0;  // dimension of the top simplices
  SimplexPool<0> points;
  SimplexPool<1> edges;
  SimplexPool<2> triangles;
  SimplexPool<3> tets;
  ComplexReport report;

  std::size_t vertexCount() const { return points.size(); }
  // Euler characteristic V − E + F − T.
  long long eulerCharacteristic() const {
    return static_cast<long long>(points.size()) - static_cast<long long>(edges.size()) +
           static_cast<long long>(triangles.size()) - static_cast<long long>(tets.size());
  }
  // Faces of the top dimension − 1 with a single parent (edges of an open surface, triangles on
  // the surface of a solid), oriented as their parent induces them.
  std::vector<Simplex<1>> boundaryEdges() const;
  std::vector<Simplex<2>> boundaryTriangles() const;
};

// Builders. Each validates its input and throws MeshError with a message naming the offending
// simplex; topological oddities are counted in the complex's report instead.
SimplicialComplex buildFromPoints(std::size_t vertexCount);
SimplicialComplex buildFromEdges(std::size_t vertexCount, std::span<const Simplex<1>> edges);
SimplicialComplex buildFromTriangles(std::size_t vertexCount,
                                     std::span<const Simplex<2>> triangles);
SimplicialComplex buildFromTets(std::size_t vertexCount, std::span<const Simplex<3>> tets);

// Counts zero-measure simplices of the top dimension (and inverted tets) at the given positions
// into complex.report. Measures below relativeTolerance × (mean edge length)^k count as zero.
void auditGeometry(SimplicialComplex& complex, std::span<const Vec3> positions,
                   double relativeTolerance = 1e-8);

}  // namespace nucleon
