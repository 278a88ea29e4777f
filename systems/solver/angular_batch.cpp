#include "systems/solver/angular_batch.h"

#include <type_traits>

#include "systems/solver/distance_batch.h"
#include "systems/solver/distance_lanes.h"
#include "systems/solver/lane_kernels.h"
#include "systems/solver/point_lanes.h"

// Compiled once per instruction set, like distance_batch.cpp (nucleon/lanes.h).
namespace nucleon::NUCLEON_LANE_ISA {

#if NUCLEON_DISTANCE_LANES

static_assert(std::is_same_v<Real, float>, "the batched angular path is float-only");

namespace {

#define NUCLEON_LANES [[gnu::target(NUCLEON_LANE_TARGET), gnu::always_inline]] inline

using Lane3 = point_lanes::Lanes3;

NUCLEON_LANES Lane3 sub(const Lane3& a, const Lane3& b) {
  return {_mm256_sub_ps(a.x, b.x), _mm256_sub_ps(a.y, b.y), _mm256_sub_ps(a.z, b.z)};
}

NUCLEON_LANES Lane3 cross(const Lane3& a, const Lane3& b) {
  return {_mm256_fmsub_ps(a.y, b.z, _mm256_mul_ps(a.z, b.y)),
          _mm256_fmsub_ps(a.z, b.x, _mm256_mul_ps(a.x, b.z)),
          _mm256_fmsub_ps(a.x, b.y, _mm256_mul_ps(a.y, b.x))};
}

NUCLEON_LANES __m256 dot(const Lane3& a, const Lane3& b) {
  return _mm256_fmadd_ps(a.x, b.x, _mm256_fmadd_ps(a.y, b.y, _mm256_mul_ps(a.z, b.z)));
}

NUCLEON_LANES Lane3 scale(const Lane3& a, __m256 s) {
  return {_mm256_mul_ps(a.x, s), _mm256_mul_ps(a.y, s), _mm256_mul_ps(a.z, s)};
}

// atan2(y, x) per lane, in (−π, π]: the ratio of the smaller to the larger magnitude, t ∈ [0, 1],
// reduced once more about π/4 (t > tan π/8: atan t = π/4 + atan((t − 1)/(t + 1))) to
// |t| ≤ tan π/8, where Cephes' atanf polynomial t + t z P(z), z = t², is accurate to float
// rounding; then unfolded to the octant of (x, y).
NUCLEON_LANES __m256 atan2Lanes(__m256 y, __m256 x) {
  const __m256 signBit = _mm256_set1_ps(-0.0f), zero = _mm256_setzero_ps();
  const __m256 ax = _mm256_andnot_ps(signBit, x), ay = _mm256_andnot_ps(signBit, y);
  const __m256 larger = _mm256_max_ps(ax, ay), smaller = _mm256_min_ps(ax, ay);
  __m256 t = _mm256_div_ps(smaller, _mm256_max_ps(larger, _mm256_set1_ps(1e-30f)));
  const __m256 past = _mm256_cmp_ps(t, _mm256_set1_ps(0.41421356237f), _CMP_GT_OQ);
  const __m256 one = _mm256_set1_ps(1.0f);
  t = _mm256_blendv_ps(t, _mm256_div_ps(_mm256_sub_ps(t, one), _mm256_add_ps(t, one)), past);
  const __m256 z = _mm256_mul_ps(t, t);
  __m256 p = _mm256_set1_ps(8.05374449538e-2f);
  p = _mm256_fmadd_ps(p, z, _mm256_set1_ps(-1.38776856032e-1f));
  p = _mm256_fmadd_ps(p, z, _mm256_set1_ps(1.99777106478e-1f));
  p = _mm256_fmadd_ps(p, z, _mm256_set1_ps(-3.33329491539e-1f));
  __m256 r = _mm256_fmadd_ps(_mm256_mul_ps(p, z), t, t);
  r = _mm256_add_ps(r, _mm256_and_ps(past, _mm256_set1_ps(0.78539816340f)));
  // Octant: |y| > |x| gives π/2 − r, x < 0 gives π − r, and the sign is y's.
  const __m256 halfPi = _mm256_set1_ps(1.57079632679f), pi = _mm256_set1_ps(3.14159265359f);
  r = _mm256_blendv_ps(r, _mm256_sub_ps(halfPi, r), _mm256_cmp_ps(ay, ax, _CMP_GT_OQ));
  r = _mm256_blendv_ps(r, _mm256_sub_ps(pi, r), _mm256_cmp_ps(x, zero, _CMP_LT_OQ));
  return _mm256_or_ps(r, _mm256_and_ps(y, signBit));
}

// A batch's angles and gradients: what a lane kernel gives the shared multiplier step.
template <int N>
struct AngleLanes {
  __m256 angle;
  Lane3 gradient[N];
  __m256 valid;  // lanes with a defined angle and gradient
};

// The dihedral hinge (DihedralKernel): φ and ∇φ of the header comment.
struct HingeLanes {
  static constexpr int kArity = 4;
  NUCLEON_LANES static AngleLanes<4> evaluate(const Lane3* x) {
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
    const __m256 tiny = _mm256_set1_ps(1e-12f);
    const Lane3 e = sub(x[1], x[0]), d2 = sub(x[2], x[0]), d3 = sub(x[3], x[0]);
    const Lane3 n1 = cross(e, d2), n2 = cross(d3, e);
    const __m256 a1 = dot(n1, n1), a2 = dot(n2, n2);
    const __m256 length = _mm256_sqrt_ps(dot(e, e));
    AngleLanes<4> out;
    out.valid = _mm256_and_ps(
        _mm256_cmp_ps(length, tiny, _CMP_GE_OQ),
        _mm256_and_ps(_mm256_cmp_ps(a1, tiny, _CMP_GE_OQ), _mm256_cmp_ps(a2, tiny, _CMP_GE_OQ)));
    // Degenerate lanes divide by 1 instead and are masked out by the step.
    const __m256 inverseLength = _mm256_div_ps(one, _mm256_blendv_ps(one, length, out.valid));
    const __m256 sine = _mm256_mul_ps(dot(cross(n1, n2), e), inverseLength);
    out.angle = atan2Lanes(sine, dot(n1, n2));
    out.gradient[2] =
        scale(n1, _mm256_sub_ps(zero, _mm256_div_ps(length, _mm256_blendv_ps(one, a1, out.valid))));
    out.gradient[3] =
        scale(n2, _mm256_sub_ps(zero, _mm256_div_ps(length, _mm256_blendv_ps(one, a2, out.valid))));
    const __m256 inverseLengthSquared = _mm256_mul_ps(inverseLength, inverseLength);
    const __m256 s2 = _mm256_mul_ps(dot(d2, e), inverseLengthSquared);
    const __m256 minusS3 = _mm256_sub_ps(zero, _mm256_mul_ps(dot(d3, e), inverseLengthSquared));
    const Lane3& g2 = out.gradient[2];
    const Lane3& g3 = out.gradient[3];
    // ∇_x1 = −s2 g2 − s3 g3, ∇_x0 = −g2 − g3 − ∇_x1 (the four sum to zero).
    out.gradient[1] = {_mm256_fnmadd_ps(s2, g2.x, _mm256_mul_ps(minusS3, g3.x)),
                       _mm256_fnmadd_ps(s2, g2.y, _mm256_mul_ps(minusS3, g3.y)),
                       _mm256_fnmadd_ps(s2, g2.z, _mm256_mul_ps(minusS3, g3.z))};
    const Lane3& g1 = out.gradient[1];
    out.gradient[0] = {_mm256_sub_ps(_mm256_sub_ps(zero, _mm256_add_ps(g2.x, g3.x)), g1.x),
                       _mm256_sub_ps(_mm256_sub_ps(zero, _mm256_add_ps(g2.y, g3.y)), g1.y),
                       _mm256_sub_ps(_mm256_sub_ps(zero, _mm256_add_ps(g2.z, g3.z)), g1.z)};
    return out;
  }
};

// The isometric hinge (IsometricBendKernel): v = Σ_k k_k x_k with the constraint's weights k,
// C = ‖v‖ in `angle`, ∇_x_k C = k_k v/‖v‖; a flat hinge (‖v‖² below 1e-24) has no gradient.
// No normals, no arctangent, one division.
struct IsometricBendLanes {
  static constexpr int kArity = 4;
  static constexpr bool kWeighted = true;
  NUCLEON_LANES static AngleLanes<4> evaluate(const Lane3* x, const __m256* k) {
    const __m256 one = _mm256_set1_ps(1.0f);
    Lane3 v = scale(x[0], k[0]);
    for (int c = 1; c < 4; ++c)
      v = {_mm256_fmadd_ps(x[c].x, k[c], v.x), _mm256_fmadd_ps(x[c].y, k[c], v.y),
           _mm256_fmadd_ps(x[c].z, k[c], v.z)};
    const __m256 squared = dot(v, v);
    AngleLanes<4> out;
    out.valid = _mm256_cmp_ps(squared, _mm256_set1_ps(1e-24f), _CMP_GE_OQ);
    out.angle = _mm256_sqrt_ps(squared);
    const Lane3 direction =
        scale(v, _mm256_div_ps(one, _mm256_blendv_ps(one, out.angle, out.valid)));
    for (int c = 0; c < 4; ++c) out.gradient[c] = scale(direction, k[c]);
    return out;
  }
};

// The angle at x2 (AngleKernel): θ = atan2(‖û × v̂‖, û · v̂), u = x0 − x2, v = x1 − x2,
//   ∇_x0 θ = −t_u/‖u‖, ∇_x1 θ = −t_v/‖v‖, ∇_x2 θ = −∇_x0 θ − ∇_x1 θ,
// t_u = (v̂ − cos θ û)/sin θ and t_v likewise. A point on the other two (‖u‖ or ‖v‖ below 1e-12)
// or a straight angle (sin θ < 1e-6, no plane) has no gradient.
struct AngleLanesKernel {
  static constexpr int kArity = 3;
  NUCLEON_LANES static AngleLanes<3> evaluate(const Lane3* x) {
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
    const __m256 tiny = _mm256_set1_ps(1e-12f);
    const Lane3 u = sub(x[0], x[2]), v = sub(x[1], x[2]);
    const __m256 lu = _mm256_sqrt_ps(dot(u, u)), lv = _mm256_sqrt_ps(dot(v, v));
    const __m256 lengths =
        _mm256_and_ps(_mm256_cmp_ps(lu, tiny, _CMP_GE_OQ), _mm256_cmp_ps(lv, tiny, _CMP_GE_OQ));
    const __m256 inverseU = _mm256_div_ps(one, _mm256_blendv_ps(one, lu, lengths));
    const __m256 inverseV = _mm256_div_ps(one, _mm256_blendv_ps(one, lv, lengths));
    const Lane3 uh = scale(u, inverseU), vh = scale(v, inverseV);
    const Lane3 normal = cross(uh, vh);
    const __m256 sine = _mm256_sqrt_ps(dot(normal, normal)), cosine = dot(uh, vh);
    AngleLanes<3> out;
    // Coincident points: θ = π, as the scalar kernel returns.
    out.angle = _mm256_blendv_ps(_mm256_set1_ps(3.14159265359f), atan2Lanes(sine, cosine), lengths);
    out.valid = _mm256_and_ps(lengths, _mm256_cmp_ps(sine, _mm256_set1_ps(1e-6f), _CMP_GE_OQ));
    const __m256 inverseSine = _mm256_div_ps(one, _mm256_blendv_ps(one, sine, out.valid));
    // ∇_x0 = −(v̂ − cos û)/(sin ‖u‖), ∇_x1 = −(û − cos v̂)/(sin ‖v‖).
    const __m256 factorU = _mm256_sub_ps(zero, _mm256_mul_ps(inverseSine, inverseU));
    const __m256 factorV = _mm256_sub_ps(zero, _mm256_mul_ps(inverseSine, inverseV));
    out.gradient[0] = {_mm256_mul_ps(factorU, _mm256_fnmadd_ps(cosine, uh.x, vh.x)),
                       _mm256_mul_ps(factorU, _mm256_fnmadd_ps(cosine, uh.y, vh.y)),
                       _mm256_mul_ps(factorU, _mm256_fnmadd_ps(cosine, uh.z, vh.z))};
    out.gradient[1] = {_mm256_mul_ps(factorV, _mm256_fnmadd_ps(cosine, vh.x, uh.x)),
                       _mm256_mul_ps(factorV, _mm256_fnmadd_ps(cosine, vh.y, uh.y)),
                       _mm256_mul_ps(factorV, _mm256_fnmadd_ps(cosine, vh.z, uh.z))};
    const Lane3& g0 = out.gradient[0];
    const Lane3& g1 = out.gradient[1];
    out.gradient[2] = {_mm256_sub_ps(zero, _mm256_add_ps(g0.x, g1.x)),
                       _mm256_sub_ps(zero, _mm256_add_ps(g0.y, g1.y)),
                       _mm256_sub_ps(zero, _mm256_add_ps(g0.z, g1.z))};
    return out;
  }
};

// The undamped XPBD step of an angle C = wrap(θ − θ0) with ∇θ from the lane kernel:
//   Δλ = (−C − α̃λ) / (Σ_k w_k ‖∇_k θ‖² + α̃), zero in lanes without a gradient or a free particle.
// The isometric hinges' C is not an angle and is not wrapped (kWrap false).
template <int N, bool kWrap = true>
NUCLEON_LANES __m256 multiplierStep(const AngleLanes<N>& a, const __m256* w, __m256 rest,
                                    __m256 stretchCompliance, __m256 compressionCompliance,
                                    __m256 lambda, __m256 inverseH2) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  __m256 constraint = _mm256_sub_ps(a.angle, rest);
  if constexpr (kWrap) {
    // C = θ − θ0 wrapped to (−π, π]: both lie in (−π, π], so one turn at most.
    const __m256 pi = _mm256_set1_ps(3.14159265359f), twoPi = _mm256_set1_ps(6.28318530718f);
    constraint =
        _mm256_sub_ps(constraint, _mm256_and_ps(_mm256_cmp_ps(constraint, pi, _CMP_GT_OQ), twoPi));
    constraint = _mm256_add_ps(
        constraint,
        _mm256_and_ps(_mm256_cmp_ps(constraint, _mm256_sub_ps(zero, pi), _CMP_LE_OQ), twoPi));
  }
  __m256 stiffness = zero;
  for (int k = 0; k < N; ++k)
    stiffness = _mm256_fmadd_ps(w[k], dot(a.gradient[k], a.gradient[k]), stiffness);
  // The side the multiplier ends on: C < s λ (kernel_detail::belowRest, constraint_kernels.h).
  const __m256 below = _mm256_cmp_ps(constraint, _mm256_mul_ps(stiffness, lambda), _CMP_LT_OQ);
  const __m256 alpha =
      _mm256_mul_ps(_mm256_blendv_ps(stretchCompliance, compressionCompliance, below), inverseH2);
  const __m256 active =
      _mm256_and_ps(a.valid, _mm256_cmp_ps(stiffness, _mm256_set1_ps(1e-12f), _CMP_GE_OQ));
  const __m256 numerator = _mm256_sub_ps(zero, _mm256_fmadd_ps(alpha, lambda, constraint));
  return _mm256_and_ps(
      _mm256_div_ps(numerator, _mm256_blendv_ps(one, _mm256_add_ps(stiffness, alpha), active)),
      active);
}

// The positions of the corners of constraints k … k+7, one Lane3 per corner (point_lanes.h:
// twelve gathers per hinge batch were most of its time).
template <std::size_t N>
NUCLEON_LANES void loadCorners(const Vec3* positions, const std::array<Index, N>* particles,
                               Index k, Lane3* x) {
  for (std::size_t c = 0; c < N; ++c)
    x[c] = point_lanes::loadCorner(positions, particles, k, static_cast<int>(c));
}

// One inverse mass per corner of constraints k … k+7, from a per-particle array (`particles`).
template <std::size_t N>
NUCLEON_LANES void loadMasses(const Real* inverseMass, const std::array<Index, N>* particles,
                              Index k, __m256* w) {
  for (std::size_t c = 0; c < N; ++c)
    w[c] = _mm256_setr_ps(inverseMass[particles[k][c]], inverseMass[particles[k + 1][c]],
                          inverseMass[particles[k + 2][c]], inverseMass[particles[k + 3][c]],
                          inverseMass[particles[k + 4][c]], inverseMass[particles[k + 5][c]],
                          inverseMass[particles[k + 6][c]], inverseMass[particles[k + 7][c]]);
}

// One lane per corner of constraints k … k+7 from a per-constraint column of N values (the
// pool's end inverse masses, the isometric hinges' weights).
template <std::size_t N>
NUCLEON_LANES void loadRows(const std::array<Real, N>* rows, Index k, __m256* w) {
  if constexpr (N == 4) {
    // Eight rows of four: two 4 × 4 transposes in one set of registers (3–5% of a colored-gs
    // bend sweep against eight scalar loads per corner).
    const float* at = rows[k].data();
    __m256 row[4];
    for (int j = 0; j < 4; ++j)
      row[j] = _mm256_set_m128(_mm_loadu_ps(at + 4 * (j + 4)), _mm_loadu_ps(at + 4 * j));
    const __m256 t0 = _mm256_unpacklo_ps(row[0], row[1]), t1 = _mm256_unpacklo_ps(row[2], row[3]);
    const __m256 t2 = _mm256_unpackhi_ps(row[0], row[1]), t3 = _mm256_unpackhi_ps(row[2], row[3]);
    w[0] = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(1, 0, 1, 0));
    w[1] = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(3, 2, 3, 2));
    w[2] = _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(1, 0, 1, 0));
    w[3] = _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(3, 2, 3, 2));
  } else {
    for (std::size_t c = 0; c < N; ++c)
      w[c] = _mm256_setr_ps(rows[k][c], rows[k + 1][c], rows[k + 2][c], rows[k + 3][c],
                            rows[k + 4][c], rows[k + 5][c], rows[k + 6][c], rows[k + 7][c]);
  }
}

// A lane kernel's C and gradients for constraints k … k+7, given their weights where it takes
// them (kWeighted).
template <class Lanes>
constexpr bool kWeightedLanes = requires {
  Lanes::kWeighted;
};

template <class Lanes, std::size_t N>
NUCLEON_LANES AngleLanes<Lanes::kArity> evaluateLanes(const BatchColumns<N>& b, Index k,
                                                      const Lane3* x) {
  if constexpr (kWeightedLanes<Lanes>) {
    __m256 weights[N];
    loadRows(b.weights, k, weights);
    return Lanes::evaluate(x, weights);
  } else {
    return Lanes::evaluate(x);
  }
}

template <class Lanes>
[[gnu::target(NUCLEON_LANE_TARGET)]] Index projectInPlace(const AngularBatch<Lanes::kArity>& b,
                                                          Index begin, Index end) {
  constexpr int n = Lanes::kArity;
  const __m256 inverseH2 = _mm256_set1_ps(b.inverseH2), zero = _mm256_setzero_ps();
  Index k = begin;
  for (; k + kAngularBatchSize <= end; k += kAngularBatchSize) {
    Lane3 x[n];
    loadCorners(b.positions, b.particles, k, x);
    __m256 w[n];
    loadRows(b.endInverseMass, k, w);
    const __m256 lambda = _mm256_loadu_ps(b.lambda + k);
    const AngleLanes<n> angle = evaluateLanes<Lanes>(b, k, x);
    const __m256 deltaLambda = multiplierStep<n, !kWeightedLanes<Lanes>>(
        angle, w, _mm256_loadu_ps(b.rest + k), _mm256_loadu_ps(b.compliance + k),
        _mm256_loadu_ps(b.compressionCompliance + k), lambda, inverseH2);
    _mm256_storeu_ps(b.lambda + k, _mm256_add_ps(lambda, deltaLambda));
    for (int c = 0; c < n; ++c) {
      const __m256 factor = _mm256_mul_ps(w[c], deltaLambda);
      const Lane3 moved = {_mm256_fmadd_ps(factor, angle.gradient[c].x, x[c].x),
                           _mm256_fmadd_ps(factor, angle.gradient[c].y, x[c].y),
                           _mm256_fmadd_ps(factor, angle.gradient[c].z, x[c].z)};
      __m128 row[8];
      point_lanes::transposeLanes(moved, row);
      // Pins (w = 0) are not written: constraints of one color may share them.
      const int free = _mm256_movemask_ps(_mm256_cmp_ps(w[c], zero, _CMP_NEQ_OQ));
      for (int j = 0; j < 8; ++j)
        if (free >> j & 1) point_lanes::storePoint(b.positions[b.particles[k + j][c]], row[j]);
    }
  }
  return k;
}

template <class Lanes>
[[gnu::target(NUCLEON_LANE_TARGET)]] Index projectJacobi(const AngularJacobiBatch<Lanes::kArity>& b,
                                                         Index begin, Index end) {
  constexpr int n = Lanes::kArity;
  const __m256 zero = _mm256_setzero_ps();
  const __m256 inverseH2 = _mm256_set1_ps(b.inverseH2);
  const __m256 relaxation = _mm256_set1_ps(b.relaxation), step = _mm256_set1_ps(b.step);
  const __m256 carry = _mm256_set1_ps(b.carry);
  const bool accelerated = b.carry != 0;
  Index k = begin;
  for (; k + kAngularBatchSize <= end; k += kAngularBatchSize) {
    Lane3 x[n];
    loadCorners(b.positions, b.particles, k, x);
    __m256 w[n];
    loadMasses(b.splitInverseMass, b.particles, k, w);
    const __m256 stretchCompliance = _mm256_loadu_ps(b.compliance + k);
    const __m256 compressionCompliance = _mm256_loadu_ps(b.compressionCompliance + k);
    const __m256 lambda = _mm256_loadu_ps(b.lambda + k);
    const AngleLanes<n> angle = evaluateLanes<Lanes>(b, k, x);
    const __m256 deltaLambda = multiplierStep<n, !kWeightedLanes<Lanes>>(
        angle, w, _mm256_loadu_ps(b.rest + k), stretchCompliance, compressionCompliance, lambda,
        inverseH2);
    // Hard constraints (both compliances 0) are accelerated on the accelerated sweeps.
    __m256 hard = _mm256_and_ps(_mm256_cmp_ps(stretchCompliance, zero, _CMP_EQ_OQ),
                                _mm256_cmp_ps(compressionCompliance, zero, _CMP_EQ_OQ));
    if (!accelerated) hard = zero;
    const __m256 factor = _mm256_blendv_ps(relaxation, step, hard);
    const __m256 scaled = _mm256_mul_ps(factor, deltaLambda);
    _mm256_storeu_ps(b.lambda + k, _mm256_add_ps(lambda, scaled));
    const __m256 keep = _mm256_and_ps(carry, hard);
    const bool carries = _mm256_movemask_ps(_mm256_cmp_ps(keep, zero, _CMP_NEQ_OQ)) != 0;
    Vec3* slot = b.correction + n * std::size_t{k};
    for (int c = 0; c < n; ++c) {
      const __m256 f = _mm256_mul_ps(w[c], scaled);
      Lane3 u = scale(angle.gradient[c], f);
      if (carries) {
        // Adaptive restart per slot, as in the scalar path (constraint_sweeps.h): history that
        // opposes the new move is dropped.
        __m128 point[8];
        for (int j = 0; j < 8; ++j) point[j] = point_lanes::loadSlot(slot[n * j + c]);
        const Lane3 old = point_lanes::transposeRows(point);
        const __m256 carried = _mm256_and_ps(keep, _mm256_cmp_ps(dot(u, old), zero, _CMP_GE_OQ));
        u = {_mm256_fmadd_ps(carried, old.x, u.x), _mm256_fmadd_ps(carried, old.y, u.y),
             _mm256_fmadd_ps(carried, old.z, u.z)};
      }
      __m128 row[8];
      point_lanes::transposeLanes(u, row);
      for (int j = 0; j < 8; ++j) point_lanes::storeSlot(slot[n * j + c], row[j]);
    }
  }
  return k;
}

// Jacobi by colors: constraints [begin, end) of one color (no two share a free particle) read
// the same positions as in projectJacobi and add their corrections to their particles' sums,
// b.sum[i] += u, instead of writing slots; the batches are the slot path's blocks of eight from
// constraint 0, their lanes outside [begin, end) computed and dropped, so each constraint gets
// the slot path's bits (λ included) and each particle's sum its terms in the gather's order when
// the colors are swept in order. The caller keeps `end` within the pool's whole blocks, and uses
// it only where no constraint carries a history (every one soft: carry never applies).
template <class Lanes>
[[gnu::target(NUCLEON_LANE_TARGET)]] Index accumulateJacobi(
    const AngularJacobiBatch<Lanes::kArity>& b, Index begin, Index end) {
  constexpr int n = Lanes::kArity;
  const __m256 zero = _mm256_setzero_ps();
  const __m256 inverseH2 = _mm256_set1_ps(b.inverseH2);
  const __m256 relaxation = _mm256_set1_ps(b.relaxation);
  const __m256i laneIndex = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (Index k = begin - begin % kAngularBatchSize; k < end; k += kAngularBatchSize) {
    // Lanes k + j in [begin, end): j ≥ begin − k and j < end − k.
    const __m256i first = _mm256_set1_epi32(static_cast<int>(begin) - static_cast<int>(k));
    const __m256i past = _mm256_set1_epi32(static_cast<int>(end) - static_cast<int>(k));
    const __m256i inRange = _mm256_andnot_si256(_mm256_cmpgt_epi32(first, laneIndex),
                                                _mm256_cmpgt_epi32(past, laneIndex));
    const int ownLanes = _mm256_movemask_ps(_mm256_castsi256_ps(inRange));
    Lane3 x[n];
    loadCorners(b.positions, b.particles, k, x);
    __m256 w[n];
    loadMasses(b.splitInverseMass, b.particles, k, w);
    const __m256 lambda = _mm256_loadu_ps(b.lambda + k);
    const AngleLanes<n> angle = evaluateLanes<Lanes>(b, k, x);
    const __m256 deltaLambda = multiplierStep<n, !kWeightedLanes<Lanes>>(
        angle, w, _mm256_loadu_ps(b.rest + k), _mm256_loadu_ps(b.compliance + k),
        _mm256_loadu_ps(b.compressionCompliance + k), lambda, inverseH2);
    const __m256 scaled = _mm256_mul_ps(relaxation, deltaLambda);
    _mm256_maskstore_ps(b.lambda + k, inRange, _mm256_add_ps(lambda, scaled));
    for (int c = 0; c < n; ++c) {
      const __m256 f = _mm256_mul_ps(w[c], scaled);
      const Lane3 u = scale(angle.gradient[c], f);
      __m128 row[8];
      point_lanes::transposeLanes(u, row);
      // Pins (w = 0) take no correction and may be shared within a color: not written.
      const int own = ownLanes & _mm256_movemask_ps(_mm256_cmp_ps(w[c], zero, _CMP_NEQ_OQ));
      for (int j = 0; j < 8; ++j) {
        if (!(own >> j & 1)) continue;
        Vec3& sum = b.sum[b.particles[k + j][c]];
        point_lanes::storePoint(sum, _mm_add_ps(point_lanes::loadPoint(sum), row[j]));
      }
    }
  }
  return end;
}

#undef NUCLEON_LANES

}  // namespace

Index projectHingeBatches(const InPlaceBatch<4>& batch, Index begin, Index end) {
  return projectInPlace<HingeLanes>(batch, begin, end);
}

Index projectHingeJacobiBatches(const JacobiBatch<4>& batch, Index begin, Index end) {
  return projectJacobi<HingeLanes>(batch, begin, end);
}

Index projectIsometricBendBatches(const InPlaceBatch<4>& batch, Index begin, Index end) {
  return projectInPlace<IsometricBendLanes>(batch, begin, end);
}

Index projectIsometricBendJacobiBatches(const JacobiBatch<4>& batch, Index begin, Index end) {
  return projectJacobi<IsometricBendLanes>(batch, begin, end);
}

Index projectAngleBatches(const InPlaceBatch<3>& batch, Index begin, Index end) {
  return projectInPlace<AngleLanesKernel>(batch, begin, end);
}

Index projectAngleJacobiBatches(const JacobiBatch<3>& batch, Index begin, Index end) {
  return projectJacobi<AngleLanesKernel>(batch, begin, end);
}

Index accumulateHingeJacobiBatches(const JacobiBatch<4>& batch, Index begin, Index end) {
  return accumulateJacobi<HingeLanes>(batch, begin, end);
}

Index accumulateIsometricBendJacobiBatches(const JacobiBatch<4>& batch, Index begin, Index end) {
  return accumulateJacobi<IsometricBendLanes>(batch, begin, end);
}

Index accumulateAngleJacobiBatches(const JacobiBatch<3>& batch, Index begin, Index end) {
  return accumulateJacobi<AngleLanesKernel>(batch, begin, end);
}

#endif

}  // namespace nucleon::NUCLEON_LANE_ISA

#if !defined(NUCLEON_LANES_AVX512)

namespace nucleon {

bool angularBatchesAvailable() {
  return distanceBatchesAvailable();  // the same instructions and the same float state
}

Index projectHingeBatches(const AngularBatch<4>& batch, Index begin, Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), projectHingeBatches, begin, batch, begin, end);
}

Index projectHingeJacobiBatches(const AngularJacobiBatch<4>& batch, Index begin, Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), projectHingeJacobiBatches, begin, batch, begin, end);
}

Index projectIsometricBendBatches(const AngularBatch<4>& batch, Index begin, Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), projectIsometricBendBatches, begin, batch, begin, end);
}

Index projectIsometricBendJacobiBatches(const AngularJacobiBatch<4>& batch, Index begin,
                                        Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), projectIsometricBendJacobiBatches, begin, batch, begin, end);
}

Index projectAngleBatches(const AngularBatch<3>& batch, Index begin, Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), projectAngleBatches, begin, batch, begin, end);
}

Index projectAngleJacobiBatches(const AngularJacobiBatch<3>& batch, Index begin, Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), projectAngleJacobiBatches, begin, batch, begin, end);
}

Index accumulateHingeJacobiBatches(const AngularJacobiBatch<4>& batch, Index begin, Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), accumulateHingeJacobiBatches, begin, batch, begin, end);
}

Index accumulateIsometricBendJacobiBatches(const AngularJacobiBatch<4>& batch, Index begin,
                                           Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), accumulateIsometricBendJacobiBatches, begin, batch, begin,
                            end);
}

Index accumulateAngleJacobiBatches(const AngularJacobiBatch<3>& batch, Index begin, Index end) {
  return NUCLEON_CALL_LANES(laneIsa(), accumulateAngleJacobiBatches, begin, batch, begin, end);
}

}  // namespace nucleon

#endif
