// Bounding volume hierarchies over the swept boxes of the collision primitives: the broad phase's
// acceleration structure (systems/broad_phase.*). Embree's builder (rtcBuildBVH, binned SAH)
// makes each tree's topology, a binary tree with up to four boxes per leaf; its node bounds, its
// refits and its traversals are the component's own, in a flat depth-first layout.
//
// Lifetime: a tree is built from scratch when the number of boxes it holds changes and refit
// otherwise (the topology kept, the node bounds recomputed from the new boxes), which is what a
// simulation needs from one substep to the next. Four trees: triangles, edges, all points and the
// isolated points. Embree itself stays inside systems/collision/primitive_bvh_embree.cpp, so that
// including this header (through world_state.h) does not pull in Embree's headers.
//
// The component also keeps the broad phase's scratch (query boxes, per-chunk partner lists), so
// that once its capacities have grown a call allocates nothing.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "components/candidate_pairs.h"
#include "nucleon/types.h"

namespace nucleon {

// An axis-aligned box in float, the precision Embree stores bounds in. A box whose lower corner
// is above its upper one is empty and overlaps nothing: the box of a skipped primitive.
struct PrimitiveBox {
  std::array<float, 3> lower;
  std::array<float, 3> upper;

  static constexpr PrimitiveBox empty() {
    constexpr float big = 3.0e38f;
    return {{big, big, big}, {-big, -big, -big}};
  }
  bool isEmpty() const {
    return !(lower[0] <= upper[0] && lower[1] <= upper[1] && lower[2] <= upper[2]);
  }
};

// Closed boxes: touching counts as overlapping. False whenever either box is empty.
inline bool overlaps(const PrimitiveBox& a, const PrimitiveBox& b) {
  return a.lower[0] <= b.upper[0] && b.lower[0] <= a.upper[0] && a.lower[1] <= b.upper[1] &&
         b.lower[1] <= a.upper[1] && a.lower[2] <= b.upper[2] && b.lower[2] <= a.upper[2] &&
         !a.isEmpty() && !b.isEmpty();
}

// Whether two boxes that move linearly over an interval of time, from their start boxes to their
// end boxes, overlap at some instant of it. Per axis and side the gap is linear in time, so each
// of the six conditions holds on a sub-interval; the boxes meet where all six do. Computed in
// double with a tolerance of 1 nm toward meeting, far below any bound slack.
// `since` limits the interval to its part from that fraction on.
[[gnu::always_inline]] inline bool meetInMotion(const PrimitiveBox& startA,
                                                const PrimitiveBox& endA,
                                                const PrimitiveBox& startB,
                                                const PrimitiveBox& endB, double since = 0) {
  if (startA.isEmpty() || endA.isEmpty() || startB.isEmpty() || endB.isEmpty()) return false;
  // Most pairs that meet overlap at the start or at the end: comparing the floats themselves is
  // exact, and whenever they overlap the double figures below say the same (each g0, or each g1,
  // is then at least the tolerance; with every g1 positive, a crossing g0 / (g0 − g1) rounds to at
  // most 1).
  if (since == 0 && overlaps(startA, startB)) return true;
  if (overlaps(endA, endB)) return true;
  constexpr double kTolerance = 1e-9;
  // g(t) = g0 + t (g1 − g0) ≥ 0 for the room between a lower and an upper side, over the
  // interval from `since` (g0 taken there) to its end. Most pairs that meet already overlap at
  // its start: all six g0 ≥ 0.
  double start[6], end[6];
  bool overlapAtStart = true;
  for (int k = 0; k < 3; ++k) {
    const double lowerA = startA.lower[k] + since * (double(endA.lower[k]) - startA.lower[k]);
    const double upperA = startA.upper[k] + since * (double(endA.upper[k]) - startA.upper[k]);
    const double lowerB = startB.lower[k] + since * (double(endB.lower[k]) - startB.lower[k]);
    const double upperB = startB.upper[k] + since * (double(endB.upper[k]) - startB.upper[k]);
    start[2 * k] = upperB - lowerA + kTolerance;
    start[2 * k + 1] = upperA - lowerB + kTolerance;
    end[2 * k] = double(endB.upper[k]) - endA.lower[k] + kTolerance;
    end[2 * k + 1] = double(endA.upper[k]) - endB.lower[k] + kTolerance;
    overlapAtStart &= start[2 * k] >= 0 && start[2 * k + 1] >= 0;
  }
  if (overlapAtStart) return true;
  // Each condition holds from its crossing on (g0 < 0 ≤ g1), up to it (g1 < 0 ≤ g0), always or
  // never; the boxes meet where all six hold.
  double from = 0, to = 1;
  for (int c = 0; c < 6; ++c) {
    const double g0 = start[c], g1 = end[c];
    if (g0 >= 0 && g1 >= 0) continue;
    if (g0 < 0 && g1 < 0) return false;
    const double crossing = g0 / (g0 - g1);
    if (g0 < 0)
      from = std::max(from, crossing);
    else
      to = std::min(to, crossing);
  }
  return from <= to;
}

// A primitive's box at the start and at the end of a motion.
struct BoxEnds {
  PrimitiveBox start;
  PrimitiveBox end;
};

[[gnu::always_inline]] inline bool meetInMotion(const BoxEnds& a, const BoxEnds& b,
                                                double since = 0) {
  return meetInMotion(a.start, a.end, b.start, b.end, since);
}

enum class BvhTree : std::uint8_t { Triangles, Edges, IsolatedPoints, Points };
constexpr std::size_t kBvhTreeCount = 4;

// A primitive's tag, which lets a traversal pass over a pair of subtrees none of whose pairs the
// broad phase's filters would keep: the primitive's object in the low bits (kMixedObject for a
// subtree of several objects) and kFreeTag if one of its particles can move. Two subtrees of
// primitives that cannot move, or of two objects that never collide (one object without
// self-collision), hold no pair.
constexpr std::uint32_t kFreeTag = 1u << 31;
constexpr std::uint32_t kMixedObject = kFreeTag - 1;
constexpr std::uint32_t primitiveTag(std::uint32_t object, bool free) {
  return (object < kMixedObject ? object : kMixedObject) | (free ? kFreeTag : 0u);
}

// The object pairs that never collide, as a bit matrix for the traversals' lookups
// (CollisionPrimitives::excludedPairs is the source). Tabulated up to kMaxObjects objects; beyond
// that no object pair counts as excluded here (the pair filters still drop them) and only
// subtrees that cannot move are passed over.
struct ObjectExclusions {
  static constexpr std::size_t kMaxObjects = 2048;
  std::size_t objects = 0;
  std::vector<std::uint64_t> source;  // the excluded pairs the matrix was made from
  std::vector<std::uint64_t> bits;    // bit a × objects + b
  bool excluded(std::uint32_t a, std::uint32_t b) const {
    if (a >= objects || b >= objects) return false;
    const std::size_t k = std::size_t{a} * objects + b;
    return (bits[k >> 6] >> (k & 63)) & 1u;
  }
  // Whether object a is in some excluded pair.
  bool names(std::uint32_t a) const { return a < objects && named[a]; }
  std::vector<std::uint8_t> named;
};

class PrimitiveBvh {
 public:
  PrimitiveBvh();
  ~PrimitiveBvh();
  PrimitiveBvh(PrimitiveBvh&&) noexcept;
  PrimitiveBvh& operator=(PrimitiveBvh&&) noexcept;
  PrimitiveBvh(const PrimitiveBvh&) = delete;
  PrimitiveBvh& operator=(const PrimitiveBvh&) = delete;

  // The boxes each tree bounds, by tree (index with the BvhTree value); primitive i of a tree is
  // boxes[tree][i]. Written by the broad phase, then commit().
  std::array<std::vector<PrimitiveBox>, kBvhTreeCount> boxes;

  // Per tree, each primitive's box at the start and at the end of the motion it was found for
  // (its particles' path ends, grown like the swept box): the moving box the pair tests use
  // (meetInMotion). The tree's box is the box of the two.
  // Both in one record, so that a pair test loads one record per primitive.
  std::array<std::vector<BoxEnds>, kBvhTreeCount> boxEnds;

  // Per tree, each primitive's tag (primitiveTag), written with the boxes. A tree whose tags do
  // not match its boxes in number (none: the broad phase writes none where pruning would not
  // pay) is traversed without pruning.
  std::array<std::vector<std::uint32_t>, kBvhTreeCount> tags;
  // Which object pairs the traversals may pass over (setExclusions).
  ObjectExclusions exclusions;
  // Tabulates the excluded object pairs (keys as CollisionPrimitives::excludedPairs) for the
  // objects they name; allocates only when they change.
  void setExclusions(const std::vector<std::uint64_t>& excludedPairs);

  // Makes every tree bound its current boxes: built from scratch where the number of boxes
  // differs from the one the tree was built for, refit otherwise. Returns whether any tree was
  // built from scratch. A tree without boxes holds no nodes.
  bool commit();

  // Calls visit(context, i) once for every primitive i of `tree` whose box overlaps `query`, in no
  // particular order. Safe to call from many threads at once between two commits.
  // `queryTag` (primitiveTag of the query's primitive) passes over the subtrees that cannot pair
  // with it, as the pair traversal does; kMixedObject | kFreeTag passes over none.
  using Visitor = void (*)(void* context, Index primitive);
  void forEachOverlap(BvhTree tree, const PrimitiveBox& query, Visitor visit, void* context,
                      std::uint32_t queryTag = kMixedObject | kFreeTag) const;

  // Calls visit(context, a, b, count) with batches of the pairs (a[k], b[k]) of a primitive of
  // `treeA` and one of `treeB` whose boxes overlap: every such pair and no other, in no
  // particular order and from many threads at once (a dual-tree traversal that splits the larger
  // node, the boxes of two leaves tested pair by pair). A tree met with itself reports each pair
  // once, as a < b: a node's pairs are those within each child and those across the two, so no
  // pair of subtrees is visited twice. An empty box overlaps nothing. Subtrees whose tags say
  // that none of their pairs can be kept (both cannot move, or their objects never collide) are
  // passed over: the pairs left out are only ones the broad phase's filters drop. Call between two
  // commits.
  using PairVisitor = void (*)(void* context, const Index* a, const Index* b, std::size_t count);
  void forEachOverlappingPair(BvhTree treeA, BvhTree treeB, PairVisitor visit, void* context) const;

  std::size_t builtCount(BvhTree tree) const { return builtCount_[static_cast<std::size_t>(tree)]; }
  // Trees built from scratch and trees refit, over the component's lifetime.
  std::size_t builds() const { return builds_; }
  // Pairs of subtrees (or a subtree and a query) the traversals passed over by their tags.
  std::size_t passedOver() const;
  std::size_t refits() const { return refits_; }
  // Errors Embree reported to the device's error callback, and builds that failed (none in a
  // healthy run). A failed build leaves its tree one leaf of every box: complete but slow. The
  // world reports the count as collisions.broad_phase_tree_errors.
  std::size_t embreeErrors() const;

  // Broad phase scratch, kept between calls for its capacity.
  std::vector<Index> isolatedPoints;  // the point of each primitive of the IsolatedPoints tree
  std::vector<Index> pairOffset;      // per query primitive: where its partners start
  std::vector<Index> listPlace;       // per thread list and query primitive: count, then place
  // Pairs found by each thread of the arena (by its index in it), and last a list shared by
  // threads outside the arena, as first << 32 | second, before they are put in order.
  std::vector<std::vector<std::uint64_t>> threadPairs;
  // Per arena thread: pairs not yet listed, each list's header on a cache line of its own (the
  // threads append to them on every kept pair: adjacent headers would share a line between cores).
  struct alignas(64) StagedPairs {
    std::vector<std::uint64_t> keys;
  };
  std::vector<StagedPairs> threadStaging;
  // Incremental re-detection: which particles got a new (held) path, the primitives with one
  // (points, edges, triangles), the new pairs of each kind, and the merged pair lists.
  std::vector<std::uint8_t> grownParticle;
  std::array<std::vector<Index>, 3> changedPrimitives;
  std::array<std::vector<std::uint64_t>, 4> newPairs;
  // Per primitive (points, edges, triangles): whether it has a grown particle.
  std::array<std::vector<std::uint8_t>, 3> changedPrimitive;
  // The new pairs' sort by first index: per kind, the counts and places, and the sorted copy.
  std::array<std::vector<Index>, 4> newPairOffset;
  std::array<std::vector<std::uint64_t>, 4> newPairScratch;
  // The merge's chunks: a run of one kind's old pairs, the new pairs of that kind that go among
  // them, and how many pairs the merge keeps (then: how many it keeps before the chunk).
  struct MergeChunk {
    std::size_t kind, oldBegin, oldEnd, newBegin, newEnd, kept;
  };
  std::vector<MergeChunk> mergeChunks;
  std::vector<PairKind> mergedKind;
  std::vector<Index> mergedFirst;
  std::vector<Index> mergedSecond;

 private:
  struct Embree;
  std::unique_ptr<Embree> embree_;
  std::array<std::size_t, kBvhTreeCount> builtCount_{};
  std::size_t builds_ = 0;
  std::size_t refits_ = 0;
};

}  // namespace nucleon
