// The entries of the lane kernels, one set per instruction set they are compiled for
// (nucleon/lanes.h), and the call that picks the set in use. Included by the files that dispatch
// (distance_batch.cpp, angular_batch.cpp, jacobi_vertex.cpp); everyone else calls the entries of
// distance_batch.h, angular_batch.h and jacobi_vertex.h.
#pragma once

#include <cstddef>
#include <span>

#include "components/constraint_graph.h"
#include "nucleon/lanes.h"
#include "nucleon/types.h"
#include "systems/solver/batch_parameters.h"
#include "systems/solver/distance_lanes.h"
#include "systems/solver/jacobi_vertex.h"

// Each set's entries: the batches project as projectDistanceBatches (distance_batch.h) and the
// like; moveVertexBlocks is the vertex sweep's first pass for blocks [begin, end).
#define NUCLEON_LANE_KERNEL_ENTRIES                                                                \
  Index projectDistanceBatches(const InPlaceBatch<2>& batch, Index begin, Index end);              \
  Index projectDistanceJacobiBatches(const JacobiBatch<2>& batch, Index begin, Index end);         \
  Index projectHingeBatches(const InPlaceBatch<4>& batch, Index begin, Index end);                 \
  Index projectHingeJacobiBatches(const JacobiBatch<4>& batch, Index begin, Index end);            \
  Index projectIsometricBendBatches(const InPlaceBatch<4>& batch, Index begin, Index end);         \
  Index projectIsometricBendJacobiBatches(const JacobiBatch<4>& batch, Index begin, Index end);    \
  Index projectAngleBatches(const InPlaceBatch<3>& batch, Index begin, Index end);                 \
  Index projectAngleJacobiBatches(const JacobiBatch<3>& batch, Index begin, Index end);            \
  Index accumulateHingeJacobiBatches(const JacobiBatch<4>& batch, Index begin, Index end);         \
  Index accumulateIsometricBendJacobiBatches(const JacobiBatch<4>& batch, Index begin, Index end); \
  Index accumulateAngleJacobiBatches(const JacobiBatch<3>& batch, Index begin, Index end);         \
  void moveVertexBlocks(const VertexSlotRows& rows, std::span<const Vec3> positions, Real* move,   \
                        Real* laneLambda, const VertexJacobiStep& step, bool accumulate,           \
                        std::size_t begin, std::size_t end);

namespace nucleon::avx2 {
NUCLEON_LANE_KERNEL_ENTRIES
}  // namespace nucleon::avx2

namespace nucleon::avx512 {
NUCLEON_LANE_KERNEL_ENTRIES
}  // namespace nucleon::avx512

#undef NUCLEON_LANE_KERNEL_ENTRIES

// `function(arguments…)` of the set `isa` (read once, so that a call never mixes two sets);
// `none` where no set runs (the caller's scalar path then does the work). A build without lanes
// (double state, or not x86-64) has no kernels to call: there it is always `none`.
#if NUCLEON_DISTANCE_LANES
#define NUCLEON_CALL_LANES(isa, function, none, ...)     \
  [&] {                                                  \
    switch (isa) {                                       \
      case ::nucleon::LaneIsa::Avx512:                   \
        return ::nucleon::avx512::function(__VA_ARGS__); \
      case ::nucleon::LaneIsa::Avx2:                     \
        return ::nucleon::avx2::function(__VA_ARGS__);   \
      default:                                           \
        return none;                                     \
    }                                                    \
  }()
#else
namespace nucleon {
template <class... Arguments>
void ignoreLaneArguments(const Arguments&...) {}
}  // namespace nucleon
#define NUCLEON_CALL_LANES(isa, function, none, ...)  \
  [&] {                                               \
    ::nucleon::ignoreLaneArguments(isa, __VA_ARGS__); \
    return none;                                      \
  }()
#endif
