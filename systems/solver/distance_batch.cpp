#include "systems/solver/distance_batch.h"

#include <type_traits>

#include "systems/solver/distance_lanes.h"
#include "systems/solver/lane_kernels.h"
#include "systems/solver/point_lanes.h"

// This file is compiled once per instruction set (nucleon/lanes.h): its kernels go to the set's
// namespace, and the entries of distance_batch.h, which pick a set, to the AVX2 compile.
namespace nucleon::NUCLEON_LANE_ISA {

#if NUCLEON_DISTANCE_LANES

// The kernel reads positions as packed floats (point_lanes.h).
static_assert(std::is_same_v<Real, float>, "the batched distance path is float-only");

namespace {

using distance_lanes::multiplierScale;

[[gnu::target(NUCLEON_LANE_TARGET)]] Index projectInPlace(const DistanceBatch& b, Index begin,
                                                          Index end) {
  const __m256 zero = _mm256_setzero_ps();
  const __m256 inverseH2 = _mm256_set1_ps(b.inverseH2);
  // The pairs (a0 b0 a1 b1 a2 b2 a3 b3) become (a0 a1 a2 a3 b0 b1 b2 b3).
  const __m256i split = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
  alignas(32) float ax[8], ay[8], az[8], bx[8], by[8], bz[8];
  alignas(32) int ia[8], ib[8];
  const bool hard = b.lambda == nullptr;  // no compliances, no multipliers
  const __m256 omega = _mm256_set1_ps(hard ? b.relaxation : 1.0f);
  Index k = begin;
  for (; k + 8 <= end; k += 8) {
    const auto* pairs = reinterpret_cast<const __m256i*>(b.particles + k);
    const __m256i low = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(pairs), split);
    const __m256i high = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(pairs + 1), split);
    const __m256i a = _mm256_permute2x128_si256(low, high, 0x20);
    const __m256i c = _mm256_permute2x128_si256(low, high, 0x31);
    // Positions loaded per particle and transposed (point_lanes.h), not gathered.
    const point_lanes::Lanes3 ends[2] = {point_lanes::loadCorner(b.positions, b.particles, k, 0),
                                         point_lanes::loadCorner(b.positions, b.particles, k, 1)};
    const __m256 xa = ends[0].x, ya = ends[0].y, za = ends[0].z;
    const __m256 xb = ends[1].x, yb = ends[1].y, zb = ends[1].z;
    __m256 wa, wb;
    if (b.endInverseMass) {
      const float* pairsOfW = reinterpret_cast<const float*>(b.endInverseMass + k);
      const __m256 wLow = _mm256_permutevar8x32_ps(_mm256_loadu_ps(pairsOfW), split);
      const __m256 wHigh = _mm256_permutevar8x32_ps(_mm256_loadu_ps(pairsOfW + 8), split);
      wa = _mm256_permute2f128_ps(wLow, wHigh, 0x20);
      wb = _mm256_permute2f128_ps(wLow, wHigh, 0x31);
    } else {
      wa = point_lanes::loadCornerValues(b.inverseMass, b.particles, k, 0);
      wb = point_lanes::loadCornerValues(b.inverseMass, b.particles, k, 1);
    }

    const __m256 dx = _mm256_sub_ps(xa, xb), dy = _mm256_sub_ps(ya, yb), dz = _mm256_sub_ps(za, zb);
    const __m256 length = distance_lanes::length(dx, dy, dz);
    const __m256 lambda = hard ? zero : _mm256_loadu_ps(b.lambda + k);
    const __m256 scale = multiplierScale(length, _mm256_loadu_ps(b.rest + k),
                                         hard ? zero : _mm256_loadu_ps(b.compliance + k),
                                         hard ? zero : _mm256_loadu_ps(b.compressionCompliance + k),
                                         lambda, wa, wb, inverseH2, b.unilateral);
    if (!hard) _mm256_storeu_ps(b.lambda + k, _mm256_fmadd_ps(scale, length, lambda));
    // Bit j set: that end of constraint j is free and moves, and is written back. A constraint
    // with a zero step leaves finite ends where they are (x + 0·d = x), so its stores are skipped:
    // a coarse unilateral limit grips in about a third of its lanes (36% on the 128² hanging
    // cloth), and a batch of slack limits writes nothing. A NaN step is stored, as before, for
    // the non-finite repairs to find.
    const int moves = _mm256_movemask_ps(_mm256_cmp_ps(scale, zero, _CMP_NEQ_UQ));
    const int freeA = moves & _mm256_movemask_ps(_mm256_cmp_ps(wa, zero, _CMP_NEQ_OQ));
    const int freeB = moves & _mm256_movemask_ps(_mm256_cmp_ps(wb, zero, _CMP_NEQ_OQ));
    if ((freeA | freeB) == 0) continue;
    // ω = 1 multiplies exactly: the plain step's bits.
    const __m256 sa = _mm256_mul_ps(wa, _mm256_mul_ps(omega, scale)),
                 sb = _mm256_mul_ps(wb, _mm256_mul_ps(omega, scale));
    _mm256_store_ps(ax, _mm256_fmadd_ps(sa, dx, xa));
    _mm256_store_ps(ay, _mm256_fmadd_ps(sa, dy, ya));
    _mm256_store_ps(az, _mm256_fmadd_ps(sa, dz, za));
    _mm256_store_ps(bx, _mm256_fnmadd_ps(sb, dx, xb));
    _mm256_store_ps(by, _mm256_fnmadd_ps(sb, dy, yb));
    _mm256_store_ps(bz, _mm256_fnmadd_ps(sb, dz, zb));
    _mm256_store_si256(reinterpret_cast<__m256i*>(ia), a);
    _mm256_store_si256(reinterpret_cast<__m256i*>(ib), c);
    for (int j = 0; j < 8; ++j) {
      if (freeA >> j & 1) b.positions[ia[j]] = Vec3(ax[j], ay[j], az[j]);
      if (freeB >> j & 1) b.positions[ib[j]] = Vec3(bx[j], by[j], bz[j]);
    }
  }
  return k;
}

// The Jacobi batch: the arithmetic of projectInPlace with split inverse masses, the result written
// to the constraints' slots. Positions are only read, so constraints may share particles.
[[gnu::target(NUCLEON_LANE_TARGET)]] Index projectJacobi(const DistanceJacobiBatch& b, Index begin,
                                                         Index end) {
  const __m256 zero = _mm256_setzero_ps();
  const __m256 inverseH2 = _mm256_set1_ps(b.inverseH2);
  const __m256 relaxation = _mm256_set1_ps(b.relaxation), step = _mm256_set1_ps(b.step);
  const __m256 carry = _mm256_set1_ps(b.carry);
  const bool accelerated = b.carry != 0;
  Index k = begin;
  for (; k + 8 <= end; k += 8) {
    const point_lanes::Lanes3 endA = point_lanes::loadCorner(b.positions, b.particles, k, 0);
    const point_lanes::Lanes3 endB = point_lanes::loadCorner(b.positions, b.particles, k, 1);
    const __m256 dx = _mm256_sub_ps(endA.x, endB.x);
    const __m256 dy = _mm256_sub_ps(endA.y, endB.y);
    const __m256 dz = _mm256_sub_ps(endA.z, endB.z);
    const __m256 wa = point_lanes::loadCornerValues(b.splitInverseMass, b.particles, k, 0);
    const __m256 wb = point_lanes::loadCornerValues(b.splitInverseMass, b.particles, k, 1);

    const __m256 length = distance_lanes::length(dx, dy, dz);
    const __m256 stretchCompliance = _mm256_loadu_ps(b.compliance + k);
    const __m256 compressionCompliance = _mm256_loadu_ps(b.compressionCompliance + k);
    const __m256 lambda = _mm256_loadu_ps(b.lambda + k);
    const __m256 scale =
        multiplierScale(length, _mm256_loadu_ps(b.rest + k), stretchCompliance,
                        compressionCompliance, lambda, wa, wb, inverseH2, b.unilateral);
    // Every constraint is accelerated on the accelerated sweeps (the batches take undamped pools
    // only): a hard one (both compliances 0) with a restart per slot, a compliant one with its
    // multiplier's history and a restart per constraint (constraint_sweeps.h).
    __m256 hard = _mm256_and_ps(_mm256_cmp_ps(stretchCompliance, zero, _CMP_EQ_OQ),
                                _mm256_cmp_ps(compressionCompliance, zero, _CMP_EQ_OQ));
    const __m256 factor = accelerated ? step : relaxation;
    const __m256 scaled = _mm256_mul_ps(factor, scale);
    const __m256 stepLambda = _mm256_mul_ps(scaled, length);
    __m256 carried = zero;  // the compliant lanes' carry, 0 where they restart
    if (accelerated) {
      const __m256 previous = _mm256_loadu_ps(b.lambdaMove + k);
      const __m256 along = _mm256_cmp_ps(_mm256_mul_ps(stepLambda, previous), zero, _CMP_GE_OQ);
      carried = _mm256_andnot_ps(hard, _mm256_and_ps(along, carry));
      const __m256 move = _mm256_fmadd_ps(carried, previous, stepLambda);
      _mm256_storeu_ps(b.lambda + k,
                       _mm256_blendv_ps(_mm256_add_ps(lambda, move),
                                        _mm256_fmadd_ps(scaled, length, lambda), hard));
      _mm256_storeu_ps(b.lambdaMove + k, move);
    } else {
      hard = zero;
      _mm256_storeu_ps(b.lambda + k, _mm256_fmadd_ps(scaled, length, lambda));
      _mm256_storeu_ps(b.lambdaMove + k, stepLambda);
    }
    // The slots u_a = g_a d and u_b = −g_b d, plus the carried history where it is kept, in
    // lanes; the same operations as the scalar jacobiOne, component by component.
    const __m256 ga = _mm256_mul_ps(wa, scaled);
    const __m256 gb = _mm256_xor_ps(_mm256_set1_ps(-0.0f), _mm256_mul_ps(wb, scaled));
    point_lanes::Lanes3 u[2] = {
        {_mm256_mul_ps(ga, dx), _mm256_mul_ps(ga, dy), _mm256_mul_ps(ga, dz)},
        {_mm256_mul_ps(gb, dx), _mm256_mul_ps(gb, dy), _mm256_mul_ps(gb, dz)}};
    const __m256 keep = _mm256_and_ps(carry, hard);
    Vec3* slot = b.correction + 2 * std::size_t{k};
    if (_mm256_movemask_ps(_mm256_cmp_ps(_mm256_or_ps(keep, carried), zero, _CMP_NEQ_OQ)) != 0) {
      for (int e = 0; e < 2; ++e) {
        __m128 row[8];
        for (int j = 0; j < 8; ++j) row[j] = point_lanes::loadSlot(slot[2 * j + e]);
        const point_lanes::Lanes3 old = point_lanes::transposeRows(row);
        // Adaptive restart per slot of a hard constraint, as in the scalar path
        // (constraint_sweeps.h): u · u_prev = x x' + (y y' + z z'), Eigen's order for a Vec3.
        const __m256 along = _mm256_add_ps(
            _mm256_mul_ps(u[e].x, old.x),
            _mm256_add_ps(_mm256_mul_ps(u[e].y, old.y), _mm256_mul_ps(u[e].z, old.z)));
        const __m256 kept =
            _mm256_or_ps(_mm256_and_ps(keep, _mm256_cmp_ps(along, zero, _CMP_GE_OQ)), carried);
        u[e] = {_mm256_add_ps(u[e].x, _mm256_mul_ps(kept, old.x)),
                _mm256_add_ps(u[e].y, _mm256_mul_ps(kept, old.y)),
                _mm256_add_ps(u[e].z, _mm256_mul_ps(kept, old.z))};
      }
    }
    for (int e = 0; e < 2; ++e) {
      __m128 row[8];
      point_lanes::transposeLanes(u[e], row);
      for (int j = 0; j < 8; ++j) point_lanes::storeSlot(slot[2 * j + e], row[j]);
    }
  }
  return k;
}

}  // namespace

Index projectDistanceBatches(const InPlaceBatch<2>& batch, Index begin, Index end) {
  return projectInPlace(batch, begin, end);
}

Index projectDistanceJacobiBatches(const JacobiBatch<2>& batch, Index begin, Index end) {
  return projectJacobi(batch, begin, end);
}

#endif

}  // namespace nucleon::NUCLEON_LANE_ISA

#if !defined(NUCLEON_LANES_AVX512)

namespace nucleon {

bool distanceBatchesAvailable() {
  return laneIsa() != LaneIsa::None;
}

Index projectDistanceBatches(const DistanceBatch& batch, Index begin, Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), projectDistanceBatches, begin, batch, begin, end);
}

Index projectDistanceJacobiBatches(const DistanceJacobiBatch& batch, Index begin, Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), projectDistanceJacobiBatches, begin, batch, begin, end);
}

}  // namespace nucleon

#endif
