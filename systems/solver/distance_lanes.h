// The batched distance kernel that every AVX2 distance path shares: the distance batches of
// colored Gauss–Seidel and Jacobi (distance_batch.cpp), the vertex-centric Jacobi sweep
// (jacobi_vertex.cpp) and the tethers' layered sweep (tether_sweep.cpp). Eight lanes of
//   C = |d| − L,   scale = (−C − α̃ λ) / ((w_a + w_b + α̃) |d|),   Δλ = scale |d|,
// the undamped XPBD step of Macklin et al. 2016 (eq. 18) with Δλ n = scale d sharing one division
// (n = d/|d|): end a moves by w_a scale d, end b by −w_b scale d. α̃ is the stretch or the
// compression compliance over h², by the side the multiplier ends on (the sign of (w_a + w_b) λ −
// C). Lanes with a degenerate edge (|d| < 1e-12), two fixed ends or, unilateral, a slack limit get
// scale 0. With α = λ = 0 this is the plain PBD step −C d / ((w_a + w_b) |d|), which the hard paths
// take.
//
// Written for float state on x86-64 with AVX2 and FMA; callers check distanceBatchesAvailable()
// (distance_batch.h) before running a function compiled with this header's target.
//
// The lane kernels are compiled once per instruction set (nucleon/lanes.h): NUCLEON_LANE_ISA names
// the set of this translation unit (the namespace its kernels live in) and NUCLEON_LANE_TARGET is
// the target attribute of its lane functions. A file compiled for AVX-512 defines
// NUCLEON_LANES_AVX512 before its first include.
#pragma once

#if defined(NUCLEON_LANES_AVX512)
#define NUCLEON_LANE_ISA avx512
#define NUCLEON_LANE_TARGET "avx2,fma,avx512f,avx512vl"
#else
#define NUCLEON_LANE_ISA avx2
#define NUCLEON_LANE_TARGET "avx2,fma"
#endif

#if (defined(__x86_64__) || defined(__i386__)) && !defined(NUCLEON_DOUBLE)
#include <immintrin.h>
#define NUCLEON_DISTANCE_LANES 1

namespace nucleon::NUCLEON_LANE_ISA::distance_lanes {

// |d| per lane.
[[gnu::target(NUCLEON_LANE_TARGET)]] inline __m256 length(__m256 dx, __m256 dy, __m256 dz) {
  return _mm256_sqrt_ps(_mm256_fmadd_ps(dx, dx, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dz, dz))));
}

// scale per lane, as above.
[[gnu::target(NUCLEON_LANE_TARGET)]] inline __m256 multiplierScale(
    __m256 length, __m256 rest, __m256 stretchCompliance, __m256 compressionCompliance,
    __m256 lambda, __m256 wa, __m256 wb, __m256 inverseH2, bool unilateral) {
  const __m256 tiny = _mm256_set1_ps(1e-12f), zero = _mm256_setzero_ps();
  const __m256 constraint = _mm256_sub_ps(length, rest);
  const __m256 stiffness = _mm256_add_ps(wa, wb);
  // The side the multiplier ends on: C < s λ (kernel_detail::belowRest, constraint_kernels.h).
  const __m256 below = _mm256_cmp_ps(constraint, _mm256_mul_ps(stiffness, lambda), _CMP_LT_OQ);
  const __m256 alpha =
      _mm256_mul_ps(_mm256_blendv_ps(stretchCompliance, compressionCompliance, below), inverseH2);
  __m256 active = _mm256_and_ps(_mm256_cmp_ps(length, tiny, _CMP_GE_OQ),
                                _mm256_cmp_ps(stiffness, tiny, _CMP_GE_OQ));
  if (unilateral) active = _mm256_and_ps(active, _mm256_cmp_ps(constraint, zero, _CMP_GT_OQ));
  const __m256 numerator = _mm256_sub_ps(zero, _mm256_fmadd_ps(alpha, lambda, constraint));
  return _mm256_and_ps(_mm256_div_ps(numerator, _mm256_mul_ps(_mm256_add_ps(stiffness, alpha),
                                                              _mm256_max_ps(length, tiny))),
                       active);
}

// The hard step (α = λ = 0): scale = −C / ((w_a + w_b) |d|).
[[gnu::target(NUCLEON_LANE_TARGET)]] inline __m256 hardScale(__m256 length, __m256 rest, __m256 wa,
                                                             __m256 wb, bool unilateral) {
  const __m256 zero = _mm256_setzero_ps();
  return multiplierScale(length, rest, zero, zero, zero, wa, wb, zero, unilateral);
}

}  // namespace nucleon::NUCLEON_LANE_ISA::distance_lanes

namespace nucleon {
namespace distance_lanes = NUCLEON_LANE_ISA::distance_lanes;
}

#endif
