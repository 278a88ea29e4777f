// Continuous collision detection (CCD) narrow phase: whether two primitives moving linearly over
// t ∈ [0, 1] come within a distance d ≥ 0 of each other, and a lower bound of the earliest time
// they do. Pairs: vertex–face, edge–edge, vertex–edge, vertex–vertex. Double precision.
//
// Method: conservative advancement with certified separating planes.
//
// Every pair's difference function F(t, u, v) (point minus face point, or point of one edge minus
// point of the other) is affine in the primitive parameters for fixed t, so at time t its values
// form a convex polytope P(t) = conv{V_i(t)} with k ≤ 4 vertices: p−a, p−b, p−c for vertex–face;
// a−c, a−d, b−c, b−d (a parallelogram) for edge–edge; p−a, p−b for vertex–edge; p−q for
// vertex–vertex. Each V_i(t) is linear in t, and for fixed parameters F is linear in t as well,
// so for a direction n
//     min over P(t) of n·F  ≥  min_i n·V_i(t),
// a minimum of k linear functions of t. If it exceeds d|n| on [t0, t1], the primitives stay
// farther apart than d over that whole interval. This is the co-domain argument of inclusion-based
// CCD (Wang, Ferguson, Schneider et al. 2021, "A Large Scale Benchmark and an Inclusion-Based
// Algorithm for Continuous Collision Detection", §4) taken along one well-chosen direction
// instead of the three coordinate axes, over the whole parameter domain at once, so nothing
// is subdivided in (u, v).
//
// The direction at time t_k is the closest point x of P(t_k) to the origin (the closest points of
// the two primitives, Ericson 2005 §5.1.5 and §5.1.9): its plane supports P(t_k) at distance |x|,
// and the interval it certifies ends where the first vertex's linear bound reaches d — solved in
// closed form, not searched for. The next step starts there (Mirtich 1996, "Impulse-based dynamic
// simulation", conservative advancement; Li et al. 2021, "Codimensional Incremental Potential
// Contact", §5 uses a motion-length bound instead of planes). For a pure translation the first
// plane gives the exact time of impact in one step, and a near miss along a straight path is
// stepped over in one or two steps (the step from a point at distance r approaching at speed s is
// r/s along the current normal, which ends past the closest approach).
//
// Conservative in floating point: n·V_i(t) is evaluated from the rounded inputs with an a-priori
// bound on its rounding error (ccd.cpp: 114 u M for |n_j| ≤ 1, inputs bounded by M, u = 2⁻⁵³;
// 256 u M is used), and every certified interval is checked at both ends with that bound, so no
// time at which the primitives are within d is ever skipped. The answer is a hit at t_k when the
// closest points at t_k are within d + tolerance, when a plane cannot advance (the closest-point
// estimate is off by more than the rounding bound, which only degenerate primitives cause), or
// when the iteration cap is reached: a conservative hit, never a miss. Everything before t_k has
// been certified farther than d, so toi = t_k is a lower bound of the earliest time; with a hit
// by tolerance it is also within that tolerance's worth of motion of it.
//
// Cost: a few tens of floating-point operations per step, no allocation, no branching on
// primitive type inside the loop; a coordinate-axis prefilter (the swept bounding boxes of the two
// primitives, inflated by d, do not overlap) answers far pairs before any closest point.
#pragma once

#include "nucleon/types.h"

namespace nucleon {

struct CcdResult {
  bool hit = false;
  // A lower bound of the earliest time in [0, 1] at which the primitives are within the distance;
  // 1 when there is no hit.
  double toi = 1;
};

struct CcdSettings {
  // A hit is accepted when the closest points are within distance + tolerance × (the extent of
  // the pair's relative configuration): the only source of false positives besides the cap.
  double tolerance = 1e-9;
  // Advancement steps before a conservative hit is returned.
  int maxIterations = 1000;
};

// Point p against triangle abc; suffix 0 at t = 0, 1 at t = 1.
CcdResult vertexFaceCcd(const Vec3d& p0, const Vec3d& a0, const Vec3d& b0, const Vec3d& c0,
                        const Vec3d& p1, const Vec3d& a1, const Vec3d& b1, const Vec3d& c1,
                        double distance, const CcdSettings& settings = {});

// Segment ab against segment cd.
CcdResult edgeEdgeCcd(const Vec3d& a0, const Vec3d& b0, const Vec3d& c0, const Vec3d& d0,
                      const Vec3d& a1, const Vec3d& b1, const Vec3d& c1, const Vec3d& d1,
                      double distance, const CcdSettings& settings = {});

// Point p against segment ab.
CcdResult vertexEdgeCcd(const Vec3d& p0, const Vec3d& a0, const Vec3d& b0, const Vec3d& p1,
                        const Vec3d& a1, const Vec3d& b1, double distance,
                        const CcdSettings& settings = {});

// Point p against point q.
CcdResult vertexVertexCcd(const Vec3d& p0, const Vec3d& q0, const Vec3d& p1, const Vec3d& q1,
                          double distance, const CcdSettings& settings = {});

}  // namespace nucleon
