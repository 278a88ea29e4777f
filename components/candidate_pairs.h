// Candidate pairs of collision primitives whose swept, thickness-inflated bounds overlap, and whose
// distance may come within reach, over the motion the broad phase was given (the rest of a step,
// ARCHITECTURE.md §4): the broad phase's output and the narrow phase's input. Per-step lifetime
// (refreshed within a step when a particle is predicted to leave its bounds), refilled into storage
// that keeps its capacity.
//
// Pairs are stored sorted by (kind, first, second), so the set, and everything computed from it,
// is the same whatever the thread count. Indices are into the CollisionPrimitives lists:
//   VertexFace    first = point,  second = triangle
//   EdgeEdge      first = edge,   second = edge, first < second
//   VertexEdge    first = point,  second = edge        (isolated points only)
//   VertexVertex  first = point,  second = point, first < second (isolated points only)
// No pair shares a particle, none joins two objects whose pair is excluded, and none has only
// particles of inverse mass 0 (two kinematic or pinned primitives cannot respond).
//
// The set is complete only while every particle stays inside its bounds: within boundSlack of the
// straight path the pairs were found for, less than the primitives' boxes were grown by.
// Boxes and bounds are kept in a frame that follows the particles' common motion (frameOrigin).
// Two primitives whose particles stay inside their bounds and that are not a pair cannot come
// within their contact distance. The solve clamps free particles into their bounds; a substep
// whose prediction leaves them finds the pairs again.
#pragma once

#include <cstdint>
#include <vector>

#include "nucleon/types.h"

namespace nucleon {

enum class PairKind : std::uint8_t { VertexFace, EdgeEdge, VertexEdge, VertexVertex };

// Which CollisionPrimitives list a pair's first or second primitive indexes: 0 points, 1 edges,
// 2 triangles (per-primitive data kept as three arrays in that order).
constexpr int primitiveListOf(PairKind kind, bool first) {
  switch (kind) {
    case PairKind::VertexFace:
      return first ? 0 : 2;
    case PairKind::EdgeEdge:
      return 1;
    case PairKind::VertexEdge:
      return first ? 0 : 1;
    default:
      return 0;
  }
}

struct CandidatePairs {
  std::vector<PairKind> kind;
  std::vector<Index> first;
  std::vector<Index> second;

  // Per particle, in the frame (frameOrigin): the straight path the pairs were found for, from
  // pathStart at substep boundary pathFrom to pathEnd at boundary pathTo, and held at pathEnd
  // after it; the particle must stay within boundSlack of its path's point at every boundary
  // (pathPoint) for the set to be complete. The boxes of the primitives move along their
  // particles' paths over that window, and two primitives are a pair only if their moving boxes
  // meet at some instant of it: neighbours that move together are not paired however far they
  // move (broad_phase.h). motionLower/motionUpper are the boxes of the paths.
  // A particle that left its bounds once, whose course the solve may bend again, is held
  // instead: its path is the middle of its motion's box, a point, and pathReach the box's half
  // extents, added to the slack (a box that does not move, as a swept box).
  std::vector<Vec3> pathStart;
  std::vector<Vec3> pathEnd;
  std::vector<Vec3> pathReach;
  int pathFrom = 0;
  int pathTo = 1;
  // Every path is a point held at its end (a set carried into a new step, not extended since):
  // carrying it again changes nothing.
  bool pathsHeld = false;
  Real boundSlack = 0;
  std::vector<Vec3> motionLower;
  std::vector<Vec3> motionUpper;
  // Scratch: the end of each particle's extrapolated motion (predictMotionEnd).
  std::vector<Vec3> motionEnd;
  // The frame the motion boxes and bounds are in (broad_phase.h, setMotionFrame): its offset from
  // the world at each substep boundary k of the step (k = 0 at the step's start, k = substeps at
  // its end), and the substep in progress. A particle at p at boundary k is at p − frameOrigin[k]
  // in the frame; with no frame set, the offset is zero.
  std::vector<Vec3> frameOrigin;
  int frameSubstep = 0;
  // Scratch of setMotionFrame: one coordinate of every free particle's motion.
  std::vector<Real> frameScratch;
  // Which set this is: every change of the pairs (a broad phase, full or incremental) counts one
  // up, so that per-pair data kept elsewhere can tell whether it still belongs to them.
  std::uint64_t version = 0;
  // Each pair's index in the set before the last change (version − 1), or kNewPair for a pair
  // that change added, so that per-pair data can follow the pairs; empty when the change kept
  // no pair (a first broad phase, the brute force).
  static constexpr Index kNewPair = ~Index{0};
  std::vector<Index> formerIndex;
  // Scratch of a full broad phase: the pairs before it, to match them with the new ones.
  std::vector<PairKind> formerKind;
  std::vector<Index> formerFirst;
  std::vector<Index> formerSecond;

  std::size_t size() const { return kind.size(); }
  Vec3 frameAt(int boundary) const {
    return boundary >= 0 && static_cast<std::size_t>(boundary) < frameOrigin.size()
               ? frameOrigin[static_cast<std::size_t>(boundary)]
               : Vec3::Zero();
  }
  // Where particle i's path is at substep boundary k: linear between pathFrom and pathTo,
  // held before and after.
  Vec3 pathPoint(std::size_t i, int boundary) const {
    if (pathTo <= pathFrom || boundary >= pathTo) return pathEnd[i];
    if (boundary <= pathFrom) return pathStart[i];
    const Real t = Real(boundary - pathFrom) / Real(pathTo - pathFrom);
    return pathStart[i] + t * (pathEnd[i] - pathStart[i]);
  }
  // The step's last boundary (1 with no frame set).
  int lastBoundary() const {
    return frameOrigin.size() > 1 ? static_cast<int>(frameOrigin.size()) - 1 : 1;
  }
  // The offsets at the start and at the end of the substep in progress.
  Vec3 startOffset() const { return frameAt(frameSubstep); }
  Vec3 endOffset() const { return frameAt(frameSubstep + 1); }
  void clear() { kind.clear(), first.clear(), second.clear(), formerIndex.clear(), ++version; }
  void push_back(PairKind k, Index a, Index b) {
    kind.push_back(k), first.push_back(a), second.push_back(b);
  }
};

}  // namespace nucleon
