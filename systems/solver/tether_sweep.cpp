#include "systems/solver/tether_sweep.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "systems/solver/distance_batch.h"
#include "systems/solver/tether_projection.h"

#include "systems/solver/distance_lanes.h"

namespace nucleon {
namespace {

constexpr Index kBatch = 8;
constexpr std::size_t kBlocksPerTask = 64;
constexpr Real kTiny = Real(1e-12);

// Rank r's tethers applied to its vertex, layers two at a time (scalar).
inline void projectVertex(const TetherConstraints& pool, Index rank, Vec3* p, const Real* w) {
  const auto& layers = pool.coloring.colorOffset;
  const Index vertex = pool.particles[layers[0] + rank][0];
  if (w[vertex] == 0) return;
  auto reaches = [&](std::size_t k) {
    return k + 1 < layers.size() && layers[k] + rank < layers[k + 1];
  };
  Vec3 x = p[vertex];
  for (std::size_t k = 0; reaches(k); k += 2) {
    const Index c = layers[k] + rank;
    if (reaches(k + 1)) {
      const Index e = layers[k + 1] + rank;
      x = projectOntoTetherPair(x, p[pool.particles[c][1]], pool.rest[c], p[pool.particles[e][1]],
                                pool.rest[e]);
    } else {
      x = projectOntoTether(x, p[pool.particles[c][1]], pool.rest[c]);
    }
  }
  p[vertex] = x;
}

#if NUCLEON_DISTANCE_LANES
// The (free, pin) pairs of eight tethers from c on → the eight free and the eight pin indices.
[[gnu::target("avx2,fma")]] inline void loadPairs(const TetherConstraints& pool, Index c,
                                                  __m256i& free, __m256i& pin) {
  const __m256i split = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
  const auto* pairs = reinterpret_cast<const __m256i*>(pool.particles.data() + c);
  const __m256i low = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(pairs), split);
  const __m256i high = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(pairs + 1), split);
  free = _mm256_permute2x128_si256(low, high, 0x20);
  pin = _mm256_permute2x128_si256(low, high, 0x31);
}

// Eight consecutive particles' positions (24 packed floats from `at`) as x, y, z vectors: three
// loads and a transpose instead of three gathers. The blends pick each coordinate's lanes from
// the three loads, the permutes put them in order.
[[gnu::target("avx2,fma")]] inline void loadEight(const float* at, __m256& x, __m256& y,
                                                  __m256& z) {
  const __m256 m0 = _mm256_loadu_ps(at), m1 = _mm256_loadu_ps(at + 8),
               m2 = _mm256_loadu_ps(at + 16);
  const __m256 ux = _mm256_blend_ps(_mm256_blend_ps(m0, m1, 0x92), m2, 0x24);
  const __m256 uy = _mm256_blend_ps(_mm256_blend_ps(m0, m1, 0x24), m2, 0x49);
  const __m256 uz = _mm256_blend_ps(_mm256_blend_ps(m0, m1, 0x49), m2, 0x92);
  x = _mm256_permutevar8x32_ps(ux, _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
  y = _mm256_permutevar8x32_ps(uy, _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6));
  z = _mm256_permutevar8x32_ps(uz, _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
}

// The inverse of loadEight: x, y, z vectors back to 24 packed floats at `at`.
[[gnu::target("avx2,fma")]] inline void storeEight(float* at, __m256 x, __m256 y, __m256 z) {
  const __m256 ux = _mm256_permutevar8x32_ps(x, _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
  const __m256 uy = _mm256_permutevar8x32_ps(y, _mm256_setr_epi32(5, 0, 3, 6, 1, 4, 7, 2));
  const __m256 uz = _mm256_permutevar8x32_ps(z, _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
  _mm256_storeu_ps(at, _mm256_blend_ps(_mm256_blend_ps(ux, uy, 0x92), uz, 0x24));
  _mm256_storeu_ps(at + 8, _mm256_blend_ps(_mm256_blend_ps(ux, uy, 0x24), uz, 0x49));
  _mm256_storeu_ps(at + 16, _mm256_blend_ps(_mm256_blend_ps(ux, uy, 0x49), uz, 0x92));
}

// Eight pins' positions as x, y, z vectors.
struct Eight {
  __m256 x, y, z;
};

// The pins of eight tethers; neighbouring vertices mostly share their pin in a layer, and then
// one broadcast serves all.
[[gnu::target("avx2,fma")]] inline void loadPins(const TetherConstraints&, const Vec3* p,
                                                 const float* base, __m256i pin, Eight& out) {
  const __m256i firstPin = _mm256_set1_epi32(_mm256_cvtsi256_si32(pin));
  if (_mm256_movemask_epi8(_mm256_cmpeq_epi32(pin, firstPin)) == -1) {
    const Vec3& shared = p[_mm256_cvtsi256_si32(pin)];
    out = {_mm256_set1_ps(shared.x()), _mm256_set1_ps(shared.y()), _mm256_set1_ps(shared.z())};
    return;
  }
  const __m256i pin3 = _mm256_add_epi32(_mm256_slli_epi32(pin, 1), pin);
  out = {_mm256_i32gather_ps(base, pin3, 4), _mm256_i32gather_ps(base + 1, pin3, 4),
         _mm256_i32gather_ps(base + 2, pin3, 4)};
}

[[gnu::target("avx2,fma")]] inline __m256 norm(__m256 x, __m256 y, __m256 z) {
  return distance_lanes::length(x, y, z);
}

// projectOntoTether, eight at a time: q = x − d (|d| − r)/|d| where |d| > r, d = x − c.
[[gnu::target("avx2,fma")]] inline void projectOntoBall(__m256 x, __m256 y, __m256 z,
                                                        const Eight& c, __m256 r, __m256& qx,
                                                        __m256& qy, __m256& qz) {
  const __m256 dx = _mm256_sub_ps(x, c.x), dy = _mm256_sub_ps(y, c.y), dz = _mm256_sub_ps(z, c.z);
  // The shared kernel's hard, unilateral step with the pin fixed (w_a = 1, w_b = 0).
  const __m256 scale =
      distance_lanes::hardScale(norm(dx, dy, dz), r, _mm256_set1_ps(1), _mm256_setzero_ps(), true);
  qx = _mm256_fmadd_ps(scale, dx, x);
  qy = _mm256_fmadd_ps(scale, dy, y);
  qz = _mm256_fmadd_ps(scale, dz, z);
}

// Lanes where |q − c| ≤ r (1 + slack).
[[gnu::target("avx2,fma")]] inline __m256 insideBall(__m256 qx, __m256 qy, __m256 qz,
                                                     const Eight& c, __m256 r) {
  const __m256 length =
      norm(_mm256_sub_ps(qx, c.x), _mm256_sub_ps(qy, c.y), _mm256_sub_ps(qz, c.z));
  return _mm256_cmp_ps(length, _mm256_mul_ps(r, _mm256_set1_ps(1 + tether_detail::kInsideSlack)),
                       _CMP_LE_OQ);
}

// Lanes surely inside the ball (surelyInsideTether, tether_projection.h): |x − c|² below r² by a
// margin that rounding cannot cross, without a square root.
[[gnu::target("avx2,fma")]] inline __m256 surelyInsideBall(__m256 x, __m256 y, __m256 z,
                                                           const Eight& c, __m256 r) {
  const __m256 dx = _mm256_sub_ps(x, c.x), dy = _mm256_sub_ps(y, c.y), dz = _mm256_sub_ps(z, c.z);
  const __m256 squared = _mm256_fmadd_ps(dx, dx, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dz, dz)));
  const __m256 limit =
      _mm256_mul_ps(_mm256_mul_ps(r, r), _mm256_set1_ps(1 - 16 * tether_detail::kInsideSlack));
  return _mm256_cmp_ps(squared, limit, _CMP_LT_OQ);
}

// projectOntoTetherPair, eight at a time, branch-free: every candidate is computed and the
// lanes pick theirs.
[[gnu::target("avx2,fma")]] inline void projectOntoBallPair(__m256& x, __m256& y, __m256& z,
                                                            const Eight& a, __m256 ra,
                                                            const Eight& b, __m256 rb) {
  const __m256 tiny = _mm256_set1_ps(kTiny), zero = _mm256_setzero_ps();
  __m256 ax, ay, az, bx, by, bz;
  projectOntoBall(x, y, z, a, ra, ax, ay, az);
  projectOntoBall(x, y, z, b, rb, bx, by, bz);
  const __m256 takeA = insideBall(ax, ay, az, b, rb);
  const __m256 takeB = insideBall(bx, by, bz, a, ra);
  // The circle where the spheres meet: centre m = a + s u, radius √(ra² − s²).
  const __m256 ux0 = _mm256_sub_ps(b.x, a.x), uy0 = _mm256_sub_ps(b.y, a.y),
               uz0 = _mm256_sub_ps(b.z, a.z);
  const __m256 distance = norm(ux0, uy0, uz0);
  const __m256 apart = _mm256_cmp_ps(distance, tiny, _CMP_GE_OQ);
  const __m256 safe = _mm256_max_ps(distance, tiny);
  const __m256 ux = _mm256_div_ps(ux0, safe), uy = _mm256_div_ps(uy0, safe),
               uz = _mm256_div_ps(uz0, safe);
  const __m256 s = _mm256_div_ps(
      _mm256_fmadd_ps(distance, distance, _mm256_fmsub_ps(ra, ra, _mm256_mul_ps(rb, rb))),
      _mm256_add_ps(safe, safe));
  const __m256 radius =
      _mm256_sqrt_ps(_mm256_max_ps(_mm256_fnmadd_ps(s, s, _mm256_mul_ps(ra, ra)), zero));
  const __m256 mx = _mm256_fmadd_ps(s, ux, a.x), my = _mm256_fmadd_ps(s, uy, a.y),
               mz = _mm256_fmadd_ps(s, uz, a.z);
  const __m256 tx = _mm256_sub_ps(x, mx), ty = _mm256_sub_ps(y, my), tz = _mm256_sub_ps(z, mz);
  const __m256 along = _mm256_fmadd_ps(tx, ux, _mm256_fmadd_ps(ty, uy, _mm256_mul_ps(tz, uz)));
  const __m256 ox = _mm256_fnmadd_ps(along, ux, tx), oy = _mm256_fnmadd_ps(along, uy, ty),
               oz = _mm256_fnmadd_ps(along, uz, tz);
  const __m256 offset = norm(ox, oy, oz);
  const __m256 scale = _mm256_and_ps(_mm256_div_ps(radius, _mm256_max_ps(offset, tiny)),
                                     _mm256_cmp_ps(offset, tiny, _CMP_GT_OQ));
  __m256 cx = _mm256_fmadd_ps(scale, ox, mx), cy = _mm256_fmadd_ps(scale, oy, my),
         cz = _mm256_fmadd_ps(scale, oz, mz);
  cx = _mm256_blendv_ps(ax, cx, apart);
  cy = _mm256_blendv_ps(ay, cy, apart);
  cz = _mm256_blendv_ps(az, cz, apart);
  x = _mm256_blendv_ps(_mm256_blendv_ps(cx, bx, takeB), ax, takeA);
  y = _mm256_blendv_ps(_mm256_blendv_ps(cy, by, takeB), ay, takeA);
  z = _mm256_blendv_ps(_mm256_blendv_ps(cz, bz, takeB), az, takeA);
}

// Eight consecutive ranks [a, a + 8), every layer that reaches any of them reaching all eight.
[[gnu::target("avx2,fma")]] void projectEight(const TetherConstraints& pool, Index a, Vec3* p,
                                              std::size_t layerCount) {
  const float* base = reinterpret_cast<const float*>(p);
  const auto& layers = pool.coloring.colorOffset;
  __m256i vertex, pin;
  loadPairs(pool, layers[0] + a, vertex, pin);
  // Ranks of equal tether count are in vertex order, so the eight vertices are often
  // consecutive particles (a cloth's rows): then they load and store as 24 packed floats.
  const Index first = static_cast<Index>(_mm256_cvtsi256_si32(vertex));
  const bool consecutive = pool.particles[layers[0] + a + 7][0] == first + 7;
  __m256 x, y, z;
  if (consecutive) {
    loadEight(base + 3 * std::size_t(first), x, y, z);
  } else {
    const __m256i vertex3 = _mm256_add_epi32(_mm256_slli_epi32(vertex, 1), vertex);
    x = _mm256_i32gather_ps(base, vertex3, 4);
    y = _mm256_i32gather_ps(base + 1, vertex3, 4);
    z = _mm256_i32gather_ps(base + 2, vertex3, 4);
  }
  auto reaches = [&](std::size_t k) { return k < layerCount && layers[k] + a < layers[k + 1]; };
  for (std::size_t k = 0; reaches(k); k += 2) {
    Eight pinA, pinB;
    if (k > 0) loadPairs(pool, layers[k] + a, vertex, pin);
    loadPins(pool, p, base, pin, pinA);
    const __m256 ra = _mm256_loadu_ps(pool.rest.data() + layers[k] + a);
    // Eight vertices surely inside their balls stay where they are: the projections' square
    // roots and divisions are skipped (most of a hanging cloth's tethers are slack).
    const __m256 insideA = surelyInsideBall(x, y, z, pinA, ra);
    if (!reaches(k + 1)) {
      if (_mm256_movemask_ps(insideA) != 0xFF) projectOntoBall(x, y, z, pinA, ra, x, y, z);
      continue;
    }
    loadPairs(pool, layers[k + 1] + a, vertex, pin);
    loadPins(pool, p, base, pin, pinB);
    const __m256 rb = _mm256_loadu_ps(pool.rest.data() + layers[k + 1] + a);
    if (_mm256_movemask_ps(_mm256_and_ps(insideA, surelyInsideBall(x, y, z, pinB, rb))) == 0xFF)
      continue;
    projectOntoBallPair(x, y, z, pinA, ra, pinB, rb);
  }
  if (consecutive) {
    storeEight(reinterpret_cast<float*>(p) + 3 * std::size_t(first), x, y, z);
    return;
  }
  alignas(32) float xs[8], ys[8], zs[8];
  alignas(32) int index[8];
  _mm256_store_ps(xs, x);
  _mm256_store_ps(ys, y);
  _mm256_store_ps(zs, z);
  loadPairs(pool, layers[0] + a, vertex, pin);
  _mm256_store_si256(reinterpret_cast<__m256i*>(index), vertex);
  for (int j = 0; j < 8; ++j) p[index[j]] = Vec3(xs[j], ys[j], zs[j]);
}
// Whether ranks [a, a + 8) can go eight at a time: every layer reaching rank a reaches a + 7, and
// every vertex is free (a pinned vertex has no tethers, but a kinematic change of mass could).
bool fullBatch(const TetherConstraints& pool, Index a, const Real* w) {
  const auto& layers = pool.coloring.colorOffset;
  for (std::size_t k = 0; k + 1 < layers.size(); ++k) {
    const Index size = layers[k + 1] - layers[k];
    if (size > a && size < a + kBatch) return false;
  }
  for (Index r = a; r < a + kBatch; ++r)
    if (w[pool.particles[layers[0] + r][0]] == 0) return false;
  return true;
}

#endif

}  // namespace

void layerTethers(TetherConstraints& pool) {
  const std::size_t n = pool.size();
  pool.coloring = ConstraintColoring{};
  if (n == 0) return;
  // Tethers of each vertex in pool order (the builder appends a vertex's nearest pin first).
  std::vector<Index> byVertex(n);
  std::iota(byVertex.begin(), byVertex.end(), Index(0));
  std::stable_sort(byVertex.begin(), byVertex.end(),
                   [&](Index a, Index b) { return pool.particles[a][0] < pool.particles[b][0]; });
  struct Run {
    Index start, count;
  };
  std::vector<Run> runs;
  for (Index i = 0; i < n;) {
    Index j = i;
    while (j < n && pool.particles[byVertex[j]][0] == pool.particles[byVertex[i]][0]) ++j;
    runs.push_back({i, j - i});
    i = j;
  }
  // Rank vertices by decreasing tether count (stable: then by vertex index).
  std::stable_sort(runs.begin(), runs.end(),
                   [](const Run& a, const Run& b) { return a.count > b.count; });
  std::vector<Index> order;
  order.reserve(n);
  pool.coloring.colorOffset.push_back(0);
  for (Index k = 0; k < runs.front().count; ++k) {
    for (const Run& run : runs) {
      if (run.count <= k) break;
      order.push_back(byVertex[run.start + k]);
    }
    pool.coloring.colorOffset.push_back(static_cast<Index>(order.size()));
  }
  pool.permute(order);
  pool.coloring.order.resize(n);
  std::iota(pool.coloring.order.begin(), pool.coloring.order.end(), Index(0));
  pool.coloring.inPlace = true;
}

void solveTethers(SolverKind kind, TetherConstraints& pool, const SweepContext& context) {
  if (pool.size() == 0) return;
  if (context.objectRuns || !context.optimizedPaths || pool.coloring.colorCount() == 0) {
    solveSweep<TetherKernel, kGenericSweep>(kind, pool, context);
    return;
  }
  Vec3* p = context.particles.p.data();
  const Real* w = context.particles.w.data();
  const Index ranks = pool.coloring.colorOffset[1];
  if (kind == SolverKind::GaussSeidel) {  // the sequential reference: one vertex at a time
    for (Index r = 0; r < ranks; ++r) projectVertex(pool, r, p, w);
    return;
  }
  bool batched = false;
#if NUCLEON_DISTANCE_LANES
  batched = distanceBatchesAvailable();
#endif
  const std::size_t layerCount = pool.coloring.colorCount();
  // Blocks of eight ranks from rank 0, whatever the thread count: which vertices go eight at a
  // time, and hence the rounding, never depends on the partitioning.
  const Index blocks = (ranks + kBatch - 1) / kBatch;
  tbb::parallel_for(
      tbb::blocked_range<Index>(0, blocks, kBlocksPerTask),
      [&](const tbb::blocked_range<Index>& range) {
        for (Index b = range.begin(); b != range.end(); ++b) {
          const Index a = b * kBatch;
#if NUCLEON_DISTANCE_LANES
          if (batched && a + kBatch <= ranks && fullBatch(pool, a, w)) {
            projectEight(pool, a, p, layerCount);
            continue;
          }
#endif
          for (Index r = a; r < std::min(ranks, a + kBatch); ++r) projectVertex(pool, r, p, w);
        }
      },
      tbb::static_partitioner());
  (void)batched;
  (void)layerCount;
}

}  // namespace nucleon
