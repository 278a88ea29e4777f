#include "systems/collision/primitive_contacts.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Eigenvalues>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_scan.h>

#include "systems/collision/broad_phase.h"
#include "systems/collision/ccd.h"
#include "systems/collision/contact_step_lanes.h"
#include "systems/collision/pair_distance_lanes.h"
#include "systems/collision/particle_contacts.h"
#include "systems/collision/primitive_distance.h"

namespace nucleon {
namespace {

constexpr std::size_t kPairGrain = 1024;
// Per-particle loops (the contact gather above all) split into ranges of 256: at 1,024 a pile of
// 1,600 particles (cloth_self) gathered on one thread; 256 took its step 17.5 → 16.9 ms at 2
// threads, the same at 1 thread and on a 16 k-particle pile. The loops write per particle, so the
// result does not depend on the split.
constexpr std::size_t kParticleGrain = 256;
// Candidates per chunk of the narrow phase: its unit of parallel work and of output order.
constexpr std::size_t kContactChunk = 1024;
// Rounds of the fail-safe before it gives up and reports the pairs left (each round stops at
// least one more particle, so this bounds the work, not the outcome of realistic scenes).
constexpr int kMaxFailsafeRounds = 64;
// Rounds in which the impact zones keep their momentum; later ones stop them.
constexpr int kMomentumRounds = kMaxFailsafeRounds / 2;
constexpr double kInfinity = std::numeric_limits<double>::infinity();
// Room (m) a carried lower bound must leave before a pair is passed over: far above the rounding
// of the double arithmetic that carries it, far below any contact distance.
constexpr double kBoundTolerance = 1e-7;
// Halvings of an impact zone's rigid motion before it stops (moveImpactZones).
constexpr int kZoneShareHalvings = 6;

// The particles of a candidate pair, the first primitive's first, with the primitives' radii
// and objects.
struct PairView {
  PairKind kind;
  int count = 0;      // particles in the pair
  int firstSide = 0;  // how many of them belong to the first primitive
  Index id[4] = {0, 0, 0, 0};
  Real radius = 0;  // the two radii summed: the contact distance
  std::uint32_t objectA = 0, objectB = 0;
  Index first = 0, second = 0;  // the primitives
};

PairView viewOf(const CollisionPrimitives& prims, PairKind kind, Index a, Index b) {
  PairView v;
  v.kind = kind;
  v.first = a, v.second = b;
  switch (kind) {
    case PairKind::VertexFace: {
      const auto& t = prims.triangleParticles[b];
      v.count = 4, v.firstSide = 1;
      v.id[0] = prims.pointParticle[a], v.id[1] = t[0], v.id[2] = t[1], v.id[3] = t[2];
      v.radius = prims.pointRadius[a] + prims.triangleRadius[b];
      v.objectA = prims.pointObject[a], v.objectB = prims.triangleObject[b];
      break;
    }
    case PairKind::EdgeEdge: {
      const auto& e = prims.edgeParticles[a];
      const auto& f = prims.edgeParticles[b];
      v.count = 4, v.firstSide = 2;
      v.id[0] = e[0], v.id[1] = e[1], v.id[2] = f[0], v.id[3] = f[1];
      v.radius = prims.edgeRadius[a] + prims.edgeRadius[b];
      v.objectA = prims.edgeObject[a], v.objectB = prims.edgeObject[b];
      break;
    }
    case PairKind::VertexEdge: {
      const auto& e = prims.edgeParticles[b];
      v.count = 3, v.firstSide = 1;
      v.id[0] = prims.pointParticle[a], v.id[1] = e[0], v.id[2] = e[1];
      v.radius = prims.pointRadius[a] + prims.edgeRadius[b];
      v.objectA = prims.pointObject[a], v.objectB = prims.edgeObject[b];
      break;
    }
    case PairKind::VertexVertex:
      v.count = 2, v.firstSide = 1;
      v.id[0] = prims.pointParticle[a], v.id[1] = prims.pointParticle[b];
      v.radius = prims.pointRadius[a] + prims.pointRadius[b];
      v.objectA = prims.pointObject[a], v.objectB = prims.pointObject[b];
      break;
  }
  return v;
}

// Coefficients c_k of the closest points of the pair at positions X (C's gradient directions).
std::array<double, 4> closestCoefficients(PairKind kind, const Vec3d* X) {
  switch (kind) {
    case PairKind::VertexFace: {
      const auto b = closestOnTriangle(X[0], X[1], X[2], X[3]);
      return {1, -b[0], -b[1], -b[2]};
    }
    case PairKind::EdgeEdge: {
      const auto st = closestBetweenSegments(X[0], X[1], X[2], X[3]);
      return {1 - st[0], st[0], -(1 - st[1]), -st[1]};
    }
    case PairKind::VertexEdge: {
      const double t = closestOnSegment(X[0], X[1], X[2]);
      return {1, -(1 - t), -t, 0};
    }
    case PairKind::VertexVertex:
      return {1, -1, 0, 0};
  }
  return {0, 0, 0, 0};
}

Vec3d combine(const std::array<double, 4>& c, const Vec3d* X, int count) {
  Vec3d sum = Vec3d::Zero();
  for (int k = 0; k < count; ++k) sum += c[k] * X[k];
  return sum;
}

// The start distance at or below which the fail-safe takes a pair as touching already, and passes
// it over (resolveCrossings). A vertex–face or edge–edge pair with free particles on both sides is
// crossing-free at any distance above zero, and holding it to its start keeps it so: two parts of
// a sheet pressed flat onto the ground lie within a nanometre of each other, and passed over at
// 1e-9 m a vertex of one slid onto a triangle of the other (cloth_drop_sphere at 3 substeps).
// Within 1e-12 m they are taken as coincident, as a float build rounds them: checked down to zero,
// the double build's torn cloth (the lips of a tear) left pairs unresolved and a frame with an
// intersection. Against a side with no free particle (a collider, a pinned group), or between
// isolated points, within 1e-9 m is touching: the water of liquid_paddle has thousands of such
// pairs against its box and paddle in the double build, which the fail-safe could not hold in 64
// rounds.
// Whether each side of a pair has a particle of nonzero inverse mass.
struct FreeSides {
  bool first = false, second = false;
};
FreeSides freeSides(const PairView& v, const ParticlePool& particles) {
  FreeSides sides;
  for (int k = 0; k < v.count; ++k)
    (k < v.firstSide ? sides.first : sides.second) |= particles.w[v.id[k]] > 0;
  return sides;
}

double touchingDistance(const PairView& v, const ParticlePool& particles) {
  if (v.kind != PairKind::VertexFace && v.kind != PairKind::EdgeEdge) return 1e-9;
  const FreeSides sides = freeSides(v, particles);
  return sides.first && sides.second ? 1e-12 : 1e-9;
}

// Earliest time in [0, 1] at which the pair, moving linearly from X0 to X1, may come within
// `distance`; conservative (systems/collision/ccd.h).
CcdResult pairCcd(PairKind kind, const Vec3d* X0, const Vec3d* X1, double distance) {
  switch (kind) {
    case PairKind::VertexFace:
      return vertexFaceCcd(X0[0], X0[1], X0[2], X0[3], X1[0], X1[1], X1[2], X1[3], distance);
    case PairKind::EdgeEdge:
      return edgeEdgeCcd(X0[0], X0[1], X0[2], X0[3], X1[0], X1[1], X1[2], X1[3], distance);
    case PairKind::VertexEdge:
      return vertexEdgeCcd(X0[0], X0[1], X0[2], X1[0], X1[1], X1[2], distance);
    case PairKind::VertexVertex:
      return vertexVertexCcd(X0[0], X0[1], X1[0], X1[1], distance);
  }
  return CcdResult{};
}

// Bound on how much the distance between the two primitives can shrink over the motion X0 → X1.
// The distance does not change under a translation common to both, so take away the first
// particle's displacement u_0 from every particle: each point of a side then moves at most the
// largest |u_k − u_0| of that side (a point of a primitive is a fixed convex combination of its
// particles), and the distance, 1-Lipschitz in each point, shrinks by at most the two summed.
// Relative: a cloth falling as a whole has neighbours whose bound is near zero.
double motionBound(const PairView& v, const Vec3d* X0, const Vec3d* X1) {
  // The largest squared length per side, then one root each: the same value as the largest
  // length (the root is monotone and correctly rounded), with fewer roots.
  const Vec3d u0 = X1[0] - X0[0];
  double a = 0, b = 0;
  for (int k = 1; k < v.count; ++k) {
    const double d = (X1[k] - X0[k] - u0).squaredNorm();
    if (k < v.firstSide)
      a = std::max(a, d);
    else
      b = std::max(b, d);
  }
  return std::sqrt(a) + std::sqrt(b);
}

// A lower bound on the distance between the two primitives at X: the gap between the boxes of
// their particles (a few comparisons against a closest-point computation).
double boxDistance(const PairView& v, const Vec3d* X) {
  Vec3d lowerA = X[0], upperA = X[0];
  for (int k = 1; k < v.firstSide; ++k)
    lowerA = lowerA.cwiseMin(X[k]), upperA = upperA.cwiseMax(X[k]);
  Vec3d lowerB = X[v.firstSide], upperB = X[v.firstSide];
  for (int k = v.firstSide + 1; k < v.count; ++k)
    lowerB = lowerB.cwiseMin(X[k]), upperB = upperB.cwiseMax(X[k]);
  const Vec3d gap = (lowerB - upperA).cwiseMax(lowerA - upperB).cwiseMax(0.0);
  return gap.norm();
}

// Whether the contact of pair `v` with closest-point coefficients `c` is another pair's contact
// again (primitive_contacts.h, "One contact per feature"): a vertex–face pair whose closest point
// is a vertex or edge its triangle does not own; an edge–edge pair whose closest point is an end
// of one edge, or a point–edge pair, where the point's vertex–face pairs with the edge's
// triangles hold it.
// Whether a point of object `pointObject` meets `edge` through the edge's triangles (vertex–face
// pairs): the object collides with its vertices and the edge belongs to a triangle.
bool heldByFaces(const CollisionPrimitives& prims, std::uint32_t pointObject, Index edge) {
  return pointObject < prims.objectFlags.size() &&
         (prims.objectFlags[pointObject] & kCollideVertices) != 0 &&
         edge < prims.edgeTriangle.size() &&
         prims.edgeTriangle[edge] != CollisionPrimitives::kNoTriangle;
}

bool duplicateFeature(const PairView& v, const std::array<double, 4>& c,
                      const CollisionPrimitives& prims) {
  if (v.kind == PairKind::VertexFace) {
    if (v.second >= prims.triangleOwnership.size()) return false;
    const std::uint8_t owns = prims.triangleOwnership[v.second];
    const int zeros = (c[1] == 0) + (c[2] == 0) + (c[3] == 0);
    if (zeros == 2) {
      const int vertex = c[1] != 0 ? 0 : c[2] != 0 ? 1 : 2;
      return (owns & (1u << vertex)) == 0;
    }
    if (zeros == 1) {
      // The edge opposite the vertex with weight 0: from vertex k + 1 to k + 2.
      const int opposite = c[1] == 0 ? 0 : c[2] == 0 ? 1 : 2;
      return (owns & (1u << (3 + (opposite + 1) % 3))) == 0;
    }
    return false;
  }
  // An isolated point meets an edge of a mesh through that edge's triangles.
  if (v.kind == PairKind::VertexEdge) return heldByFaces(prims, v.objectA, v.second);
  if (v.kind != PairKind::EdgeEdge) return false;
  const bool endA = c[0] == 0 || c[1] == 0, endB = c[2] == 0 || c[3] == 0;
  return (endA && heldByFaces(prims, v.objectA, v.second)) ||
         (endB && heldByFaces(prims, v.objectB, v.first));
}

// Makes the contact of candidate pair `v` if it may come within reach; false if it cannot.
bool makeContact(const PairView& v, const CollisionPrimitives& prims, const ParticlePool& particles,
                 const ObjectSurface* surfaces, double& startDistance, double& lowerBound,
                 PrimitiveContactRecord& out) {
  lowerBound = -kInfinity;
  Vec3d X0[4] = {Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero()};
  Vec3d X1[4] = {Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero()};
  for (int k = 0; k < v.count; ++k) {
    X0[k] = particles.x[v.id[k]].cast<double>();
    X1[k] = particles.p[v.id[k]].cast<double>();
  }
  const double reach = double(v.radius) + double(kPrimitiveContactMargin);
  const double motion = motionBound(v, X0, X1);
  // The start distance is what the fail-safe needs of every pair, and a lower bound serves it as
  // long as it is positive (a pair at distance 0 is left to its contact). The box gap is one, and
  // where it already rules the contact out, the exact distance is not computed.
  const double gapBound = boxDistance(v, X0);
  if (gapBound > 1e-9 && (gapBound - motion > reach || !std::isfinite(motion))) {
    startDistance = gapBound;
    if (std::isfinite(motion)) lowerBound = gapBound - motion;
    return false;
  }
  const auto c0 = closestCoefficients(v.kind, X0);
  const Vec3d gap0 = combine(c0, X0, v.count);
  startDistance = gap0.norm();
  if (!std::isfinite(startDistance) || !std::isfinite(motion)) return false;
  lowerBound = startDistance - motion;
  if (lowerBound > reach) return false;
  // Along the predicted motion the distance is at least max(d0 − t L, d1 − (1 − t) L), whose
  // smallest value over t is (d0 + d1 − L) / 2.
  const auto c1 = closestCoefficients(v.kind, X1);
  const Vec3d gap1 = combine(c1, X1, v.count);
  const double endDistance = gap1.norm();
  // A non-finite prediction gets no contact, so that it cannot spread to the pair's other
  // particles; the update resets and counts it.
  if (!std::isfinite(endDistance)) return false;
  lowerBound = std::max(lowerBound, (startDistance + endDistance - motion) / 2);
  if (lowerBound > reach) return false;

  // The configuration the contact is linearised at: where the pair first comes within its
  // contact distance if it does during the predicted motion, else the predicted end.
  // CCD only where the bound above leaves room to come within the contact distance, and not
  // where the pair starts within it: CCD's first step would answer the start (t = 0).
  const bool mayImpact = (startDistance + endDistance - motion) / 2 <= double(v.radius);
  const bool touching = mayImpact && startDistance <= double(v.radius);
  // Without CCD the contact is linearised at the predicted end, with the end's closest points
  // unless they touch: a duplicate is known before anything more is computed (and likewise at
  // the start for a pair that starts within reach).
  if (!mayImpact && endDistance > 1e-9 * std::max(1.0, X1[0].cwiseAbs().maxCoeff()) &&
      duplicateFeature(v, c1, prims))
    return false;
  if (touching && startDistance > 1e-9 * std::max(1.0, X0[0].cwiseAbs().maxCoeff()) &&
      duplicateFeature(v, c0, prims))
    return false;
  if (v.objectA == v.objectB) {
    // Held apart by the mesh itself: no contact between primitives of one object that are closer
    // than their contact distance in the rest shape (they would push the mesh away from its rest
    // shape); the fail-safe still checks them for crossings. (Dropping also the pairs within
    // reach, contact distance + margin, in the rest shape cut contacts on a single cloth layer
    // but let folded layers of cloth_self press through to the ground: measured worse.)
    // A torn cloth's copies keep their original's rest position: pairs across an opened cut
    // are not held apart by the mesh any more, so they collide (CollisionPrimitives::acrossCut).
    Vec3d R[4] = {Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero()};
    for (int k = 0; k < v.count; ++k) R[k] = particles.restPosition[v.id[k]].cast<double>();
    const std::span<const Index> ids(v.id, static_cast<std::size_t>(v.count));
    if (!prims.acrossCut(ids.first(static_cast<std::size_t>(v.firstSide)),
                         ids.subspan(static_cast<std::size_t>(v.firstSide))) &&
        boxDistance(v, R) < double(v.radius) &&
        combine(closestCoefficients(v.kind, R), R, v.count).norm() < double(v.radius))
      return false;
  }
  const CcdResult impact = mayImpact && !touching ? pairCcd(v.kind, X0, X1, double(v.radius))
                                                  : CcdResult{touching, touching ? 0.0 : 1.0};
  const double t = impact.hit ? std::clamp(impact.toi, 0.0, 1.0) : 1.0;
  // At either end of the motion the closest points are those above ((1 − t) X0 + t X1 is then
  // X0 or X1 exactly).
  Vec3d X[4] = {Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero()};
  for (int k = 0; k < v.count; ++k) X[k] = (1 - t) * X0[k] + t * X1[k];
  std::array<double, 4> c = t == 0 ? c0 : c1;
  Vec3d n = t == 0 ? gap0 : gap1;
  if (t > 0 && t < 1) {
    c = closestCoefficients(v.kind, X);
    n = combine(c, X, v.count);
  }
  const double scale = 1e-9 * std::max(1.0, X[0].cwiseAbs().maxCoeff());
  if (n.norm() <= scale) {
    // Touching at the impact (zero contact distance): the side the pair started on.
    c = c0;
    n = gap0;
  }
  if (n.norm() <= scale) {
    // Coincident at the start as well: a face's normal, else any fixed direction.
    if (v.kind == PairKind::VertexFace) n = (X[2] - X[1]).cross(X[3] - X[1]);
    if (!(n.norm() > 0)) n = Vec3d(0, 1, 0);
  }
  if (duplicateFeature(v, c, prims)) return false;
  n.normalize();

  const ObjectSurface& a = surfaces[v.objectA];
  const ObjectSurface& b = surfaces[v.objectB];
  out.particles = {v.id[0], v.id[1], v.id[2], v.id[3]};
  Vec3d relativeVelocity = Vec3d::Zero();
  for (int k = 0; k < v.count; ++k) {
    out.coefficient[k] = static_cast<Real>(c[k]);
    relativeVelocity += c[k] * particles.v[v.id[k]].cast<double>();
  }
  for (int k = v.count; k < 4; ++k) out.coefficient[k] = 0;
  out.normal = n.cast<Real>();
  out.distance = v.radius;
  out.friction = (a.friction + b.friction) / 2;
  out.staticFriction = (a.staticFriction + b.staticFriction) / 2;
  out.restitution = std::max(a.restitution, b.restitution);
  out.stickiness = std::max(a.stickiness, b.stickiness);
  out.approachSpeed = static_cast<Real>(n.dot(relativeVelocity));
  // Σ w_k c_k²: the generalised inverse mass along the normal (w does not change in a substep).
  out.inverseMass = 0;
  for (int k = 0; k < 4; ++k)
    out.inverseMass += particles.w[out.particles[k]] * out.coefficient[k] * out.coefficient[k];
  return true;
}

// The narrow phase's first filter over a block of up to kPairLanes consecutive candidates
// (systems/collision/pair_distance_lanes.h): their vertex–face and edge–edge pairs are measured
// in float lanes. A pair whose bounds, less the lanes' error, keep it out of reach over the
// motion, and an edge–edge pair whose contact would be another pair's (duplicateFeature: its
// closest points at an end of an edge, which both sides' vertex–face pairs hold) where
// makeContact would look, get their start distance and lower bound from the lanes, as
// makeContact would give them (within that error, on the safe side), and no contact; the rest go
// on to makeContact.
struct LaneFilter {
  PairView view[kPairLanes];
  bool measured[kPairLanes] = {};  // the candidate needs nothing more
  int laneOf[kPairLanes] = {};     // its lane in the lanes of its kind; −1 if in none
  // makeContact's scale of "touching" at the start and at the end: 1e-9 × max(1, |X[0]|).
  double touchScale[2][kPairLanes] = {};
  PairLanes lanes[2] = {};  // vertex–face, edge–edge
  PairLaneBounds bounds[2] = {};
  int used[2] = {0, 0};

  void clear() { used[0] = used[1] = 0; }

  void add(std::size_t slot, const ParticlePool& particles) {
    const PairView& v = view[slot];
    laneOf[slot] = -1;
    const int group = v.kind == PairKind::VertexFace ? 0 : v.kind == PairKind::EdgeEdge ? 1 : -1;
    if (group < 0) return;
    PairLanes& l = lanes[group];
    const int lane = used[group];
    const Vec3 x0 = particles.x[v.id[0]], p0 = particles.p[v.id[0]];
    bool finite = true;
    for (int k = 1; k < 4; ++k) {
      const Vec3 start = particles.x[v.id[k]] - x0, end = particles.p[v.id[k]] - p0;
      for (int axis = 0; axis < 3; ++axis) {
        l.start[k][axis][lane] = static_cast<float>(start[axis]);
        l.end[k][axis][lane] = static_cast<float>(end[axis]);
        finite &= std::isfinite(l.start[k][axis][lane]) && std::isfinite(l.end[k][axis][lane]);
      }
    }
    // A pair with a coordinate that is not finite is left to makeContact, which does not make
    // its contact.
    if (!finite) return;
    touchScale[0][slot] = 1e-9 * std::max(1.0, double(x0.cwiseAbs().maxCoeff()));
    touchScale[1][slot] = 1e-9 * std::max(1.0, double(p0.cwiseAbs().maxCoeff()));
    laneOf[slot] = lane;
    ++used[group];
  }

  void run() {
    if (used[0] > 0) vertexFaceLaneBounds(lanes[0], bounds[0]);
    if (used[1] > 0) edgeEdgeLaneBounds(lanes[1], bounds[1]);
  }

  // Whether the lanes show that makeContact would make no contact for candidate `slot`: then
  // `startDistance` and `lowerBound` are set as makeContact sets them for such a pair.
  bool settle(std::size_t slot, const PairView& v, const CollisionPrimitives& prims,
              double& startDistance, double& lowerBound) const {
    const int lane = laneOf[slot];
    if (lane < 0) return false;
    const PairLaneBounds& b = bounds[v.kind == PairKind::VertexFace ? 0 : 1];
    const double error = double(kPairLaneTolerance) * double(b.extent[lane]);
    const double start = double(b.startDistance[lane]) - error,
                 end = double(b.endDistance[lane]) - error, motion = double(b.motion[lane]) + error;
    if (!(start > 0)) return false;
    const double bound = std::max(start - motion, (start + end - motion) / 2);
    const auto settled = [&] {
      startDistance = start;
      lowerBound = bound;
      return true;
    };
    if (bound > double(v.radius) + double(kPrimitiveContactMargin) + kBoundTolerance)
      return settled();
    if (v.kind != PairKind::EdgeEdge || !heldByFaces(prims, v.objectA, v.second) ||
        !heldByFaces(prims, v.objectB, v.first))
      return false;
    // makeContact's two early duplicates: at the end where no impact is possible, at the
    // start where the pair starts within its contact distance. The lanes' closest points are
    // at an end of an edge there, and each side's vertices meet the other edge's triangles.
    const double radius = double(v.radius);
    if ((start + end - motion) / 2 > radius && end > touchScale[1][slot] &&
        b.endFeature[lane] == float(kEdgeEnds))
      return settled();
    const double startAbove = double(b.startDistance[lane]) + error;
    if (startAbove < radius && start > touchScale[0][slot] &&
        b.startFeature[lane] == float(kEdgeEnds))
      return settled();
    return false;
  }
};

// The tangential correction of contact c over the substep (Coulomb, position level): the relative
// tangential motion d_t of the contact points is removed entirely if |d_t| ≤ μ_s λ_n and by
// μ_k λ_n otherwise.
Vec3 frictionStep(const PrimitiveContactPool& pool, const ParticlePool& particles, std::size_t c) {
  const Real lambda = pool.lambda[c];
  if (!(lambda > 0)) return Vec3::Zero();
  Vec3 d = Vec3::Zero();
  for (int k = 0; k < 4; ++k) {
    const Index i = pool.particles[c][k];
    d += pool.coefficient[c][k] * (particles.p[i] - particles.x[i]);
  }
  const Vec3& n = pool.normal[c];
  const Vec3 tangential = d - n * n.dot(d);
  const Real length = tangential.norm();
  if (!(length > 0)) return Vec3::Zero();
  const Real m = pool.inverseMass[c];
  if (!(m > 0)) return Vec3::Zero();
  const Real removed = length <= pool.staticFriction[c] * lambda
                           ? Real(1)
                           : std::min(pool.friction[c] * lambda / length, Real(1));
  return -removed * tangential / m;
}

// Applies per-contact corrections (contact c moves particle k of it by w_k c_k · correction(c))
// gathered per particle in contact order and averaged over the particle's active contacts.
template <class Correction>
void gatherCorrections(const PrimitiveContactPool& pool, ParticlePool& particles,
                       Correction&& correction) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pool.touched.size(), kParticleGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t t = r.begin(); t != r.end(); ++t) {
                        const Index i = pool.touched[t];
                        Vec3 sum = Vec3::Zero();
                        int active = 0;
                        for (Index e = pool.incidenceOffset[i]; e < pool.incidenceOffset[i + 1];
                             ++e) {
                          // Without a branch: whether a contact is pressed changes from
                          // round to round, and a zero correction adds nothing to the sum.
                          const Vec3 delta = correction(pool.incidence[e] >> 2);
                          sum += pool.incidenceCoefficient[e] * delta;
                          active += (delta.x() != 0) | (delta.y() != 0) | (delta.z() != 0);
                        }
                        if (active > 0) particles.p[i] += particles.w[i] * sum / Real(active);
                      }
                    });
}

// A parallel round where some contacts hold a liquid particle (pool.splitParticle). Those are
// mass-split (Tonge et al. 2012): each particle k takes them with n_k times its inverse mass, n_k
// its pressed contacts, each such step is scaled from Σ c_k² w_k to Σ c_k² w_k n_k, and a particle
// moves by their sum, so each exchanges equal and opposite impulses. The other contacts keep the
// mean of a particle's pressed ones, as in a world without liquids. Averaged, a cloth vertex
// pressed by many particles of water took one push while each particle took its own: the cloth
// carried about a tenth of the water resting on it (bench/results/2core-AMD-EPYC/liquids.md).
// Splitting every contact kept the load but cost cloth piles and impacts their convergence (a
// particle touching crowded ones is pushed by a fraction of its step), so only the liquids' are.
void applySplitAndMeanSteps(PrimitiveContactPool& pool, ParticlePool& particles) {
  const std::size_t n = pool.size();
  const auto splits = [&](std::size_t c) {
    for (int k = 0; k < 4; ++k)
      if (pool.coefficient[c][k] != 0 && pool.splitParticle[pool.particles[c][k]]) return true;
    return false;
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pool.touched.size(), kParticleGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t t = r.begin(); t != r.end(); ++t) {
                        const Index i = pool.touched[t];
                        Index active = 0;
                        for (Index e = pool.incidenceOffset[i]; e < pool.incidenceOffset[i + 1];
                             ++e)
                          active += pool.step[pool.incidence[e] >> 2] != 0;
                        pool.pressedCount[i] = active;
                      }
                    });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPairGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        const Real step = pool.step[c];
                        if (step == 0 || !splits(c)) continue;
                        Real split = 0;
                        for (int k = 0; k < 4; ++k) {
                          const Real coefficient = pool.coefficient[c][k];
                          const Index i = pool.particles[c][k];
                          split += coefficient * coefficient * particles.w[i] *
                                   Real(std::max<Index>(pool.pressedCount[i], 1));
                        }
                        const Real m = pool.inverseMass[c];
                        const Real scaled = split > 0 ? step * (m / split) : Real(0);
                        pool.lambda[c] += (scaled - step) * m;
                        pool.step[c] = scaled;
                        pool.splitStep[c] = 1;
                      }
                    });
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, pool.touched.size(), kParticleGrain),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t t = r.begin(); t != r.end(); ++t) {
          const Index i = pool.touched[t];
          Vec3 summed = Vec3::Zero(), averaged = Vec3::Zero();
          int active = 0;
          for (Index e = pool.incidenceOffset[i]; e < pool.incidenceOffset[i + 1]; ++e) {
            const Index c = pool.incidence[e] >> 2;
            if (pool.step[c] == 0) continue;
            const Vec3 delta = pool.incidenceCoefficient[e] * Vec3(pool.step[c] * pool.normal[c]);
            if (pool.splitStep[c]) {
              summed += delta;
            } else {
              averaged += delta;
              ++active;
            }
          }
          if (active > 0) summed += averaged / Real(active);
          particles.p[i] += particles.w[i] * summed;
          pool.pressedCount[i] = 0;
        }
      });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPairGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) pool.splitStep[c] = 0;
                    });
}

// A round whose pressed contacts are at most 1/kScatterShare of all is applied by
// scatterPressedSteps: the gather reads every contact of every touched particle, most of them
// unpressed (cloth_drop_sphere's pile presses about one contact in twelve per round).
constexpr std::size_t kScatterShare = 4;

// The gather's corrections for a round with few pressed contacts, in one pass over them: each
// pressed contact adds c_k × step × normal to its particles' sums in contact order, the order of
// the gather's incidence lists, and each such particle then moves by w × sum / count. The same
// bits as gatherCorrections, whose zero corrections add nothing to a sum. Serial: the pressed
// contacts are few, and the order of the sums must not depend on the thread count.
void scatterPressedSteps(PrimitiveContactPool& pool, ParticlePool& particles) {
  const std::size_t n = pool.size();
  pool.pressedParticles.clear();
  for (std::size_t c = 0; c < n; ++c) {
    const Real step = pool.step[c];
    if (step == 0) continue;
    const Vec3 delta = step * pool.normal[c];
    for (int k = 0; k < 4; ++k) {
      const Real coefficient = pool.coefficient[c][k];
      if (coefficient == 0) continue;
      const Index i = pool.particles[c][k];
      if (pool.pressedCount[i]++ == 0) pool.pressedParticles.push_back(i);
      pool.pressedSum[i] += coefficient * delta;
    }
  }
  for (const Index i : pool.pressedParticles) {
    particles.p[i] += particles.w[i] * pool.pressedSum[i] / Real(pool.pressedCount[i]);
    pool.pressedSum[i].setZero();
    pool.pressedCount[i] = 0;
  }
}

// The mean substep motion p − x of the free particles with a finite one, summed over fixed
// chunks in order, so that it does not depend on the thread count.
Vec3d meanMotion(const ParticlePool& particles, std::vector<Vec3d>& sums,
                 std::vector<std::size_t>& counts) {
  const std::size_t n = particles.size(), chunks = (n + kParticleGrain - 1) / kParticleGrain;
  sums.assign(chunks, Vec3d::Zero());
  counts.assign(chunks, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t chunk = r.begin(); chunk != r.end(); ++chunk)
                        for (std::size_t i = chunk * kParticleGrain;
                             i < std::min(n, (chunk + 1) * kParticleGrain); ++i) {
                          const Vec3d u = (particles.p[i] - particles.x[i]).cast<double>();
                          if (particles.w[i] == 0 || !u.allFinite()) continue;
                          sums[chunk] += u;
                          ++counts[chunk];
                        }
                    });
  Vec3d sum = Vec3d::Zero();
  std::size_t count = 0;
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) sum += sums[chunk], count += counts[chunk];
  return count > 0 ? Vec3d(sum / double(count)) : Vec3d::Zero();
}

// out[list][i]: `valueOf` of the particles of primitive i of each list.
template <class T, class ValueOf>
void gatherPerPrimitive(std::array<std::vector<T>, 3>& out, const CollisionPrimitives& prims,
                        const ValueOf& valueOf) {
  out[0].resize(prims.points());
  out[1].resize(prims.edges());
  out[2].resize(prims.triangles());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, prims.points(), kParticleGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        out[0][i] = valueOf(std::span<const Index>(&prims.pointParticle[i], 1));
                    });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, prims.edges(), kParticleGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        out[1][i] = valueOf(std::span<const Index>(prims.edgeParticles[i]));
                    });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, prims.triangles(), kParticleGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        out[2][i] = valueOf(std::span<const Index>(prims.triangleParticles[i]));
                    });
}

// The rigid motion x → R x + t of kinematic particles `ids` (one to three), from their
// positions at the start (x) and end (p) of the substep: the frame of a triangle, the shortest
// turn of an edge about its midpoint, the displacement of a point. Exact for particles that move
// rigidly (a keyframed collider, a pinned ring); for a bent body, the rigid motion of that
// triangle.
struct RigidMotion {
  Mat3d rotation = Mat3d::Identity();
  Vec3d translation = Vec3d::Zero();
};

RigidMotion kinematicMotion(const Index* ids, int count, const ParticlePool& particles) {
  RigidMotion motion;
  // Particles that stand still or only translate (the common case) get exactly that, unrounded.
  const Vec3 shift = particles.p[ids[0]] - particles.x[ids[0]];
  bool translates = true;
  for (int k = 1; k < count; ++k) translates &= particles.p[ids[k]] - particles.x[ids[k]] == shift;
  if (translates) {
    motion.translation = shift.cast<double>();
    return motion;
  }
  Vec3d X0[3], X1[3];
  for (int k = 0; k < count; ++k) {
    X0[k] = particles.x[ids[k]].cast<double>();
    X1[k] = particles.p[ids[k]].cast<double>();
  }
  const auto frame = [](const Vec3d* X, Mat3d& F) {
    const Vec3d e1 = (X[1] - X[0]).normalized();
    const Vec3d n = e1.cross(X[2] - X[0]).normalized();
    F.col(0) = e1, F.col(1) = n.cross(e1), F.col(2) = n;
    return F.allFinite();
  };
  Mat3d F0, F1;
  if (count == 3 && (X0[1] - X0[0]).cross(X0[2] - X0[0]).norm() > 1e-12 &&
      (X1[1] - X1[0]).cross(X1[2] - X1[0]).norm() > 1e-12 && frame(X0, F0) && frame(X1, F1)) {
    motion.rotation = F1 * F0.transpose();
    motion.translation = X1[0] - motion.rotation * X0[0];
  } else if (count >= 2 && (X0[1] - X0[0]).norm() > 1e-12 && (X1[1] - X1[0]).norm() > 1e-12) {
    motion.rotation =
        Eigen::Quaterniond::FromTwoVectors(X0[1] - X0[0], X1[1] - X1[0]).toRotationMatrix();
    motion.translation = (X1[0] + X1[1]) / 2 - motion.rotation * ((X0[0] + X0[1]) / 2);
  } else {
    motion.translation = X1[0] - X0[0];
  }
  if (!motion.rotation.allFinite() || !motion.translation.allFinite()) motion = RigidMotion{};
  return motion;
}

// What the fail-safe holds the free particles of a pair to when one side has no free particle:
// the rigid motion of that side, taken from a triangle of its object that contains it where one
// is kinematic throughout (a point or an edge alone leaves the turn about itself unknown), and
// the precedence of that motion: a lower object, then a lower triangle (or particle), first.
struct Carry {
  std::uint64_t precedence = 1;  // 1: an impact zone
  RigidMotion motion;
};

// A body's precedence: its object in the high 32 bits and its triangle or lowest particle in the
// low ones, each complemented so that the lower index ranks higher.
std::uint64_t bodyPrecedence(std::uint32_t object, Index primitive) {
  constexpr std::uint64_t kMax = std::numeric_limits<std::uint32_t>::max();
  return (kMax - object) << 32 | (kMax - primitive);
}

Carry kinematicCarry(const PairView& v, bool firstSide, PairKind kind, Index primitive,
                     const CollisionPrimitives& prims, const ParticlePool& particles) {
  Index triangle = CollisionPrimitives::kNoTriangle;
  const bool point = firstSide ? kind != PairKind::EdgeEdge : kind == PairKind::VertexVertex;
  const bool edge = !point && (firstSide || kind != PairKind::VertexFace);
  if (!firstSide && kind == PairKind::VertexFace)
    triangle = primitive;
  else if (point && primitive < prims.pointTriangle.size())
    triangle = prims.pointTriangle[primitive];
  else if (edge && primitive < prims.edgeTriangle.size())
    triangle = prims.edgeTriangle[primitive];
  const std::uint32_t object = firstSide ? v.objectA : v.objectB;
  Carry carry;
  if (triangle != CollisionPrimitives::kNoTriangle) {
    const auto& t = prims.triangleParticles[triangle];
    if (particles.w[t[0]] == 0 && particles.w[t[1]] == 0 && particles.w[t[2]] == 0) {
      carry.precedence = bodyPrecedence(object, triangle);
      carry.motion = kinematicMotion(t.data(), 3, particles);
      return carry;
    }
  }
  const int begin = firstSide ? 0 : v.firstSide, end = firstSide ? v.firstSide : v.count;
  Index lowest = v.id[begin];
  for (int k = begin; k < end; ++k) lowest = std::min(lowest, v.id[k]);
  carry.precedence = bodyPrecedence(object, lowest);
  carry.motion = kinematicMotion(v.id + begin, end - begin, particles);
  return carry;
}

// The same for a pair with free particles on both sides and kinematic particles among them that
// move this substep (a sheet's own pinned row, animated, in a pair with its free rows). An impact
// zone that stops at the substep's start cannot resolve such a pair: the pinned particles move on
// and cross the stopped ones (flag_whip under Gauss–Seidel left such pairs unresolved from frame
// 17 on, and its sheet then passed through itself). Held to the rigid motion of the pair's moving
// kinematic particles, the whole pair keeps its crossing-free start where they move rigidly (a
// pinned group that translates or turns as one). Precedence as a body of the first such
// particle's object. False, changing nothing, when the pair has no moving kinematic particle or
// theirs is no common rigid motion (two pinned groups pulling a sheet apart): within 1 µm plus a
// millionth of their travel, room for the float rounding of a keyframed group.
constexpr double kRigidTolerance = 1e-6;
bool movingKinematicCarry(const PairView& v, const ParticlePool& particles, Carry& carry) {
  Index moving[4];
  int count = 0;
  int side = 0;
  for (int k = 0; k < v.count; ++k) {
    const Index id = v.id[k];
    if (particles.w[id] != 0 || particles.p[id] == particles.x[id]) continue;
    if (count == 0) side = k < v.firstSide ? 0 : 1;
    moving[count++] = id;
  }
  if (count == 0) return false;
  Index lowest = moving[0];
  for (int k = 1; k < count; ++k) lowest = std::min(lowest, moving[k]);
  const std::uint32_t object = side == 0 ? v.objectA : v.objectB;
  const RigidMotion motion = kinematicMotion(moving, std::min(count, 3), particles);
  // Only a motion that takes every one of them where it goes: kinematic particles of two groups
  // that move apart (a sheet torn by its two pinned halves) have no common motion to keep the
  // pair's start, and their pair stays in its zone.
  for (int k = 0; k < count; ++k) {
    const Vec3d x = particles.x[moving[k]].cast<double>(),
                p = particles.p[moving[k]].cast<double>();
    const Vec3d moved = motion.rotation * x + motion.translation;
    if (!((moved - p).norm() <= kRigidTolerance * (1 + (p - x).norm()))) return false;
  }
  carry.precedence = bodyPrecedence(object, lowest);
  carry.motion = motion;
  return true;
}

// The impact zone of particle i (union–find with path halving); i must be in one.
Index zoneOf(std::vector<Index>& parent, Index i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

// Puts particle i in the zone `root` (kNoZone: a zone of its own); returns the joined zone's root.
// The lower root survives a merge, so that the zones do not depend on anything but pair order.
Index joinZone(std::vector<Index>& parent, Index i, Index root) {
  if (parent[i] == PrimitiveContactPool::kNoZone) parent[i] = i;
  const Index own = zoneOf(parent, i);
  if (root == PrimitiveContactPool::kNoZone || root == own) return own;
  const Index low = std::min(own, root), high = std::max(own, root);
  parent[high] = low;
  return low;
}

// Whether a pair moves with one impact zone as the last round moved it, far enough from touching
// that the zone's motion cannot take it to contact. A rigid motion of the crossing-free start
// keeps the pair uncrossed (moveImpactZones): its straight-line path is the affine map
// (1 − s) 1 + s R, whose smallest stretch is cos(θ/2) for a turn θ, so the pair's distance stays
// above cos(θ/2) times its start distance, less the rounding of the targets to Real (half an
// ulp of each coordinate, within 4 ε max|x| for the pair's two closest points). The CCD need not
// be asked, and is best not: conservative advancement steps a turning pair a hair's breadth apart
// forward by a sliver of the substep at a time, and at its iteration cap it reports a hit (two
// cloth edges 6.8 × 10⁻⁷ m apart in a zone turning through about 18°: capped at t = 0.108, free
// with ten times the steps). Reported crossing in every round, such a pair held the zones until
// they stopped outright at half the round limit, and the particles stopped with them stretched the
// cloth around them (cloth_drop_sphere at 2 substeps × 10 sweeps: edges at 3.8 times their
// length). Read-only on the union–find, so it may run in parallel.
bool movesWithOneZone(const PairView& v, const PrimitiveContactPool& contacts,
                      const ParticlePool& particles, const Vec3d* X1, double startDistance) {
  const auto rootOf = [&](Index i) {
    while (contacts.zoneParent[i] != i) i = contacts.zoneParent[i];
    return i;
  };
  Index root = PrimitiveContactPool::kNoZone;
  double largest = 0;
  for (int k = 0; k < v.count; ++k) {
    const Index id = v.id[k];
    if (particles.w[id] == 0 || contacts.carryPrecedence[id] != 1) return false;
    const Index own = rootOf(id);
    if (root != PrimitiveContactPool::kNoZone && own != root) return false;
    root = own;
    largest = std::max(largest, X1[k].cwiseAbs().maxCoeff());
  }
  const Index slot = contacts.zoneSlot[root];
  if (slot == PrimitiveContactPool::kNoZone) return false;
  // cos(θ/2) = √((trace R + 1) / 4).
  const double halfTurnCosine =
      std::sqrt(std::max(contacts.zones[slot].rotation.trace() + 1, 0.0) / 4);
  const double rounding = 4 * double(std::numeric_limits<Real>::epsilon()) * largest;
  return halfTurnCosine * startDistance > rounding + kBoundTolerance;
}

// A zone whose rigid motion takes one of its particles deeper into one plane collider's contact
// layer (a crumpled patch of cloth lying on the ground, still falling) keeps the part of its
// motion the plane allows: the translation less its component into the plane, the turn about the
// plane's normal only, which keep every particle's height above the plane (the plane takes the
// rest of the momentum, as its contact would). Halving the whole motion instead (below) never
// clears a zone that is still falling, however slowly: it stopped where the substep began, and
// its particles, held still while the cloth around them moved on, stretched their edges
// (torture/high_drop at one substep: edges beyond 3 times their length in 6 frames, and 11
// crossing pairs left unresolved; sliding, none, the worst edge at 2.9 times). Zones that
// would enter several planes, or a sphere, are left to the halving.
template <class ZoneOf, class TargetOf>
void slideZonesAlongPlanes(std::vector<PrimitiveContactPool::ImpactZone>& zones, ZoneOf&& zoneOf,
                           TargetOf&& targetOf, const PrimitiveContactPool& contacts,
                           const ParticlePool& particles, const ColliderPool& colliders) {
  for (PrimitiveContactPool::ImpactZone& zone : zones) zone.plane = -1;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    if (contacts.carryPrecedence[i] != 1) continue;
    PrimitiveContactPool::ImpactZone& zone = zoneOf(i);
    if (zone.plane == -2) continue;
    const Vec3 target = targetOf(zone, i);
    for (std::size_t k = 0; k < colliders.size(); ++k) {
      if (colliders.shape[k] != ColliderShape::Plane) continue;
      const Vec3& n = colliders.normal[k];
      const Real start = n.dot(particles.x[i] - colliders.point[k]) - colliders.thickness[k];
      const Real end = n.dot(target - colliders.point[k]) - colliders.thickness[k];
      if (!(end < std::min(start, Real(0)))) continue;
      zone.plane = zone.plane == -1 || zone.plane == int(k) ? int(k) : -2;
    }
  }
  for (PrimitiveContactPool::ImpactZone& zone : zones) {
    if (zone.plane < 0) continue;
    const Vec3d n = colliders.normal[std::size_t(zone.plane)].cast<double>().normalized();
    zone.motion -= std::min(n.dot(zone.motion), 0.0) * n;
    zone.turn = n.dot(zone.turn) * n;
    const double angle = zone.turn.norm();
    zone.rotation = angle > 0 ? Mat3d(Eigen::AngleAxisd(angle, n.dot(zone.turn) > 0 ? n : -n))
                              : Mat3d::Identity();
  }
}

// Moves every impact zone (the particles at precedence 1) as one rigid body that keeps the linear
// and angular momentum of its particles' solved motion x → `from` (Bridson, Fedkiw and Anderson
// 2002 §7.4; Harmon et al. 2008): centre of mass c and mean motion ū; ω = I⁻¹ L over the
// substep, L = Σ m r × (u − ū) and I = Σ m (|r|² 1 − r rᵀ) with r = x − c, u = from − x; each
// particle goes to c + ū + R(ω)(x − c). A rigid motion of the crossing-free start keeps the zone's
// own pairs uncrossed (the motion between is an invertible affine map for turns below π/2; a
// larger turn, far beyond any substep's, is left out and the zone only translates). Sums in
// particle order, so the result does not depend on the thread count. With `keepMomentum` false
// the zones stop where the substep began instead (the old fail-safe: it ends the rounds sooner,
// and loses the zones' momentum). A zone whose rigid motion would take one of its particles
// deeper into a collider's contact layer than it started (the zone does not know the ground or a
// sphere; its start does) takes half of it (half the translation, half the turn about the same
// axis: still a rigid motion of its start), then a quarter, and stops after kZoneShareHalvings
// halvings. Stopping outright froze a crumpled sheet lying against a wall and the ground: the same
// zones stopped substep after substep, and the edges from them to the sheet around stayed at up to
// 4.5 times their length for the rest of the run (torture scene wall_slam at 3 substeps). Returns
// the zones; report.stoppedZones counts those of this round that took less than their whole
// motion.
std::size_t moveImpactZones(PrimitiveContactPool& contacts, ParticlePool& particles,
                            const ColliderPool& colliders, int round, bool keepMomentum,
                            CrossingReport& report) {
  const std::size_t n = particles.size();
  std::vector<PrimitiveContactPool::ImpactZone>& zones = contacts.zones;
  zones.clear();
  // A zone's root need not be in it any more: a particle's hold only ranks up, and a root that a
  // later crossing carried with a body keeps its place in the union–find. Every root of a zone
  // particle gets a slot (a root at precedence 1 only, as before, left such zones without one:
  // a crash on a cloth thrown by a propeller's blades).
  contacts.zoneSlot.assign(n, PrimitiveContactPool::kNoZone);
  for (std::size_t i = 0; i < n; ++i) {
    if (contacts.carryPrecedence[i] != 1) continue;
    const Index root = zoneOf(contacts.zoneParent, static_cast<Index>(i));
    if (contacts.zoneSlot[root] == PrimitiveContactPool::kNoZone) {
      contacts.zoneSlot[root] = static_cast<Index>(zones.size());
      zones.emplace_back();
    }
  }
  const auto zoneOfParticle = [&](std::size_t i) -> PrimitiveContactPool::ImpactZone& {
    return zones[contacts.zoneSlot[zoneOf(contacts.zoneParent, static_cast<Index>(i))]];
  };
  for (std::size_t i = 0; i < n; ++i) {
    if (contacts.carryPrecedence[i] != 1) continue;
    PrimitiveContactPool::ImpactZone& zone = zoneOfParticle(i);
    const double m = 1.0 / double(particles.w[i]);
    const Vec3d x = particles.x[i].cast<double>();
    zone.mass += m;
    zone.center += m * x;
    zone.motion += m * (contacts.failsafeFrom[i].cast<double>() - x);
  }
  for (PrimitiveContactPool::ImpactZone& zone : zones) {
    zone.center /= zone.mass, zone.motion /= zone.mass;
    if (!keepMomentum) zone.motion.setZero();
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (contacts.carryPrecedence[i] != 1) continue;
    PrimitiveContactPool::ImpactZone& zone = zoneOfParticle(i);
    const double m = 1.0 / double(particles.w[i]);
    const Vec3d x = particles.x[i].cast<double>();
    const Vec3d r = x - zone.center;
    zone.angular += m * r.cross(contacts.failsafeFrom[i].cast<double>() - x - zone.motion);
    zone.inertia += m * (r.squaredNorm() * Mat3d::Identity() - r * r.transpose());
  }
  for (PrimitiveContactPool::ImpactZone& zone : zones) {
    // A pseudo-inverse: a zone on a line (two particles, say) has no inertia about it, and no
    // angular momentum about it either.
    const Eigen::SelfAdjointEigenSolver<Mat3d> eigen(zone.inertia);
    const Vec3d lambda = eigen.eigenvalues();
    const double floor = 1e-12 * std::max(lambda.cwiseAbs().maxCoeff(), 1e-300);
    Vec3d projected = eigen.eigenvectors().transpose() * zone.angular;
    for (int k = 0; k < 3; ++k) projected[k] = lambda[k] > floor ? projected[k] / lambda[k] : 0.0;
    const Vec3d omega = eigen.eigenvectors() * projected;
    const double angle = omega.norm();
    zone.rotation = Mat3d::Identity();
    if (!keepMomentum || !(angle > 0)) continue;
    if (angle < std::numbers::pi / 2) {
      zone.turn = omega;
      zone.rotation = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
    } else {
      ++report.turnsDropped;
    }
  }
  const auto targetOf = [&](const PrimitiveContactPool::ImpactZone& zone, std::size_t i) {
    return Vec3((zone.center + zone.share * zone.motion +
                 zone.rotation * (particles.x[i].cast<double>() - zone.center))
                    .cast<Real>());
  };
  if (colliders.size() > 0 && keepMomentum)
    slideZonesAlongPlanes(zones, zoneOfParticle, targetOf, contacts, particles, colliders);
  if (colliders.size() > 0 && keepMomentum)
    for (int halving = 0;; ++halving) {
      for (PrimitiveContactPool::ImpactZone& zone : zones) zone.deeper = false;
      for (std::size_t i = 0; i < n; ++i) {
        if (contacts.carryPrecedence[i] != 1) continue;
        PrimitiveContactPool::ImpactZone& zone = zoneOfParticle(i);
        if (zone.share == 0 || zone.deeper) continue;
        const Real start = std::min(colliderGap(colliders, particles.x[i]), Real(0));
        zone.deeper = colliderGap(colliders, targetOf(zone, i)) < start;
      }
      bool anyDeeper = false;
      for (PrimitiveContactPool::ImpactZone& zone : zones) {
        if (!zone.deeper) continue;
        anyDeeper = true;
        if (halving == kZoneShareHalvings) {
          zone.share = 0;
          zone.rotation = Mat3d::Identity();
          continue;
        }
        zone.share *= 0.5;
        const double angle = zone.share * zone.turn.norm();
        zone.rotation =
            angle > 0 ? Mat3d(Eigen::AngleAxisd(angle, zone.turn.normalized())) : Mat3d::Identity();
      }
      if (!anyDeeper) break;
    }
  report.stoppedZones = 0;
  for (PrimitiveContactPool::ImpactZone& zone : zones)
    // A zone slid along a plane gave it the part of its momentum that pointed into it.
    report.stoppedZones += !keepMomentum || zone.share < 1 || zone.plane >= 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (contacts.carryPrecedence[i] != 1) continue;
    const PrimitiveContactPool::ImpactZone& zone = zoneOfParticle(i);
    const Vec3 target = targetOf(zone, i);
    if (particles.p[i] != target) {
      particles.p[i] = target;
      contacts.failsafeRound[i] = round + 1;
      ++report.stopped;
    }
  }
  return zones.size();
}

}  // namespace

// The CSR incidence, in parallel: per-particle counts (integer atomics: the same totals in any
// order), one scan for the offsets and the touched particles, a fill through atomic cursors, and
// each particle's short list sorted into contact order, so the gather's summation order, and its
// result, do not depend on the thread count.
void buildContactIncidence(PrimitiveContactPool& pool, std::size_t particleCount) {
  const std::size_t n = pool.size();
  pool.incidenceOffset.assign(particleCount + 1, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPairGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c)
                        for (int k = 0; k < 4; ++k)
                          if (pool.coefficient[c][k] != 0)
                            std::atomic_ref<Index>(pool.incidenceOffset[pool.particles[c][k] + 1])
                                .fetch_add(1, std::memory_order_relaxed);
                    });
  // Inclusive scan of the counts into offsets; the touched flags are scanned alongside into each
  // touched particle's place in `touched`.
  struct Sums {
    Index entries = 0, touched = 0;
  };
  pool.incidenceCursor.resize(particleCount);
  const Sums total = tbb::parallel_scan(
      tbb::blocked_range<std::size_t>(0, particleCount, kParticleGrain), Sums{},
      [&](const tbb::blocked_range<std::size_t>& r, Sums sum, bool final) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const Index count = pool.incidenceOffset[i + 1];
          if (final) {
            pool.incidenceCursor[i] = sum.touched;
            pool.incidenceOffset[i + 1] = sum.entries + count;
          }
          sum.entries += count;
          sum.touched += count > 0;
        }
        return sum;
      },
      [](Sums a, Sums b) {
        return Sums{a.entries + b.entries, a.touched + b.touched};
      });
  pool.touched.resize(total.touched);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particleCount, kParticleGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        if (pool.incidenceOffset[i + 1] > pool.incidenceOffset[i])
                          pool.touched[pool.incidenceCursor[i]] = static_cast<Index>(i);
                        pool.incidenceCursor[i] = pool.incidenceOffset[i];
                      }
                    });
  if (pool.pressedSum.size() != particleCount) {
    pool.pressedSum.assign(particleCount, Vec3::Zero());
    pool.pressedCount.assign(particleCount, 0);
  }
  pool.pressedParticles.reserve(total.touched);
  pool.incidence.resize(total.entries);
  pool.incidenceCoefficient.resize(total.entries);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, n, kPairGrain),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t c = r.begin(); c != r.end(); ++c)
          for (int k = 0; k < 4; ++k)
            if (pool.coefficient[c][k] != 0) {
              const Index at = std::atomic_ref<Index>(pool.incidenceCursor[pool.particles[c][k]])
                                   .fetch_add(1, std::memory_order_relaxed);
              pool.incidence[at] = static_cast<Index>(c << 2 | static_cast<std::size_t>(k));
            }
      });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pool.touched.size(), kParticleGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t t = r.begin(); t != r.end(); ++t) {
                        const Index i = pool.touched[t];
                        std::sort(pool.incidence.begin() + pool.incidenceOffset[i],
                                  pool.incidence.begin() + pool.incidenceOffset[i + 1]);
                        for (Index e = pool.incidenceOffset[i]; e < pool.incidenceOffset[i + 1];
                             ++e)
                          pool.incidenceCoefficient[e] =
                              pool.coefficient[pool.incidence[e] >> 2][pool.incidence[e] & 3];
                      }
                    });
}

void detectPrimitiveContacts(PrimitiveContactPool& contacts, const CandidatePairs& candidates,
                             const CollisionPrimitives& primitives, const ParticlePool& particles) {
  const ObjectSurface* surfaces = primitives.objectSurface.data();
  const std::size_t n = candidates.size(), particleCount = particles.size();
  contacts.startDistance.resize(n);
  contacts.suspect.resize(n);
  // The lower bounds of the last substep, in the order of the current pairs: kept if the pairs
  // are the same, followed through formerIndex if they changed once since.
  const bool sameSet = contacts.boundVersion != 0 && contacts.boundVersion == candidates.version;
  const bool formerSet = contacts.boundVersion != 0 &&
                         contacts.boundVersion + 1 == candidates.version &&
                         candidates.formerIndex.size() == n;
  const bool carry = (formerSet || (sameSet && contacts.lowerBound.size() == n)) &&
                     contacts.predicted.size() == particleCount;
  if (formerSet && carry) {
    contacts.formerLowerBound.swap(contacts.lowerBound);
    contacts.lowerBound.resize(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPairGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i) {
                          const Index former = candidates.formerIndex[i];
                          contacts.lowerBound[i] = former != CandidatePairs::kNewPair &&
                                                           former < contacts.formerLowerBound.size()
                                                       ? contacts.formerLowerBound[former]
                                                       : -kInfinity;
                        }
                      });
  } else if (!carry) {
    contacts.lowerBound.assign(n, -kInfinity);
  }
  if (carry) {
    // Per particle: how far the substep's start strays from the position the bounds were taken
    // at, plus how far its motion strays from the mean motion (one sum, so that a pair reads one
    // value per particle: a point of a side moves by at most the largest sum of that side).
    const Vec3d mean = meanMotion(particles, contacts.chunkMotion, contacts.chunkMovers);
    contacts.stray.resize(particleCount);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particleCount, kParticleGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i) {
                          const Vec3d x = particles.x[i].cast<double>();
                          contacts.stray[i] = (x - contacts.predicted[i].cast<double>()).norm() +
                                              (particles.p[i].cast<double>() - x - mean).norm();
                        }
                      });
    // A side strays by the most any of its particles does; written so that a NaN wins.
    gatherPerPrimitive(contacts.primitiveDeviation, primitives, [&](std::span<const Index> ids) {
      double most = 0;
      for (Index id : ids)
        if (!(contacts.stray[id] <= most)) most = contacts.stray[id];
      return most;
    });
    const std::array<const std::vector<Real>*, 3> radii = {
        &primitives.pointRadius, &primitives.edgeRadius, &primitives.triangleRadius};
    for (std::size_t list = 0; list < 3; ++list) {
      const std::vector<double>& stray = contacts.primitiveDeviation[list];
      std::vector<PrimitiveContactPool::StrayAndRadius>& out = contacts.primitiveStray[list];
      out.resize(stray.size());
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, stray.size(), kParticleGrain),
                        [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i != r.end(); ++i)
                            out[i] = {stray[i], double((*radii[list])[i])};
                        });
    }
  }
  const auto& strayOf = contacts.primitiveStray;
  // One pass: each fixed chunk of candidates keeps its contacts in candidate order, and the
  // chunks are concatenated in order, whatever the thread count. A pair whose carried bound
  // keeps it out of reach over this substep's motion is not measured again (see the header).
  const std::size_t chunks = (n + kContactChunk - 1) / kContactChunk;
  if (contacts.chunkContacts.size() < chunks) contacts.chunkContacts.resize(chunks);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t chunk = r.begin(); chunk != r.end(); ++chunk) {
          std::vector<PrimitiveContactRecord>& made = contacts.chunkContacts[chunk];
          made.clear();
          const std::size_t end = std::min(n, (chunk + 1) * kContactChunk);
          PrimitiveContactRecord record;
          LaneFilter filter;
          for (std::size_t block = chunk * kContactChunk; block < end; block += kPairLanes) {
            const std::size_t blockEnd = std::min(end, block + std::size_t{kPairLanes});
            filter.clear();
            for (std::size_t i = block; i < blockEnd; ++i) {
              const std::size_t slot = i - block;
              filter.measured[slot] = false;
              const PairKind kind = candidates.kind[i];
              const Index a = candidates.first[i], b = candidates.second[i];
              if (carry && contacts.lowerBound[i] > -kInfinity) {
                // Also a lower bound on the distance at the start of the substep.
                const int listA = primitiveListOf(kind, true), listB = primitiveListOf(kind, false);
                const PrimitiveContactPool::StrayAndRadius sideA = strayOf[listA][a],
                                                           sideB = strayOf[listB][b];
                const double over = contacts.lowerBound[i] - sideA.stray - sideB.stray;
                const Real radius = Real(sideA.radius) + Real(sideB.radius);
                if (over > double(radius) + double(kPrimitiveContactMargin) + kBoundTolerance) {
                  contacts.startDistance[i] = over;
                  contacts.lowerBound[i] = over;
                  filter.measured[slot] = true;
                  continue;
                }
              }
              filter.view[slot] = viewOf(primitives, kind, a, b);
              filter.add(slot, particles);
            }
            filter.run();
            for (std::size_t i = block; i < blockEnd; ++i) {
              const std::size_t slot = i - block;
              if (filter.measured[slot]) continue;
              const PairView& v = filter.view[slot];
              if (filter.settle(slot, v, primitives, contacts.startDistance[i],
                                contacts.lowerBound[i]))
                continue;
              if (makeContact(v, primitives, particles, surfaces, contacts.startDistance[i],
                              contacts.lowerBound[i], record))
                made.push_back(record);
            }
          }
        }
      });
  contacts.chunkOffset.resize(chunks + 1);
  contacts.chunkOffset[0] = 0;
  for (std::size_t chunk = 0; chunk < chunks; ++chunk)
    contacts.chunkOffset[chunk + 1] =
        contacts.chunkOffset[chunk] + contacts.chunkContacts[chunk].size();
  contacts.resize(contacts.chunkOffset[chunks]);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t chunk = r.begin(); chunk != r.end(); ++chunk) {
                        std::size_t slot = contacts.chunkOffset[chunk];
                        for (const PrimitiveContactRecord& c : contacts.chunkContacts[chunk])
                          contacts.store(slot++, c);
                      }
                    });
  buildContactIncidence(contacts, particles.size());
  contacts.predicted.assign(particles.p.begin(), particles.p.end());
  contacts.boundVersion = candidates.version;
}

// Whether contact c has a side without a free particle (a collider mesh, a pinned group): the
// particles of one sign of coefficient all of inverse mass 0.
bool againstBody(const PrimitiveContactPool& contacts, const ParticlePool& particles,
                 std::size_t c) {
  bool freeAhead = false, freeBehind = false;
  for (int k = 0; k < 4; ++k) {
    const Real coefficient = contacts.coefficient[c][k];
    if (coefficient == 0 || particles.w[contacts.particles[c][k]] == 0) continue;
    (coefficient > 0 ? freeAhead : freeBehind) = true;
  }
  return !(freeAhead && freeBehind);
}

void projectPrimitiveContacts(PrimitiveContactPool& contacts, ParticlePool& particles,
                              SolverKind kind) {
  const std::size_t n = contacts.size();
  if (n == 0) return;
  if (kind == SolverKind::GaussSeidel) {
    // Contacts against a body: each step from the same positions, a particle moved by the mean
    // of its pressed ones, as in the parallel backends. A particle on a curved mesh has contacts
    // with several of its triangles and edges, whose normals differ; projected one after another
    // (and their friction likewise, applyPrimitiveFriction) they left a curtain pushed by a ball
    // crumpled where it wrapped the ball, its edges at 6 times their rest length, and nine more
    // torture scenes not clean (bench/results/2core-AMD-EPYC/torture.md). Contacts between free
    // particles stay in sequence: their equal and opposite pushes keep the momentum that the
    // mean would not (a pellet shot through a cloth, CrossingFailsafe.ImpactZonesKeepMomentum).
    bool anyBody = false;
    for (std::size_t c = 0; c < n; ++c) {
      Real step = 0;
      if (againstBody(contacts, particles, c)) {
        step = primitiveContactStep(contacts, particles, c);
        contacts.lambda[c] += step * contacts.inverseMass[c];
        anyBody |= step != 0;
      }
      contacts.step[c] = step;
    }
    if (anyBody)
      gatherCorrections(contacts, particles, [&](Index c) -> Vec3 {
        return Vec3(contacts.step[c] * contacts.normal[c]);
      });
    for (std::size_t c = 0; c < n; ++c) {
      if (againstBody(contacts, particles, c)) continue;
      const Real step = primitiveContactStep(contacts, particles, c);
      if (step == 0) continue;
      contacts.lambda[c] += step * contacts.inverseMass[c];
      const Vec3 push = step * contacts.normal[c];
      for (int k = 0; k < 4; ++k) {
        const Index i = contacts.particles[c][k];
        particles.p[i] += particles.w[i] * contacts.coefficient[c][k] * push;
      }
    }
    return;
  }
  std::atomic<std::size_t> pressed{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPairGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      pressed.fetch_add(
                          primitiveContactSteps(contacts, particles, r.begin(), r.end()),
                          std::memory_order_relaxed);
                    });
  if (!contacts.splitParticle.empty()) {
    if (pressed.load() == 0) return;
    if (contacts.pressedCount.size() != particles.size())
      contacts.pressedCount.assign(particles.size(), 0);
    contacts.splitStep.resize(n);  // zero outside a round (applySplitAndMeanSteps clears it)
    applySplitAndMeanSteps(contacts, particles);
    return;
  }
  if (pressed.load() * kScatterShare <= n) {
    // Sized by buildContactIncidence; a pool filled otherwise gets its scratch here.
    if (contacts.pressedSum.size() != particles.size()) {
      contacts.pressedSum.assign(particles.size(), Vec3::Zero());
      contacts.pressedCount.assign(particles.size(), 0);
    }
    scatterPressedSteps(contacts, particles);
    return;
  }
  // A product, not a select (which cost 1–2% of cloth_self's step): a contact's normal and
  // coefficients are finite (makeContact makes none from a non-finite position), so an unpressed
  // contact's 0 × normal is zero.
  gatherCorrections(contacts, particles,
                    [&](Index c) -> Vec3 { return Vec3(contacts.step[c] * contacts.normal[c]); });
}

void applyPrimitiveFriction(PrimitiveContactPool& contacts, ParticlePool& particles,
                            SolverKind kind) {
  const std::size_t n = contacts.size();
  if (n == 0) return;
  if (kind == SolverKind::GaussSeidel) {
    // As the projection: against a body in the parallel form, between free particles in order.
    bool anyBody = false;
    for (std::size_t c = 0; c < n; ++c) {
      const bool body = againstBody(contacts, particles, c);
      contacts.tangentStep[c] = body ? frictionStep(contacts, particles, c) : Vec3::Zero();
      anyBody |= body;
    }
    if (anyBody)
      gatherCorrections(contacts, particles,
                        [&](Index c) -> Vec3 { return contacts.tangentStep[c]; });
    for (std::size_t c = 0; c < n; ++c) {
      if (againstBody(contacts, particles, c)) continue;
      const Vec3 step = frictionStep(contacts, particles, c);
      for (int k = 0; k < 4; ++k) {
        const Index i = contacts.particles[c][k];
        particles.p[i] += particles.w[i] * contacts.coefficient[c][k] * step;
      }
    }
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPairGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c)
                        contacts.tangentStep[c] = frictionStep(contacts, particles, c);
                    });
  gatherCorrections(contacts, particles, [&](Index c) -> Vec3 { return contacts.tangentStep[c]; });
}

void measureStartDistances(PrimitiveContactPool& contacts, const CandidatePairs& candidates,
                           const CollisionPrimitives& primitives, const ParticlePool& particles) {
  const std::size_t n = candidates.size();
  // After a re-detection the pairs that were already in the set keep the distance the narrow
  // phase measured for them at the same start positions, and their lower bounds over the same
  // predicted motion; a new pair has none.
  const bool carry = candidates.formerIndex.size() == n;
  if (carry) contacts.startDistance.swap(contacts.formerStartDistance);
  const bool carryBounds =
      carry && contacts.boundVersion != 0 && contacts.boundVersion + 1 == candidates.version;
  if (carryBounds) contacts.formerLowerBound.swap(contacts.lowerBound);
  contacts.lowerBound.assign(n, -kInfinity);
  contacts.boundVersion = candidates.version;
  contacts.startDistance.resize(n);
  contacts.suspect.resize(n);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, n, kPairGrain),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          if (carry && candidates.formerIndex[i] != CandidatePairs::kNewPair) {
            contacts.startDistance[i] = contacts.formerStartDistance[candidates.formerIndex[i]];
            if (carryBounds)
              contacts.lowerBound[i] = contacts.formerLowerBound[candidates.formerIndex[i]];
            continue;
          }
          const PairView v =
              viewOf(primitives, candidates.kind[i], candidates.first[i], candidates.second[i]);
          Vec3d X0[4] = {Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero()};
          for (int k = 0; k < v.count; ++k) X0[k] = particles.x[v.id[k]].cast<double>();
          // A positive lower bound serves the fail-safe (see makeContact).
          const double gap = boxDistance(v, X0);
          contacts.startDistance[i] =
              gap > 1e-9 ? gap : combine(closestCoefficients(v.kind, X0), X0, v.count).norm();
        }
      });
}

CrossingReport resolveCrossings(PrimitiveContactPool& contacts, const CandidatePairs& candidates,
                                const CollisionPrimitives& primitives,
                                const ColliderPool& colliders, ParticlePool& particles) {
  CrossingReport report;
  // Every particle ends inside its bounds, which the broad phase's inflated boxes enclose: no pair
  // outside the candidate set can have crossed.
  report.clamped = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, particles.size(), kParticleGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t clamped) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          // A non-finite prediction is left for the update, which resets and counts it.
          if (particles.w[i] == 0 || !particles.p[i].allFinite()) continue;
          const Vec3 inside = clampIntoBounds(candidates, i, particles.p[i]);
          if (inside != particles.p[i]) {
            particles.p[i] = inside;
            ++clamped;
          }
        }
        return clamped;
      },
      std::plus<>());
  const std::size_t n = candidates.size();
  // The round in which the fail-safe last moved each particle (0: not yet).
  contacts.failsafeRound.assign(particles.size(), 0);
  // A pair whose lower bound over the predicted motion exceeds how far its particles' final
  // positions strayed from the prediction cannot have crossed (see the header).
  const bool bounded = contacts.boundVersion == candidates.version &&
                       contacts.lowerBound.size() == n &&
                       contacts.predicted.size() == particles.size();
  if (bounded) {
    contacts.deviation.resize(particles.size());
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, particles.size(), kParticleGrain),
        [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t i = r.begin(); i != r.end(); ++i)
            contacts.deviation[i] =
                (particles.p[i].cast<double>() - contacts.predicted[i].cast<double>()).norm();
        });
    // A side's deviation is the most any of its particles deviates; written so that a NaN wins.
    gatherPerPrimitive(contacts.primitiveDeviation, primitives, [&](std::span<const Index> ids) {
      double most = 0;
      for (Index id : ids)
        if (!(contacts.deviation[id] <= most)) most = contacts.deviation[id];
      return most;
    });
  }
  contacts.carryPrecedence.assign(particles.size(), 0);
  contacts.carryRotation.resize(particles.size());
  contacts.carryTranslation.resize(particles.size());
  contacts.carryGap.resize(particles.size());
  contacts.zoneParent.assign(particles.size(), PrimitiveContactPool::kNoZone);
  contacts.zoneSlot.resize(particles.size());
  contacts.failsafeFrom.assign(particles.p.begin(), particles.p.end());
  bool anyZone = false;  // whether a zone was formed: else there is nothing to move
  for (int round = 0; round < kMaxFailsafeRounds; ++round) {
    // Pairs whose start distance the final motion could have used up, tested by CCD at zero
    // thickness: does any point of one reach the other? After the first round only the pairs
    // whose motion the last round changed, and those still crossing, can have a new answer.
    if (round > 0)
      gatherPerPrimitive(contacts.primitiveMoved, primitives, [&](std::span<const Index> ids) {
        std::uint8_t moved = 0;
        for (Index id : ids) moved |= contacts.failsafeRound[id] == round;
        return moved;
      });
    // How far each primitive's particles travel at most over the motion x → p as it now is: a
    // pair whose start distance exceeds its two sides' travel summed cannot have crossed (each
    // point of a side moves at most that far, and the distance is 1-Lipschitz in each point),
    // which a scan reads without loading the pair's particles. Written so that a NaN wins and
    // passes nothing over.
    gatherPerPrimitive(contacts.primitiveTravel, primitives, [&](std::span<const Index> ids) {
      double most = 0;
      for (Index id : ids) {
        const double travel = (particles.p[id] - particles.x[id]).cast<double>().norm();
        if (!(travel <= most)) most = travel;
      }
      return most;
    });
    const auto& travel = contacts.primitiveTravel;
    const auto& deviation = contacts.primitiveDeviation;
    const auto& moved = contacts.primitiveMoved;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n, kPairGrain),
        [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t i = r.begin(); i != r.end(); ++i) {
            const PairKind kind = candidates.kind[i];
            const Index a = candidates.first[i], b = candidates.second[i];
            const int listA = primitiveListOf(kind, true), listB = primitiveListOf(kind, false);
            if (round > 0 && !contacts.suspect[i] && !moved[listA][a] && !moved[listB][b]) continue;
            contacts.suspect[i] = 0;
            if (round == 0 && bounded &&
                contacts.lowerBound[i] - deviation[listA][a] - deviation[listB][b] >
                    kBoundTolerance)
              continue;
            if (contacts.startDistance[i] - travel[listA][a] - travel[listB][b] > kBoundTolerance)
              continue;
            const PairView v = viewOf(primitives, kind, a, b);
            Vec3d X0[4] = {Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero()};
            Vec3d X1[4] = {Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero(), Vec3d::Zero()};
            for (int k = 0; k < v.count; ++k) {
              X0[k] = particles.x[v.id[k]].cast<double>();
              X1[k] = particles.p[v.id[k]].cast<double>();
            }
            const double motion = motionBound(v, X0, X1);
            // Non-finite motion is the update's to reset and count, not the fail-safe's. A pair
            // whose start distance exceeds its relative motion cannot reach distance zero, but
            // only by more than the rounding of the two: a vertex pressed onto the ground beside
            // a layer lying on it moves by exactly its start distance and ends touching the
            // layer, which the CCD counts as reached and the intersection measure as
            // intersecting (torture/cloth_stack at one substep: eight intersecting triangle pairs
            // in two frames, none reported unresolved). A pair that already touches at the
            // start (coincident vertices of two objects, say) has no crossing-free start to keep:
            // its contact pushes it apart instead.
            if (!std::isfinite(motion) || contacts.startDistance[i] - motion > kBoundTolerance ||
                !(contacts.startDistance[i] > touchingDistance(v, particles)))
              continue;
            // A pair moving with one zone cannot cross (movesWithOneZone).
            if (round > 0 &&
                movesWithOneZone(v, contacts, particles, X1, contacts.startDistance[i]))
              continue;
            // Nor has a pair whose start the CCD itself counts as reached, standing still: one
            // within the CCD's tolerance but farther than the touching distance (two edges of
            // layers lying flat together across each other, 1.5 × 10⁻¹⁰ m apart). Held to its
            // start, it is reached again in every round and every substep: its zone stopped for
            // good and its particles held still while the cloth around them moved on
            // (torture/high_drop at one substep). The second CCD runs only for a hit.
            contacts.suspect[i] =
                pairCcd(v.kind, X0, X1, 0.0).hit && !pairCcd(v.kind, X0, X0, 0.0).hit ? 1 : 0;
          }
        });
    std::size_t crossings = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!contacts.suspect[i]) continue;
      ++crossings;
      const PairView v =
          viewOf(primitives, candidates.kind[i], candidates.first[i], candidates.second[i]);
      const auto [freeA, freeB] = freeSides(v, particles);
      // What the pair's free particles are held to: one impact zone, a rigid body that keeps
      // their momentum (moveImpactZones), or the rigid motion of a side with no free particle (a
      // collider, a pinned group), or what a particle of the pair is held to already where that
      // ranks higher. Holding every particle of a crossing pair to one rigid motion keeps the
      // pair as it was at the start, which was crossing-free. A particle's precedence only grows
      // (a zone over its own motion, carried over a zone, a lower body and triangle over a higher
      // one) and zones only merge, so the rounds end: a patch held to a body moves with it, and
      // a squeeze between two bodies is held in the gap (below) or, between turning bodies,
      // reported as unresolved rather than flipped back and forth. (Letting the latest crossing
      // decide, as the mean-translation carry before it did, flipped particles between stopped and
      // carried until the round limit on a box turning under a draped cloth.)
      Carry held;
      if (freeA == freeB) {
        // Once the zones stop (below): until then a zone's own motion may clear such a pair,
        // and carrying torn lips with their pinned row in the plane of a flat sheet, from the
        // first round, left an intersection (test Tearing.TornClothNeverIntersectsItself).
        if (round >= kMomentumRounds) movingKinematicCarry(v, particles, held);
      } else {
        held = kinematicCarry(v, !freeA, candidates.kind[i],
                              freeA ? candidates.second[i] : candidates.first[i], primitives,
                              particles);
        // A squeeze: a free particle carried with one collider body crosses another (two boxes
        // closing on a cloth, leaving less than its contact distance). Carried with either body it
        // crosses the other; it is held where it keeps its place in the gap between the two, each
        // body's translation weighed by the particle's start distance from the other (two faces
        // closing in parallel keep it between them), and no later crossing moves it again.
        // Pinned groups of its own object are not bodies of a squeeze.
        constexpr std::uint64_t kObjects = std::numeric_limits<std::uint32_t>::max();
        const std::uint64_t freeObject = kObjects - (freeA ? v.objectA : v.objectB);
        const std::uint64_t body = held.precedence >> 32;
        for (int k = 0; k < v.count && body != freeObject; ++k) {
          const Index id = v.id[k];
          const std::uint64_t carried = contacts.carryPrecedence[id];
          if (particles.w[id] == 0 || carried <= PrimitiveContactPool::kImpactZonePrecedence ||
              carried == PrimitiveContactPool::kSqueezedPrecedence)
            continue;
          const std::uint64_t other = carried >> 32;
          if (other == body || other == freeObject) continue;
          // Only between bodies that translate: between turning ones (two rollers wringing a
          // cloth) the weighed motion can leave the particle inside a curved surface, whose
          // contacts then push it through (measured: a wringer went from unresolved crossings
          // to edges at 64 times their length); the squeeze stays unresolved there.
          constexpr double kTurn = 1e-5;  // a translating body's frames agree to rounding
          if (!contacts.carryRotation[id].isIdentity(kTurn) ||
              !held.motion.rotation.isIdentity(kTurn))
            continue;
          // Written so that a NaN counts as no gap.
          const auto gapOf = [](double d) { return d > 0 ? d : 0.0; };
          const double gapA = gapOf(contacts.carryGap[id]), gapB = gapOf(contacts.startDistance[i]);
          const double weightA = gapA + gapB > 0 ? gapB / (gapA + gapB) : 0.5,
                       weightB = 1 - weightA;
          held.motion = RigidMotion{
              weightA * contacts.carryRotation[id] + weightB * held.motion.rotation,
              weightA * contacts.carryTranslation[id] + weightB * held.motion.translation};
          held.precedence = PrimitiveContactPool::kSqueezedPrecedence;
          ++report.squeezed;
          break;
        }
      }
      for (int k = 0; k < v.count; ++k) {
        const Index id = v.id[k];
        if (particles.w[id] > 0 && contacts.carryPrecedence[id] > held.precedence) {
          held.precedence = contacts.carryPrecedence[id];
          held.motion = RigidMotion{contacts.carryRotation[id], contacts.carryTranslation[id]};
        }
      }
      if (held.precedence == 1) {
        // Their zones merge; the zones move after the round.
        Index root = PrimitiveContactPool::kNoZone;
        for (int k = 0; k < v.count; ++k) {
          const Index id = v.id[k];
          if (particles.w[id] == 0) continue;
          root = joinZone(contacts.zoneParent, id, root);
          contacts.carryPrecedence[id] = 1;
          anyZone = true;
        }
        continue;
      }
      for (int k = 0; k < v.count; ++k) {
        const Index id = v.id[k];
        if (particles.w[id] == 0 || contacts.carryPrecedence[id] >= held.precedence) continue;
        contacts.carryPrecedence[id] = held.precedence;
        contacts.carryRotation[id] = held.motion.rotation;
        contacts.carryTranslation[id] = held.motion.translation;
        contacts.carryGap[id] = contacts.startDistance[i];
        const Vec3 target =
            Vec3((held.motion.rotation * particles.x[id].cast<double>() + held.motion.translation)
                     .cast<Real>());
        if (particles.p[id] != target) {
          particles.p[id] = target;
          contacts.failsafeRound[id] = round + 1;
          ++report.stopped;
          ++report.carried;
        }
      }
    }
    // Merging zones until none crosses another ends (Harmon et al. 2008), but a zone's new motion
    // can meet the next zone round after round: past half the round limit the zones stop where
    // the substep began, which ends it sooner (counted).
    const bool keepMomentum = round < kMomentumRounds;
    if (anyZone)
      report.zones = moveImpactZones(contacts, particles, colliders, round, keepMomentum, report);
    report.crossings += crossings;
    report.rounds = round + 1;
    if (crossings == 0) return report;
    if (round + 1 == kMaxFailsafeRounds) report.unresolved = crossings;
  }
  return report;
}

void applyRestitution(const PrimitiveContactPool& contacts, ParticlePool& particles) {
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const Real e = contacts.restitution[c];
    if (e == 0 || !(contacts.lambda[c] > 0) || contacts.approachSpeed[c] >= 0) continue;
    const Vec3& n = contacts.normal[c];
    Vec3 relative = Vec3::Zero();
    for (int k = 0; k < 4; ++k)
      relative += contacts.coefficient[c][k] * particles.v[contacts.particles[c][k]];
    const Real target = -e * contacts.approachSpeed[c];
    const Real missing = target - n.dot(relative);
    if (missing <= 0) continue;
    const Real m = contacts.inverseMass[c];
    if (!(m > 0)) continue;
    for (int k = 0; k < 4; ++k) {
      const Index i = contacts.particles[c][k];
      particles.v[i] += particles.w[i] * contacts.coefficient[c][k] * (missing / m) * n;
    }
  }
}

}  // namespace nucleon
