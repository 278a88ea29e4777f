// How the constraints of one family touch the particles, in the two forms the parallel sweeps
// need. Built once when the topology changes, never inside a step.
//
//  - ParticleIncidence (Jacobi): for each particle, the correction slots (constraint · arity + k)
//    that move it, in increasing order. Gathering in this fixed order, with no atomics, gives the
//    same sum for every thread count.
//  - ConstraintColoring (colored Gauss–Seidel): constraints permuted so that each color is a
//    contiguous range in which no two constraints share a particle; a color can then be solved in
//    parallel with direct writes.
#pragma once

#include <vector>

#include "nucleon/types.h"

namespace nucleon {

struct ParticleIncidence {
  std::vector<Index> offset;  // particle i's slots are slot[offset[i] .. offset[i+1])
  std::vector<Index> slot;
};

struct ConstraintColoring {
  std::vector<Index> order;        // constraint indices grouped by color
  std::vector<Index> colorOffset;  // color k is order[colorOffset[k] .. colorOffset[k+1])
  bool overflow = false;           // the last range is not a color: solve it serially
  bool inPlace = false;            // the pool is stored in this order: order[k] = k
  std::size_t colorCount() const { return colorOffset.empty() ? 0 : colorOffset.size() - 1; }
};

}  // namespace nucleon
