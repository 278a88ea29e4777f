// Broad phase: the candidate pairs of collision primitives that may come into contact over a
// motion (components/candidate_pairs.h), from the primitives (components/collision_primitives.h)
// and the particle positions at its start (x) and predicted end (p). The world runs it once per
// step, over the step's extrapolated motion (extrapolateMotion), and again within the step only
// when a substep's prediction leaves the particles' bounds (withinParticleBounds): the research
// recommendation of ARCHITECTURE.md §4, and the cost of a broad phase divided by the substeps.
//
// Each primitive gets a moving box: at the start, the box of its vertices at x, at the end the box
// of its vertices at p, in between the interpolation of the two, each grown by its radius plus
// half the margin and rounded outward to float. If every vertex moves on a straight line from x
// to p, a vertex's position at an instant is the interpolation of its ends, so the box of the
// vertices at that instant (the box of interpolations) lies inside the interpolated box. Two
// primitives whose moving boxes meet at no instant (meetInMotion) cannot come within
// (radius A + radius B + margin) of each other in every axis during the motion. Neighbours that
// move together are not paired, however far they move; the swept box (the box of the two ends),
// which the trees hold, would pair them with every primitive their motion passes over. The
// candidates are the pairs of these kinds whose moving boxes meet:
//
//   VertexFace    every point against every triangle
//   EdgeEdge      every edge against every other edge
//   VertexEdge    isolated points against edges
//   VertexVertex  isolated points against each other
//
// less those sharing a particle, joining an excluded object pair, or whose particles all have
// inverse mass 0, and less the vertex–face and edge–edge pairs whose particles all move on straight
// paths and whose distance, measured in float lanes (pair_distance_lanes.h) less their error,
// stays beyond r_a + r_b + margin over the whole motion: they stay as far apart as two primitives
// whose moving boxes never meet. (Boxes are loose around a cloth's diagonal edges and triangles:
// on cloth_self this drops 58% of the pairs the boxes give, on cloth_drop_sphere 48%, so the
// narrow phase and the fail-safe visit half as many every substep.) A primitive with a coordinate
// that is not finite (or beyond ±1e18 m, outside the range Embree accepts) is skipped: it takes
// part in no pair, and the count is reported.
//
// findCandidatePairs keeps the boxes in trees whose topology Embree's builder makes
// (components/primitive_bvh.h), refit from one call to the next while the primitive counts stay,
// and finds each kind's pairs with one dual-tree traversal (points against triangles, edges
// against edges, isolated points against edges and against each other), in parallel, every
// overlapping pair of swept boxes once per traversal (a self-traversal keeps first < second), each
// then kept if the moving boxes meet; pairs of subtrees whose tags (components/primitive_bvh.h)
// say that no pair of theirs would be kept, both fixed or of objects that never collide, are
// passed over whole. The threads' pairs are then put in order by a counting sort
// on the first index and a sort of each first index's partners, so the result is the same sorted
// list for any thread count. (Embree's own rtcCollide over refit user-geometry scenes, which
// reports every primitive pair of two overlapping leaves and a tree met with itself in both
// orders, cost 1.4–1.5× as much on a folded cloth; per-primitive point queries, which Embree culls
// with the sphere around the query box, 1.7× as much again.) findCandidatePairsBruteForce tests
// every pair of moving boxes: the reference.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "components/candidate_pairs.h"
#include "components/collision_primitives.h"
#include "components/primitive_bvh.h"
#include "nucleon/types.h"

namespace nucleon {

struct BroadPhaseStats {
  std::array<std::size_t, 4> pairs{};  // pairs found, by PairKind
  std::size_t skippedPrimitives = 0;   // points, edges and triangles with a non-finite coordinate
  bool rebuilt = false;                // a tree was built from scratch (the counts changed)
  // Wall time of the stages, in seconds (zero for the brute force).
  double boxSeconds = 0;
  double commitSeconds = 0;
  double querySeconds = 0;

  std::size_t totalPairs() const { return pairs[0] + pairs[1] + pairs[2] + pairs[3]; }
};

// The swept box of a primitive with the given particles: the box of their positions in x and in
// p, grown by `inflation`, rounded outward to float. Empty (PrimitiveBox::isEmpty) if a coordinate
// or the result is not finite or beyond ±1e18.
PrimitiveBox sweptBox(std::span<const Index> particles, std::span<const Vec3> x,
                      std::span<const Vec3> p, Real inflation);

// Refills `out` with the candidate pairs, sorted by (kind, first, second), and says through
// out.formerIndex which of them were pairs before the call. `bvh` is the world's broad phase
// state: reused between calls, it is refit while the primitive counts stay the same. Once its
// scratch has grown, a call allocates nothing.
// `x` and `p` are the ends of each particle's straight path.
BroadPhaseStats findCandidatePairs(CandidatePairs& out, PrimitiveBvh& bvh,
                                   const CollisionPrimitives& primitives, std::span<const Vec3> x,
                                   std::span<const Vec3> p, std::span<const Real> w, Real margin);

// The extrapolated end of each particle's motion over the rest of the step, into `end`: the
// end of `remaining` substeps of length h, from the substep's prediction p = x + h v. Free
// particles under the acceleration g end at x + R (p − x) + R(R − 1)/2 h² g, where the explicit
// substeps would take them with no constraint acting; particles of inverse mass 0 (pinned,
// kinematic) go on in a straight line. Only a guess: the bounds, not the guess, are what
// completeness rests on. (Growing the box by a fraction of the displacement, room for a course
// the constraints bend, measured worse on the collision scenes: refreshes fell by a third, while
// the pairs, and the narrow phase over them, doubled.)
void predictMotionEnd(std::vector<Vec3>& end, std::span<const Vec3> x, std::span<const Vec3> p,
                      std::span<const Real> w, const Vec3& g, Real h, int remaining);

// The frame of a step's boxes and bounds, from substep `substep` on (CandidatePairs::frameOrigin):
// it moves as the free particles' median motion would, extrapolated like predictMotionEnd
// (j m + j(j − 1)/2 h² g, j substeps on, m the per-axis median of p − x). Distances between
// primitives at one instant do not change when every particle is shifted by the same offset, so
// pairs found from boxes and bounds taken in any such frame are as complete as in the world;
// in this one a cloth that falls or flies as a whole has boxes no larger than its particles'
// motion relative to one another (a cloth falling edge-first moves in its own plane, and its
// swept boxes in the world reach several rings of neighbours). The per-axis median minimises the
// summed extents of the motion boxes, and one fast particle does not move it. The boundaries up
// to `substep` get offset `base` (zero for a new search: positions at the substep's start need no
// shift), the later ones `base` plus the extrapolated motion.
void setMotionFrame(CandidatePairs& pairs, std::span<const Vec3> x, std::span<const Vec3> p,
                    std::span<const Real> w, const Vec3& g, Real h, int substep, int substeps,
                    const Vec3& base = Vec3::Zero());

// Each particle's path, into pairs.pathStart/pathEnd (and its box, motionLower/motionUpper): from
// its position in `start` at substep boundary `from` to its position in `end` stretched by
// `stretch` (a path through `end` and on, to boundary `to`), each taken in the frame (less the
// frame's offset at its instant).
void setMotionBounds(CandidatePairs& pairs, std::span<const Vec3> start, std::span<const Vec3> end,
                     const Vec3& startOffset = Vec3::Zero(), const Vec3& endOffset = Vec3::Zero(),
                     int from = 0, int to = 1, Real stretch = 1);

// How far a particle may stray from its path with no crossing escaping the candidate
// set: kBoundSlackFraction × (2 r_min + margin), r_min the smallest primitive radius. Two
// primitives whose boxes do not meet are at least r_a + r_b + margin ≥ 2 r_min + margin apart
// around their particles' paths at every instant; if every particle strays at most that slack, they
// stay at least a tenth of it apart (room for the float rounding of boxes and bounds, for
// coordinates up to a few kilometres), so they cannot cross. They may come within their contact
// distance without a contact: the next broad phase, a substep later at most, makes one.
constexpr Real kBoundSlackFraction = Real(0.45);
Real boundSlack(const CollisionPrimitives& primitives, Real margin);

// Turns paths into bounds: a particle must stay within `slack` of its path's point, per axis.
void growParticleBounds(CandidatePairs& pairs, Real slack);

// Makes the pairs complete again where some particles left their bounds, without finding them
// all again (the incremental re-detection of I-Cloth, Tang et al. 2018): each particle whose
// `position` (or `start`) is outside its bounds gets a held path over the box of its motion from
// `start` through `end` on to the window's end (CandidatePairs::pathReach); the primitives with
// such a particle get their moving boxes again, the trees are refit, those primitives are
// queried over the rest of the window (a pair of two such primitives is kept by one of the two
// queries that find it), their new pairs are merged into the set in order (both lists are
// sorted: one pass per chunk of the set) and their pairs whose boxes no longer meet are dropped.
// The set is then the one findCandidatePairs would give over the paths and held boxes, and
// CandidatePairs::formerIndex says where each pair was before. Returns false, changing nothing,
// when more than 1/kExtendShare of the particles left their bounds, or the trees were not built for
// the current primitives: a full findCandidatePairs is then cheaper. `offsets` are the frame's
// offsets at the instants of `position`, `start` and `end`.
constexpr std::size_t kExtendShare = 8;
struct FrameOffsets {
  Vec3 position = Vec3::Zero();
  Vec3 start = Vec3::Zero();
  Vec3 end = Vec3::Zero();
  // The substep boundaries of `position`, `start` and `end`; a new path runs from `start`
  // through `end` on to the window's end (CandidatePairs::pathTo).
  int positionAt = 1;
  int startAt = 0;
  int endAt = 1;
};
bool extendCandidatePairs(CandidatePairs& pairs, PrimitiveBvh& bvh,
                          const CollisionPrimitives& primitives, std::span<const Vec3> position,
                          std::span<const Vec3> start, std::span<const Vec3> end,
                          std::span<const Real> w, Real margin, Real slack,
                          const FrameOffsets& offsets = {});

// How many particles' positions in `p`, the end of the substep in progress, lie outside their
// bounds (all of them when there are no bounds for `p`), and whether none does. Particles with a
// non-finite position are left to the update's counted repair and do not count as outside.
std::size_t countOutsideParticleBounds(const CandidatePairs& pairs, std::span<const Vec3> p);
bool withinParticleBounds(const CandidatePairs& pairs, std::span<const Vec3> p);

// Whether a new step may start from the last step's pairs (at its first substep, before any
// search): the frame goes on from where the last step's ended with this step's median motion
// (setMotionFrame with that base), at most 1/kExtendShare of the particles' positions x at the
// step's start lie outside their bounds (`outside` says how many: the caller extends the set
// for them), and the last paths were not loose: their summed extents are at most kLooseBounds
// times those a new search would give (|p − x − m| over the step's `substeps`, plus twice
// `slack`, per axis, m the frame's motion over a substep), so that a cloth come to rest does not
// keep the larger pair set of its fall. When it may, every path is held at its end from then on
// (a point, and every primitive's moving box its end box): the set stays complete for particles
// that stay within the slack of their ends. The caller then checks p as at any substep: within
// the bounds the set is complete, and few particles outside extend it. A cloth falling or at
// rest as a whole keeps its pairs from step to step. False when there are no bounds for these
// particles.
constexpr Real kLooseBounds = 2;
bool carryPairsIntoStep(CandidatePairs& pairs, PrimitiveBvh& bvh, std::span<const Vec3> x,
                        std::span<const Vec3> p, std::span<const Real> w, const Vec3& g, Real h,
                        int substeps, Real slack, std::size_t& outside);

// Position `p` of particle i at the end of the substep in progress, moved to the nearest point
// inside its bounds: the point that countOutsideParticleBounds then counts as inside.
Vec3 clampIntoBounds(const CandidatePairs& pairs, std::size_t i, const Vec3& p);

// The same pairs, by testing the boxes of every pair of primitives: quadratic, for tests and
// scale.
BroadPhaseStats findCandidatePairsBruteForce(CandidatePairs& out,
                                             const CollisionPrimitives& primitives,
                                             std::span<const Vec3> x, std::span<const Vec3> p,
                                             std::span<const Real> w, Real margin,
                                             std::span<const Vec3> reach = {});

}  // namespace nucleon
