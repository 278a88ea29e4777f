// Geodesic distances over an object's rest shape, from a set of source vertices.
//
// Distances grow in Dijkstra order, and each triangle with two settled vertices a, b (reached
// from the same source) also offers its third vertex c the straight path from the source unfolded
// into the triangle's plane (the point-source update of fast marching on triangulated domains,
// Kimmel and Sethian 1998; Novotni and Klein 2002): the source lies at distances d_a, d_b from a
// and b on the far side of ab, and c gets |c − s| when that segment crosses ab. On a flat mesh
// whose straight paths stay on the mesh this is the Euclidean distance to rounding, where a path
// along edges can be 41% longer (a grid whose diagonals all point the other way); on a curved
// mesh it follows the unfolding, and a vertex no triangle reaches straight keeps the path along
// edges. Ropes and point sets have no triangles: their distances are the paths along edges.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "components/simplicial_complex.h"
#include "nucleon/types.h"

namespace nucleon {

struct GeodesicField {
  std::vector<double> distance;  // +∞ where unreached
  std::vector<Index> source;     // the nearest source; meaningful where distance is finite
};

// Fills `field` for every vertex of `complex` (local indices), spreading only through vertices
// with allowed[v] != 0 (every vertex when `allowed` is empty). Sources are always allowed.
void geodesicDistances(const SimplicialComplex& complex, std::span<const Vec3> rest,
                       std::span<const Index> sources, std::span<const std::uint8_t> allowed,
                       GeodesicField& field);

}  // namespace nucleon
