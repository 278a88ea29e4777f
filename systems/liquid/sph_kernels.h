// SPH kernels of the liquids (Müller et al. 2003; Akinci et al. 2013), for one kernel radius H.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "components/liquid_pool.h"

namespace nucleon {

// body(s) for every slot s < n, in parallel: the liquid passes each write their own slot.
template <typename F>
void forEachLiquidParticle(std::size_t n, F&& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n), [&](const auto& range) {
    for (std::size_t i = range.begin(); i < range.end(); ++i) body(i);
  });
}

inline LiquidKernels makeLiquidKernels(Real radius) {
  const double H = radius, pi = std::numbers::pi;
  LiquidKernels k;
  k.radius = radius;
  k.radius2 = radius * radius;
  k.poly6 = static_cast<Real>(315.0 / (64.0 * pi * std::pow(H, 9)));
  k.spiky = static_cast<Real>(45.0 / (pi * std::pow(H, 6)));
  k.cohesion = static_cast<Real>(32.0 / (pi * std::pow(H, 9)));
  return k;
}

// Poly6, W(r) = 315/(64π H⁹) (H² − r²)³ for r < H, of the squared distance.
inline Real poly6(const LiquidKernels& k, Real r2) {
  if (r2 >= k.radius2) return 0;
  const Real d = k.radius2 - r2;
  return k.poly6 * d * d * d;
}

// The spiky kernel's gradient over d = x_i − x_j: ∇W = d × this, −45/(π H⁶) (H − r)²/r.
inline Real spikyGradientScale(const LiquidKernels& k, Real r2) {
  if (r2 >= k.radius2 || r2 <= Real(1e-24)) return 0;
  const Real r = std::sqrt(r2), s = k.radius - r;
  return -k.spiky * s * s / r;
}

// The spiky kernel's gradient at d = x_i − x_j, ∇W = −45/(π H⁶) (H − r)² d/r: it points from i
// towards j, and does not vanish as r → 0, so close particles still push apart.
inline Vec3 spikyGradient(const LiquidKernels& k, const Vec3& d, Real r2) {
  if (r2 >= k.radius2 || r2 <= Real(1e-24)) return Vec3::Zero();
  const Real r = std::sqrt(r2), s = k.radius - r;
  return d * (-k.spiky * s * s / r);
}

// The offset x_i − x_j of two liquid particles (liquid list indices i, j) for the kernels'
// gradients. Two particles pressed into the same point (a corner of two walls and the floor holds
// each at the same three coordinates) have no direction between them, and their gradients would
// vanish: nothing would separate them, and a pile of them makes a constraint with a large error and
// a vanishing denominator, whose multiplier throws its neighbours metres. Below 10⁻⁴ H they get a
// fixed direction of their own, opposite for the two (j − i hashed), at that distance.
inline Vec3 pairOffset(const LiquidKernels& k, const Vec3& d, Index i, Index j) {
  const Real least = Real(1e-4) * k.radius;
  if (d.squaredNorm() >= least * least) return d;
  const Index a = i < j ? i : j, b = i < j ? j : i;
  std::uint32_t hash = a * 2654435761u ^ b * 2246822519u;
  Vec3 direction;
  for (int axis = 0; axis < 3; ++axis) {
    hash ^= hash >> 15;
    hash *= 2246822519u;
    hash ^= hash >> 13;
    direction[axis] = Real(hash & 0xffff) / Real(0xffff) - Real(0.5);
  }
  direction.normalize();
  return (i < j ? least : -least) * direction;
}

// Akinci et al. 2013's cohesion spline C(r): attracting for r > H/2, repelling below.
inline Real cohesionSpline(const LiquidKernels& k, Real r) {
  if (r >= k.radius || r <= 0) return 0;
  const Real H = k.radius, a = (H - r) * (H - r) * (H - r) * r * r * r;
  if (2 * r > H) return k.cohesion * a;
  const Real H3 = H * H * H;
  return k.cohesion * (2 * a - H3 * H3 / 64);
}

}  // namespace nucleon
