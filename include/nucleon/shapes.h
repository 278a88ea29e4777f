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

// An open cylinder of cloth triangles about `axis`, or a truncated cone when the two radii differ.
// Ring k (0 ≤ k < resolution[1]) is the circle at center + (k / (rings − 1) − ½) · length · axis:
// ring 0 at the −axis end ("bottom"), the last ring at the +axis end ("top"), its radius going
// linearly from radiusBottom to radiusTop. Ring k is the vertices k·around … k·around + around − 1;
// vertex j of a ring is at angle 2πj/around right-handed about the axis, from the direction of the
// world axis (x, then y, then z) least aligned with `axis` made perpendicular to it: +x for the
// default axis y. The seam is closed (ring vertices are shared all the way round, none repeated),
// triangles face outwards and quads are split along alternating diagonals, as in gridCloth. With
// `caps`, two more vertices, the bottom centre (index around·rings) and the top centre (that plus
// one), close the ends with fans of outward triangles, so the surface bounds a volume (a collider
// body).
struct TubeSpec {
  Vec3 center = Vec3(0, 1, 0);
  Vec3 axis = Vec3(0, 1, 0);                 // any non-zero length; only its direction counts
  Real length = 1;                           // m, between the end rings
  Real radiusBottom = Real(0.25);            // m, ring 0
  Real radiusTop = Real(0.25);               // m, the last ring
  std::array<int, 2> resolution = {48, 32};  // vertices around (≥ 3), rings along (≥ 2)
  bool caps = false;
};
ObjectDef tube(const TubeSpec& spec);

// The closed surface of a box (cloth triangles facing outwards), each face a grid of `cells` ×
// `cells` squares split along one diagonal, the faces' shared edges welded: (cells + 1)³ − (cells −
// 1)³ vertices. A rigid box is this with Material::rigidity 1.
ObjectDef boxSurface(const Vec3& center, const Vec3& size, int cells);
// A box of cells[0]×cells[1]×cells[2] cubes, each split into six positively oriented tets that
// share the cube's main diagonal (a conforming mesh: neighbouring cubes agree on shared faces).
ObjectDef tetBox(const Vec3& center, const Vec3& size, const std::array<int, 3>& cells);

// Points on a cubic lattice of the given spacing filling a box (a particle cloud, e.g. a block of
// liquid): round(size / spacing) points along each axis (at least 1), centred in the box, x
// fastest, then y, then z. A liquid block starts at rest density with mass = rest density ×
// count × spacing³.
ObjectDef particleBlock(const Vec3& center, const Vec3& size, Real spacing);

}  // namespace nucleon
