// Neighbour search of the liquids: a uniform hash grid of cell size H over the liquid particles,
// rebuilt every substep from the predicted positions (ARCHITECTURE.md §2).
#pragma once

#include <span>

#include "components/liquid_pool.h"
#include "nucleon/types.h"

namespace nucleon {

// Sorts the liquid particles into slots by cell and fills each slot's mass, inverse mass and
// position (from `x`, the whole particle pool) and its neighbour list: every pair of liquid
// particles closer than the kernel radius, each list in a fixed order (the 27 cells around it in
// a fixed order, each cell's particles in list order), so the lists, and every sum over them, are
// the same at any thread count. Grows the grid and lists only when the liquids grew; counts the
// neighbours dropped beyond the list's stride.
void buildNeighbourLists(LiquidPool& pool, std::span<const Vec3> x, std::span<const Real> w);

// The stride of a particle's neighbour list for a kernel scale: room for 1.6 times the
// neighbours of a particle at rest density, up to kMaxLiquidNeighbours.
int neighbourStride(Real kernelScale);

}  // namespace nucleon
