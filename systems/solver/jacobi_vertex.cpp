#include "systems/solver/jacobi_vertex.h"

#include <algorithm>
#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "systems/solver/distance_batch.h"

#include "systems/solver/distance_lanes.h"
#include "systems/solver/lane_kernels.h"

namespace nucleon {
namespace {

constexpr Index kLanes = VertexSlotRows::kLanes;
// Edges shorter than this, or with both ends fixed, get no correction (as in distance_batch.cpp).
constexpr Real kTiny = Real(1e-12);

// Pass 1 for the particles of block b, one at a time: the arithmetic of moveVertexBlocks
// (jacobi_vertex_lanes.cpp).
void moveBlockScalar(const VertexSlotRows& rows, std::size_t b, std::span<const Vec3> positions,
                     Real* move, Real* laneLambda, const VertexJacobiStep& step, bool accumulate) {
  for (Index lane = 0; lane < kLanes; ++lane) {
    const std::size_t i = kLanes * b + lane;
    if (i >= positions.size()) break;
    const Vec3 own = positions[i];
    const Real ownW = rows.splitInverseMass[i];
    const Real factor = rows.sheet[i] != 0 ? step.sheetFactor : step.factor;
    Vec3 sum = Vec3::Zero();
    for (Index r = rows.blockRow[b]; r < rows.blockRow[b + 1]; ++r) {
      const std::size_t at = kLanes * r + lane;
      const Vec3 d = own - positions[rows.other[at]];
      const Real length = d.norm();
      const Real stiffness = ownW + rows.otherSplitInverseMass[at];
      Real multiplierStep = 0;
      if (length >= kTiny && stiffness >= kTiny) {
        const Real s = (rows.rest[at] - length) / (stiffness * length);
        sum += s * d;
        multiplierStep = factor * s * length;
      }
      laneLambda[at] = accumulate ? laneLambda[at] + multiplierStep : multiplierStep;
    }
    Vec3 m = (factor * rows.inverseMass[i]) * sum;
    Real* history = move + 3 * kLanes * b + lane;
    if (step.carry != 0) {
      const Vec3 previous(history[0], history[kLanes], history[2 * kLanes]);
      // Adaptive restart, per particle (the slot path's rule, constraint_sweeps.h).
      if (m.dot(previous) >= 0) m += step.carry * previous;
    }
    history[0] = m.x();
    history[kLanes] = m.y();
    history[2 * kLanes] = m.z();
  }
}

#if NUCLEON_DISTANCE_LANES

// Pass 2's multipliers for constraints [begin, end), eight at a time: λ_c += the value of c's
// end-0 lane. Returns the first constraint left to the caller.
[[gnu::target(NUCLEON_LANE_TARGET)]] std::size_t bookLambdaAvx2(const VertexSlotRows& rows,
                                                                const float* laneLambda,
                                                                float* lambda, std::size_t begin,
                                                                std::size_t end) {
  std::size_t c = begin;
  for (; c + kLanes <= end; c += kLanes) {
    const __m256i lane =
        _mm256_loadu_si256(reinterpret_cast<const __m256i*>(rows.lambdaLane.data() + c));
    _mm256_storeu_ps(lambda + c, _mm256_add_ps(_mm256_loadu_ps(lambda + c),
                                               _mm256_i32gather_ps(laneLambda, lane, 4)));
  }
  return c;
}

#endif

}  // namespace

VertexSlotRows buildVertexSlotRows(std::span<const std::array<Index, 2>> constraints,
                                   std::span<const Real> rest, const ParticleIncidence& incidence,
                                   std::span<const Real> splitInverseMass) {
  VertexSlotRows rows;
  const std::size_t n = incidence.offset.size() - 1;
  const std::size_t blocks = (n + kLanes - 1) / kLanes;
  auto slotsOf = [&](std::size_t i) { return incidence.offset[i + 1] - incidence.offset[i]; };
  rows.blockRow.assign(blocks + 1, 0);
  for (std::size_t b = 0; b < blocks; ++b) {
    Index most = 0;
    for (std::size_t i = kLanes * b; i < std::min(n, kLanes * (b + 1)); ++i)
      most = std::max(most, slotsOf(i));
    rows.blockRow[b + 1] = rows.blockRow[b] + most;
  }
  const std::size_t lanes = std::size_t{kLanes} * rows.blockRow[blocks];
  rows.other.assign(lanes, 0);
  rows.rest.assign(lanes, 0);
  rows.otherSplitInverseMass.assign(lanes, 0);
  rows.lambdaLane.assign(constraints.size(), 0);
  rows.splitInverseMass.assign(kLanes * blocks, 0);
  rows.inverseMass.assign(kLanes * blocks, 0);
  rows.sheet.assign(kLanes * blocks, 0);
  for (std::size_t b = 0; b < blocks; ++b)
    for (Index lane = 0; lane < kLanes; ++lane) {
      const std::size_t i = kLanes * b + lane;
      // Padding: a zero-length edge from the lane's particle (the last one past the end) to
      // itself, which the sweep leaves without correction.
      const auto own = static_cast<Index>(std::min(i, n - 1));
      for (Index r = rows.blockRow[b]; r < rows.blockRow[b + 1]; ++r)
        rows.other[kLanes * r + lane] = own;
      if (i >= n) continue;
      const Index count = slotsOf(i);
      rows.splitInverseMass[i] = splitInverseMass[i];
      rows.inverseMass[i] = count == 0 ? Real(0) : splitInverseMass[i] / Real(count);
      rows.sheet[i] = count >= VertexSlotRows::kSheetSlots ? Real(1) : Real(0);
      for (Index k = 0; k < count; ++k) {
        const Index slot = incidence.slot[incidence.offset[i] + k];
        const Index c = slot / 2, end = slot % 2;
        const Index j = constraints[c][1 - end];
        const std::size_t at = kLanes * (rows.blockRow[b] + k) + lane;
        rows.other[at] = j;
        rows.rest[at] = rest[c];
        rows.otherSplitInverseMass[at] = splitInverseMass[j];
        if (end == 0) rows.lambdaLane[c] = static_cast<Index>(at);
      }
    }
  return rows;
}

void solveDistanceJacobiVertex(const VertexSlotRows& rows, std::span<Real> move,
                               std::span<Real> laneLambda, std::span<Vec3> positions,
                               const VertexJacobiStep& step, bool accumulate) {
  const std::size_t blocks = rows.blockCount();
  const std::span<const Vec3> p = positions;
  const LaneIsa isa = laneIsa();  // one set for the whole sweep
  // Pass 1: every particle's move from the same positions, into the history, and every slot's
  // multiplier step into its lane.
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, blocks, 64),
      [&](const tbb::blocked_range<std::size_t>& r) {
        if (isa != LaneIsa::None) {
          NUCLEON_CALL_LANES(isa, moveVertexBlocks, (void)0, rows, p, move.data(),
                             laneLambda.data(), step, accumulate, r.begin(), r.end());
          return;
        }
        for (std::size_t b = r.begin(); b != r.end(); ++b)
          moveBlockScalar(rows, b, p, move.data(), laneLambda.data(), step, accumulate);
      },
      tbb::static_partitioner());
  // Pass 2: the moves.
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, blocks, 256),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t b = r.begin(); b != r.end(); ++b) {
          const Real* history = move.data() + 3 * kLanes * b;
          const std::size_t count = std::min<std::size_t>(kLanes, positions.size() - kLanes * b);
          for (std::size_t lane = 0; lane < count; ++lane)
            positions[kLanes * b + lane] +=
                Vec3(history[lane], history[kLanes + lane], history[2 * kLanes + lane]);
        }
      },
      tbb::static_partitioner());
}

void bookVertexLambda(const VertexSlotRows& rows, std::span<const Real> laneLambda,
                      std::span<Real> lambda) {
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, lambda.size(), 4096),
      [&](const tbb::blocked_range<std::size_t>& r) {
        std::size_t c = r.begin();
#if NUCLEON_DISTANCE_LANES
        if (distanceBatchesAvailable())
          c = bookLambdaAvx2(rows, laneLambda.data(), lambda.data(), c, r.end());
#endif
        for (; c < r.end(); ++c) lambda[c] += laneLambda[rows.lambdaLane[c]];
      },
      tbb::static_partitioner());
}

}  // namespace nucleon
