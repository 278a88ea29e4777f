// Loops over fixed blocks of items, for the sums of constraints that span many particles
// (pressure, shape matching): each block's partial sum goes to its own slot and the caller adds
// the slots in block order, so the result has the same bits at any thread count.
#pragma once

#include <cstddef>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace nucleon {

// Calls body(b) for every block b of `blockSize` items among `count`: on the calling thread when
// there are at most two blocks (a parallel loop costs more than their work), else in parallel.
template <typename Body>
void forFixedBlocks(std::size_t count, std::size_t blockSize, Body&& body) {
  const std::size_t blocks = (count + blockSize - 1) / blockSize;
  if (blocks <= 2) {
    for (std::size_t b = 0; b < blocks; ++b) body(b);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, 1),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t b = range.begin(); b < range.end(); ++b) body(b);
                    });
}

}  // namespace nucleon
