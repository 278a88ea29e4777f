// The vertex-centric Jacobi sweep's first pass, eight particles at a time (jacobi_vertex.h).
// Compiled once per instruction set, like distance_batch.cpp (nucleon/lanes.h).
#include <type_traits>

#include "systems/solver/distance_lanes.h"
#include "systems/solver/lane_kernels.h"
#include "systems/solver/point_lanes.h"

namespace nucleon::NUCLEON_LANE_ISA {

#if NUCLEON_DISTANCE_LANES

static_assert(std::is_same_v<Real, float>, "the batched vertex path is float-only");

namespace {

constexpr Index kLanes = VertexSlotRows::kLanes;

// Pass 1 for blocks [begin, end), eight particles at a time. Per row: eight loads of the
// neighbours' positions, three contiguous loads (other, rest, W_j) and one store (the multiplier
// step), against the slot path's two Vec3 slot writes and reads per constraint.
[[gnu::target(NUCLEON_LANE_TARGET)]] void moveBlocks(const VertexSlotRows& rows,
                                                     std::span<const Vec3> positions, float* move,
                                                     float* laneLambda,
                                                     const VertexJacobiStep& step, bool accumulate,
                                                     std::size_t begin, std::size_t end) {
  const __m256i laneIndex = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i lastParticle = _mm256_set1_epi32(static_cast<int>(positions.size()) - 1);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 chainFactor = _mm256_set1_ps(step.factor), carry = _mm256_set1_ps(step.carry);
  const __m256 sheetExtra = _mm256_set1_ps(step.sheetFactor - step.factor);
  const bool accelerated = step.carry != 0;
  for (std::size_t b = begin; b < end; ++b) {
    // Per particle: the chain factor, plus the sheet's extra where rows.sheet is 1.
    const __m256 factor =
        _mm256_fmadd_ps(sheetExtra, _mm256_loadu_ps(rows.sheet.data() + kLanes * b), chainFactor);
    // Lanes past the last particle read the last particle (their rows are all padding).
    const __m256i own = _mm256_min_epi32(
        _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(kLanes * b)), laneIndex), lastParticle);
    alignas(32) Index owners[kLanes];
    _mm256_store_si256(reinterpret_cast<__m256i*>(owners), own);
    const point_lanes::Lanes3 ownPosition = point_lanes::loadPoints(positions.data(), owners);
    const __m256 xi = ownPosition.x, yi = ownPosition.y, zi = ownPosition.z;
    const __m256 ownW = _mm256_loadu_ps(rows.splitInverseMass.data() + kLanes * b);
    __m256 sx = zero, sy = zero, sz = zero;
    for (Index r = rows.blockRow[b]; r < rows.blockRow[b + 1]; ++r) {
      const std::size_t at = kLanes * r;
      const point_lanes::Lanes3 other =
          point_lanes::loadPoints(positions.data(), rows.other.data() + at);
      const __m256 dx = _mm256_sub_ps(xi, other.x);
      const __m256 dy = _mm256_sub_ps(yi, other.y);
      const __m256 dz = _mm256_sub_ps(zi, other.z);
      const __m256 length = distance_lanes::length(dx, dy, dz);
      // s = −C / ((W_i + W_j) |d|), C = |d| − L: the shared kernel's hard step.
      const __m256 s =
          distance_lanes::hardScale(length, _mm256_loadu_ps(rows.rest.data() + at), ownW,
                                    _mm256_loadu_ps(rows.otherSplitInverseMass.data() + at), false);
      sx = _mm256_fmadd_ps(s, dx, sx);
      sy = _mm256_fmadd_ps(s, dy, sy);
      sz = _mm256_fmadd_ps(s, dz, sz);
      const __m256 multiplierStep = _mm256_mul_ps(_mm256_mul_ps(factor, s), length);
      _mm256_storeu_ps(laneLambda + at,
                       accumulate ? _mm256_add_ps(_mm256_loadu_ps(laneLambda + at), multiplierStep)
                                  : multiplierStep);
    }
    const __m256 scale =
        _mm256_mul_ps(factor, _mm256_loadu_ps(rows.inverseMass.data() + kLanes * b));
    __m256 mx = _mm256_mul_ps(scale, sx), my = _mm256_mul_ps(scale, sy),
           mz = _mm256_mul_ps(scale, sz);
    float* history = move + 3 * kLanes * b;
    if (accelerated) {
      const __m256 px = _mm256_loadu_ps(history), py = _mm256_loadu_ps(history + kLanes),
                   pz = _mm256_loadu_ps(history + 2 * kLanes);
      const __m256 dot = _mm256_fmadd_ps(mx, px, _mm256_fmadd_ps(my, py, _mm256_mul_ps(mz, pz)));
      const __m256 keep = _mm256_and_ps(carry, _mm256_cmp_ps(dot, zero, _CMP_GE_OQ));
      mx = _mm256_fmadd_ps(keep, px, mx);
      my = _mm256_fmadd_ps(keep, py, my);
      mz = _mm256_fmadd_ps(keep, pz, mz);
    }
    _mm256_storeu_ps(history, mx);
    _mm256_storeu_ps(history + kLanes, my);
    _mm256_storeu_ps(history + 2 * kLanes, mz);
  }
}

}  // namespace

void moveVertexBlocks(const VertexSlotRows& rows, std::span<const Vec3> positions, Real* move,
                      Real* laneLambda, const VertexJacobiStep& step, bool accumulate,
                      std::size_t begin, std::size_t end) {
  moveBlocks(rows, positions, move, laneLambda, step, accumulate, begin, end);
}

#endif

}  // namespace nucleon::NUCLEON_LANE_ISA
