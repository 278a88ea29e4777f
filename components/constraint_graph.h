// How the constraints of one family touch the particles, in the two forms the parallel sweeps
// need. Built once when the topology changes, never inside a step.
//
//  - ParticleIncidence (Jacobi): for each particle, the correction slots (constraint · arity + k)
//    that move it, in increasing order. Gathering in this fixed order, with no atomics, gives the
//    same sum for every thread count.
//  - ConstraintColoring (colored Gauss–Seidel): constraints permuted so that each color is a
//    contiguous range in which no two constraints share a particle; a color can then be solved in
//    parallel with direct writes.
//  - VertexSlotRows (vertex-centric Jacobi of hard distance constraints): the incidence again,
//    laid out so that eight consecutive particles walk their slots in step, one per SIMD lane.
#pragma once

#include <vector>

#include "nucleon/types.h"

namespace nucleon {

struct ParticleIncidence {
  std::vector<Index> offset;  // particle i's slots are slot[offset[i] .. offset[i+1])
  std::vector<Index> slot;
};

// ParticleIncidence of a two-particle family transposed into rows of eight lanes: block b holds
// particles 8b … 8b+7, and its rows blockRow[b] … blockRow[b+1] − 1 hold, in lane l, the k-th
// slot of particle 8b + l (k = row − blockRow[b], in the incidence's slot order). A block has as
// many rows as its particle with the most slots; the lanes of particles with fewer slots (and of
// the lanes past the last particle) point back at their own particle with rest length 0 and
// inverse mass 0: a zero-length edge, which the projection leaves without correction. Per-lane
// columns are indexed 8 · row + lane, per-particle ones 8 · block + lane (padded to whole
// blocks).
struct VertexSlotRows {
  static constexpr Index kLanes = 8;
  std::vector<Index> blockRow;              // size blocks + 1
  std::vector<Index> other;                 // per lane: the slot's other particle
  std::vector<Real> rest;                   // per lane: the constraint's rest length
  std::vector<Real> otherSplitInverseMass;  // per lane: the other particle's split inverse mass
  // Per constraint: the lane (8 · row + lane) of its end-0 slot, the one that books its
  // multiplier.
  std::vector<Index> lambdaLane;
  std::vector<Real> splitInverseMass;  // per particle: W_i = n_i w_i (0 on padding)
  std::vector<Real> inverseMass;       // per particle: w_i = W_i / n_i (0 on padding)
  // Per particle: 1 where it has at least kSheetSlots slots (inside a sheet or a solid), 0 where
  // it has fewer (on a chain, at a chain's end, or padding); picks the step's relaxation.
  std::vector<Real> sheet;
  static constexpr Index kSheetSlots = 3;
  std::size_t blockCount() const { return blockRow.empty() ? 0 : blockRow.size() - 1; }
};

struct ConstraintColoring {
  std::vector<Index> order;        // constraint indices grouped by color
  std::vector<Index> colorOffset;  // color k is order[colorOffset[k] .. colorOffset[k+1])
  bool overflow = false;           // the last range is not a color: solve it serially
  bool inPlace = false;            // the pool is stored in this order: order[k] = k
  std::size_t colorCount() const { return colorOffset.empty() ? 0 : colorOffset.size() - 1; }
};

}  // namespace nucleon
