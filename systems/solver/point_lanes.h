// Eight particles' positions into AVX2 lanes without gathers: each Vec3 is loaded as (x, y, z, 0)
// by two loads that stay inside its own twelve bytes (an unaligned 16-byte load could read past
// the last particle), and eight such rows are transposed in registers into lanes of x, y and z.
// Compiled for AVX-512 (nucleon/lanes.h), one masked load or store of three floats does what two do
// here: the same bytes are read and written, and a particle's loads and stores cost half (a
// hanging cloth's step 10-20% on the 2-core AMD EPYC, bench/results/2core-AMD-EPYC).
// On the 2-core AMD EPYC machines measured this was about a third faster than three
// vgatherdps per corner (angular_batch.cpp, distance_batch.cpp), whose microcoded gathers cost
// more than the loads and shuffles together.
//
// Written for float state on x86-64 with AVX2; callers check distanceBatchesAvailable()
// (distance_batch.h) before running a function compiled with this header's target.
#pragma once

#include "systems/solver/distance_lanes.h"

#if NUCLEON_DISTANCE_LANES

#include <cstring>

#include "nucleon/types.h"

namespace nucleon::NUCLEON_LANE_ISA::point_lanes {

struct Lanes3 {
  __m256 x, y, z;
};

// (x, y) as one 8-byte load through memcpy (a Vec3 is only 4-byte aligned: a double read through
// a cast pointer would be a misaligned load in the language's terms), z as a float load; with
// AVX-512, one load of the three floats (the fourth lane masked off: never read, zero).
[[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline __m128 loadPoint(
    const Vec3& point) {
#if defined(NUCLEON_LANES_AVX512)
  return _mm_maskz_loadu_ps(0x7, point.data());
#else
  double xy;
  std::memcpy(&xy, point.data(), sizeof xy);
  return _mm_movelh_ps(_mm_castpd_ps(_mm_set_sd(xy)), _mm_load_ss(point.data() + 2));
#endif
}

// The same load in two accesses in every compile: for the Jacobi slots, which a batch writes in
// a stream of twelve-byte records and a gather reads back. There the masked form measured 6–16%
// slower on the 2-core AMD EPYC (the bend hinges' Jacobi sweep, BM_Sweep).
[[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline __m128 loadSlot(const Vec3& slot) {
  double xy;
  std::memcpy(&xy, slot.data(), sizeof xy);
  return _mm_movelh_ps(_mm_castpd_ps(_mm_set_sd(xy)), _mm_load_ss(slot.data() + 2));
}

// Eight rows (x, y, z, 0), one per lane, to lanes of x, y and z.
[[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline Lanes3 transposeRows(
    const __m128* point) {
  __m256 row[4];
  for (int j = 0; j < 4; ++j) row[j] = _mm256_set_m128(point[j + 4], point[j]);
  // Rows (x_j y_j z_j 0 | x_j+4 y_j+4 z_j+4 0) to (x_0 … x_7), (y_0 … y_7), (z_0 … z_7).
  const __m256 t0 = _mm256_unpacklo_ps(row[0], row[1]), t1 = _mm256_unpacklo_ps(row[2], row[3]);
  const __m256 t2 = _mm256_unpackhi_ps(row[0], row[1]), t3 = _mm256_unpackhi_ps(row[2], row[3]);
  return {_mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(1, 0, 1, 0)),
          _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(3, 2, 3, 2)),
          _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(1, 0, 1, 0))};
}

// The inverse of transposeRows: lanes of x, y and z to eight rows (x, y, z, 0).
[[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline void transposeLanes(
    const Lanes3& lanes, __m128* point) {
  const __m256 zero = _mm256_setzero_ps();
  const __m256 t0 = _mm256_unpacklo_ps(lanes.x, lanes.y), t1 = _mm256_unpackhi_ps(lanes.x, lanes.y);
  const __m256 t2 = _mm256_unpacklo_ps(lanes.z, zero), t3 = _mm256_unpackhi_ps(lanes.z, zero);
  // Rows j and j + 4 share a register: (x_j y_j z_j 0 | x_j+4 y_j+4 z_j+4 0).
  const __m256 row[4] = {_mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0)),
                         _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2)),
                         _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0)),
                         _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2))};
  for (int j = 0; j < 4; ++j) {
    point[j] = _mm256_castps256_ps128(row[j]);
    point[j + 4] = _mm256_extractf128_ps(row[j], 1);
  }
}

// Writes a row's (x, y, z) to `point`: two stores inside its twelve bytes, or one masked store.
[[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline void storePoint(Vec3& point,
                                                                                __m128 row) {
#if defined(NUCLEON_LANES_AVX512)
  _mm_mask_storeu_ps(point.data(), 0x7, row);
#else
  const double xy = _mm_cvtsd_f64(_mm_castps_pd(row));
  std::memcpy(point.data(), &xy, sizeof xy);
  _mm_store_ss(point.data() + 2, _mm_movehl_ps(row, row));
#endif
}

// The store of loadSlot's records: two accesses in every compile.
[[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline void storeSlot(Vec3& slot,
                                                                               __m128 row) {
  const double xy = _mm_cvtsd_f64(_mm_castps_pd(row));
  std::memcpy(slot.data(), &xy, sizeof xy);
  _mm_store_ss(slot.data() + 2, _mm_movehl_ps(row, row));
}

// The positions of particles ids[0 … 7].
[[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline Lanes3 loadPoints(
    const Vec3* positions, const Index* ids) {
  __m128 point[8];
  for (int j = 0; j < 8; ++j) point[j] = loadPoint(positions[ids[j]]);
  return transposeRows(point);
}

// The positions of corner `corner` of constraints k … k+7 (particles[k + j][corner]).
template <class Tuple>
[[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline Lanes3 loadCorner(
    const Vec3* positions, const Tuple* particles, std::size_t k, int corner) {
  __m128 point[8];
  for (int j = 0; j < 8; ++j) point[j] = loadPoint(positions[particles[k + j][corner]]);
  return transposeRows(point);
}

// One float per constraint k … k+7 from a per-particle array, at corner `corner`
// (values[particles[k + j][corner]]): eight scalar loads. On the 2-core AMD EPYC measured, a
// vgatherdps of the same eight took a quarter of a coarse distance sweep's time (microcoded, as
// the positions' gathers above).
template <class Tuple>
[[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline __m256 loadCornerValues(
    const float* values, const Tuple* particles, std::size_t k, int corner) {
  return _mm256_setr_ps(values[particles[k][corner]], values[particles[k + 1][corner]],
                        values[particles[k + 2][corner]], values[particles[k + 3][corner]],
                        values[particles[k + 4][corner]], values[particles[k + 5][corner]],
                        values[particles[k + 6][corner]], values[particles[k + 7][corner]]);
}

}  // namespace nucleon::NUCLEON_LANE_ISA::point_lanes

namespace nucleon {
namespace point_lanes = NUCLEON_LANE_ISA::point_lanes;
}

#endif
