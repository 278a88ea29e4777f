#include "systems/collision/contact_step_lanes.h"

#include <type_traits>

// Built like pair_distance_lanes.cpp (CMakeLists.txt): no errno or trap flags to keep, so the
// division and the selects stay vector instructions, and one build per instruction set picked at
// load time; element-wise IEEE operations with no contraction give the same bits in each.

namespace nucleon {

static_assert(sizeof(Vec3) == 3 * sizeof(Real), "positions and normals are read as packed triples");
static_assert(sizeof(std::array<Index, 4>) == 4 * sizeof(Index) &&
                  sizeof(std::array<Real, 4>) == 4 * sizeof(Real),
              "particles and coefficients are read as packed quadruples");

namespace {

// (x, y, z) += w p_i, one coordinate at a time.
[[gnu::always_inline]] inline void addWeighted(const Real* p, Index i, Real w, Real& x, Real& y,
                                               Real& z) {
  const Index at = 3 * i;  // particle counts stay far below 2³² / 3
  x = x + w * p[at];
  y = y + w * p[at + 1];
  z = z + w * p[at + 2];
}

}  // namespace

#if defined(__x86_64__)
[[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif
std::size_t
primitiveContactSteps(PrimitiveContactPool& pool, const ParticlePool& particles, std::size_t begin,
                      std::size_t end) {
  const Index* ids = pool.particles.data()->data();
  const Real* coefficient = pool.coefficient.data()->data();
  const Real* normal = pool.normal.data()->data();
  const Real* distance = pool.distance.data();
  const Real* stickiness = pool.stickiness.data();
  const Real* inverseMass = pool.inverseMass.data();
  const Real* p = particles.p.data()->data();
  Real* step = pool.step.data();
  Real* lambda = pool.lambda.data();
  std::size_t pressed = 0;
#pragma omp simd reduction(+ : pressed)
  for (std::size_t c = begin; c < end; ++c) {
    // Σ c_k p_k from zero in slot order, then n · sum in the order of Eigen's dot of three
    // (the library's build: n_x s_x + (n_y s_y + n_z s_z) for float, (n_x s_x + n_y s_y) +
    // n_z s_z for double; tests/test_contact_step_lanes.cpp holds the two to the same bits).
    Real x = 0, y = 0, z = 0;
    addWeighted(p, ids[4 * c], coefficient[4 * c], x, y, z);
    addWeighted(p, ids[4 * c + 1], coefficient[4 * c + 1], x, y, z);
    addWeighted(p, ids[4 * c + 2], coefficient[4 * c + 2], x, y, z);
    addWeighted(p, ids[4 * c + 3], coefficient[4 * c + 3], x, y, z);
    const Real nx = normal[3 * c] * x, ny = normal[3 * c + 1] * y, nz = normal[3 * c + 2] * z;
    const Real dot = std::is_same_v<Real, float> ? nx + (ny + nz) : (nx + ny) + nz;
    const Real C = dot - distance[c];
    const Real s = stickiness[c], m = inverseMass[c];
    // The scalar step's tests, without branches: C ≥ s, or C ≥ 0 with no stickiness, holds.
    const bool none = (C >= s) | ((C >= 0) & (s == 0)) | !(m > 0);
    const Real delta = none ? Real(0) : -C / m;
    step[c] = delta;
    lambda[c] = lambda[c] + delta * m;
    pressed += delta != 0;
  }
  return pressed;
}

}  // namespace nucleon
