// The loop of a colored Gauss–Seidel sweep, shared by every constraint family: colors run one
// after another, the constraints of a color in parallel (no two share a particle, so direct writes
// do not race and the result does not depend on the thread count), and the overflow range, if
// any, serially at the end.
#pragma once

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "components/constraint_graph.h"

namespace nucleon {

// Calls project(c) once for every constraint index c in coloring order.
template <class Project>
__attribute__((flatten)) void forEachColor(const ConstraintColoring& coloring, std::size_t grain,
                                           Project&& project) {
  for (std::size_t k = 0; k < coloring.colorCount(); ++k) {
    const Index begin = coloring.colorOffset[k], end = coloring.colorOffset[k + 1];
    if (coloring.overflow && k + 1 == coloring.colorCount()) {
      for (Index o = begin; o < end; ++o) project(coloring.order[o]);
      continue;
    }
    // flatten: the per-constraint projection must inline into this loop.
    tbb::parallel_for(
        tbb::blocked_range<Index>(begin, end, grain), [&](const tbb::blocked_range<Index>& r)
                                                          __attribute__((flatten)) {
                                                            for (Index o = r.begin(); o != r.end();
                                                                 ++o)
                                                              project(coloring.order[o]);
                                                          });
  }
}

// The same loop by ranges for batched kernels: projectRange(begin, end) for pieces of a color
// (positions in coloring order; no two constraints of a piece share a free particle), whose
// starts are `batch` constraints apart from the color's start whatever the thread count, so
// that which constraints a batch holds, and hence the rounding, never depends on the
// partitioning; projectOne(c) for the overflow range.
template <class ProjectRange, class ProjectOne>
void forEachColorRange(const ConstraintColoring& coloring, std::size_t grain, Index batch,
                       ProjectRange&& projectRange, ProjectOne&& projectOne) {
  for (std::size_t k = 0; k < coloring.colorCount(); ++k) {
    const Index begin = coloring.colorOffset[k], end = coloring.colorOffset[k + 1];
    if (coloring.overflow && k + 1 == coloring.colorCount()) {
      for (Index o = begin; o < end; ++o) projectOne(coloring.order[o]);
      continue;
    }
    const Index batches = (end - begin + batch - 1) / batch;
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, batches, std::max<std::size_t>(1, grain / batch)),
        [&](const tbb::blocked_range<Index>& r) {
          projectRange(begin + r.begin() * batch, std::min(end, begin + r.end() * batch));
        },
        tbb::static_partitioner());
  }
}

}  // namespace nucleon
