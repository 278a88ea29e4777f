// Procedural shapes: object definitions in their rest shape, ready for World::add*.
#pragma once

#include <array>
#include <vector>

#include "nucleon/world.h"

namespace nucleon {

struct GridSpec {
  std::array<int, 2> resolution = {64, 64};  // vertices along each side (≥ 2)
  std::array<Real, 2> size = {2, 2};         // side lengths in m
  Vec3 center = Vec3(0, 1, 0);
  bool vertical = false;  // false: in the xz plane (horizontal); true: in the xy plane
};
// Vertex (i, j) is index j·resolution[0] + i; i runs along x. Corners: 0, nx−1, nx(ny−1), nx·ny−1.
// Cells are split along alternating diagonals so the cloth has no preferred shear direction.
ObjectDef gridCloth(const GridSpec& spec);

// A straight polyline of `segments` edges from `from` to `to`.
ObjectDef polylineRope(const Vec3& from, const Vec3& to, int segments);
// A polyline through the given points, in order.
ObjectDef polylineRope(const std::vector<Vec3>& points);

// A closed sphere from a subdivided icosahedron, triangles facing outwards.
ObjectDef icosphere(const Vec3& center, Real radius, int subdivisions);

// A box of cells[0]×cells[1]×cells[2] cubes, each split into six positively oriented tets that
// share the cube's main diagonal (a conforming mesh: neighbouring cubes agree on shared faces).
ObjectDef tetBox(const Vec3& center, const Vec3& size, const std::array<int, 3>& cells);

}  // namespace nucleon
