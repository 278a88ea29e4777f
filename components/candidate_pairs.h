// Candidate pairs of collision primitives whose swept, thickness-inflated bounds overlap over a
// substep: the broad phase's output and the narrow phase's input. Per-substep lifetime, refilled
// into storage that keeps its capacity.
//
// Pairs are stored sorted by (kind, first, second), so the set, and everything computed from it,
// is the same whatever the thread count. Indices are into the CollisionPrimitives lists:
//   VertexFace    first = point,  second = triangle
//   EdgeEdge      first = edge,   second = edge, first < second
//   VertexEdge    first = point,  second = edge        (isolated points only)
//   VertexVertex  first = point,  second = point, first < second (isolated points only)
// No pair shares a particle, none joins two objects whose pair is excluded, and none has only
// particles of inverse mass 0 (two kinematic or pinned primitives cannot respond).
#pragma once

#include <cstdint>
#include <vector>

#include "nucleon/types.h"

namespace nucleon {

enum class PairKind : std::uint8_t { VertexFace, EdgeEdge, VertexEdge, VertexVertex };

struct CandidatePairs {
  std::vector<PairKind> kind;
  std::vector<Index> first;
  std::vector<Index> second;

  std::size_t size() const { return kind.size(); }
  void clear() { kind.clear(), first.clear(), second.clear(); }
  void push_back(PairKind k, Index a, Index b) {
    kind.push_back(k), first.push_back(a), second.push_back(b);
  }
};

}  // namespace nucleon
