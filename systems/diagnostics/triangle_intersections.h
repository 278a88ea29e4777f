// An exact triangle–triangle intersection checker for the measures (ARCHITECTURE.md §6): how
// many pairs of surface triangles that share no vertex intersect. Independent of the collision
// code on purpose (its own broad phase and its own predicates), so that it can judge it.
//
// Exactness: every decision is the sign of an orientation determinant, evaluated by a
// floating-point filter with Shewchuk's a-priori error bound (Shewchuk 1997, "Adaptive precision
// floating-point arithmetic and fast robust geometric predicates", §4.3) and, when the filter
// cannot decide, exactly in integer arithmetic: every finite double is an integer times a power
// of two, so after scaling all inputs of one predicate by the smallest such power the
// determinant is an integer polynomial. The answer is therefore exact for any finite double
// input (float input is converted to double exactly), including overflow and underflow ranges.
#pragma once

#include <array>
#include <cstddef>
#include <span>

#include "nucleon/types.h"

namespace nucleon {

// Sign (−1, 0, +1) of det[b − a; c − a; d − a] = ((b − a) × (c − a)) · (d − a): positive when d is
// on the side of plane abc that the normal (b − a) × (c − a) points to. Exact for finite input.
int orient3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d);

// Sign of (b − a) × (c − a) in the plane: positive when a, b, c turn counterclockwise. Exact.
int orient2d(double ax, double ay, double bx, double by, double cx, double cy);

using Triangle3d = std::array<Vec3d, 3>;

// True when the triangle's three vertices are collinear (or coincide), exactly: its point set is
// a segment or a point.
bool isDegenerate(const Triangle3d& t);

// Whether two closed triangles intersect: touching at a point or along an edge counts. Exact.
// Non-degenerate pairs use Guigue and Devillers' orientation-only test (Guigue & Devillers
// 2003, "Fast and robust triangle-triangle overlap test using orientation predicates"), coplanar
// pairs a separating-axis test in 2D with orient2d. A degenerate triangle is taken as the point
// set it is (the segment between its extreme vertices, or a point) and tested exactly as such.
bool trianglesIntersect(const Triangle3d& t1, const Triangle3d& t2);

// The same question answered another way, for testing: two closed convex sets of at most three
// points intersect iff an edge of one meets the other (an endpoint of their convex intersection
// lies on an edge of one of them), so this tests the six edges with exact segment–triangle and
// segment–segment predicates. Valid for degenerate triangles too; slower.
bool trianglesIntersectByEdges(const Triangle3d& t1, const Triangle3d& t2);

// The number of unordered pairs of triangles that share no vertex index and intersect as
// closed sets (trianglesIntersect), over `triangles` indexing `positions`. Triangles with a
// non-finite vertex are left out (they intersect nothing); an index out of range throws
// std::out_of_range. Broad phase: a hierarchical grid of power-of-two cells whose size follows
// each triangle's own bounding box (no global cell size, so large and small triangles mix
// without quadratic blow-up) and a sweep along x inside each cell, over exact (unrounded)
// bounding boxes compared as closed intervals; in parallel with oneTBB in the calling task
// arena, and the count does not depend on the thread count. Allocates (it is a measure, not a
// step stage), reusing per-thread buffers between calls.
std::size_t countTriangleIntersections(std::span<const std::array<Index, 3>> triangles,
                                       std::span<const Vec3> positions);

}  // namespace nucleon
