#include "systems/liquid/density_constraints.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "systems/liquid/neighbour_grid.h"
#include "systems/liquid/sph_kernels.h"

namespace nucleon {
namespace {

// Σ_j w_j |∇_j C_i|² over the neighbours of an interior particle of a cubic lattice at spacing
// d, mass m and rest density ρ0 (∇_i C_i vanishes there by symmetry): the scale of the
// constraint's denominator, which ε and the artificial pressure are given relative to.
double restDenominator(const LiquidKernels& k, double d, double m, double invRestDensity) {
  const int reach = static_cast<int>(std::ceil(k.radius / d));
  double sum = 0;
  for (int a = -reach; a <= reach; ++a)
    for (int b = -reach; b <= reach; ++b)
      for (int c = -reach; c <= reach; ++c) {
        const Vec3 offset = Vec3(Real(a), Real(b), Real(c)) * static_cast<Real>(d);
        const Vec3 g = spikyGradient(k, offset, offset.squaredNorm());
        sum += m * invRestDensity * invRestDensity * double(g.squaredNorm());
      }
  return sum;
}

// ρ_s = Σ m W over the slot's neighbours and itself, at the slots' positions.
Real densityAt(const LiquidPool& pool, std::size_t s) {
  const LiquidKernels& k = pool.kernels;
  const Vec3 xs = pool.position[s];
  Real rho = pool.mass[s] * poly6(k, 0);
  const Index* list = pool.neighbours.data() + s * pool.neighbourStride;
  for (int c = 0; c < pool.neighbourCount[s]; ++c)
    rho += pool.mass[list[c]] * poly6(k, (xs - pool.position[list[c]]).squaredNorm());
  return rho;
}

// (W(r)/W(Δq))^n of the artificial pressure.
Real tensileRatio(const LiquidKernels& k, const LiquidObject& o, Real r2) {
  const Real ratio = poly6(k, r2) * o.tensileReference;
  Real power = 1;
  for (int e = 0; e < o.settings.tensileExponent; ++e) power *= ratio;
  return power;
}

}  // namespace

Real liquidKernelRadius(const Liquid& liquid, Real mass, std::size_t count) {
  const double m = double(mass) / double(std::max<std::size_t>(count, 1));
  return static_cast<Real>(liquid.kernelScale * std::cbrt(m / liquid.restDensity));
}

void appendLiquidObject(LiquidPool& pool, std::uint32_t objectIndex, Index first, std::size_t count,
                        const Liquid& liquid, Real mass) {
  const Real radius = liquidKernelRadius(liquid, mass, count);
  if (pool.objects.empty()) pool.kernels = makeLiquidKernels(radius);
  pool.neighbourStride = std::max(pool.neighbourStride, neighbourStride(liquid.kernelScale));
  LiquidObject o;
  o.object = objectIndex;
  o.begin = static_cast<Index>(pool.particle.size());
  o.end = o.begin + static_cast<Index>(count);
  o.settings = liquid;
  o.particleMass = mass / Real(count);
  o.invRestDensity = 1 / liquid.restDensity;
  o.spacing = std::cbrt(o.particleMass * o.invRestDensity);
  const double denominator =
      restDenominator(pool.kernels, o.spacing, o.particleMass, o.invRestDensity);
  o.epsilon = static_cast<Real>(liquid.relaxation * denominator);
  o.tensileScale = static_cast<Real>(liquid.tensileStrength / denominator);
  o.tensileReference = 1 / poly6(pool.kernels, liquid.tensileDistance * liquid.tensileDistance *
                                                   pool.kernels.radius2);
  const std::uint32_t entry = static_cast<std::uint32_t>(pool.objects.size());
  pool.objects.push_back(o);
  for (std::size_t i = 0; i < count; ++i) {
    pool.particle.push_back(first + static_cast<Index>(i));
    pool.objectOf.push_back(entry);
  }
  const std::size_t n = pool.particle.size();
  pool.density.resize(n);
  pool.lambdaTotal.resize(n);
  pool.lambda.resize(n);
  pool.lambdaOverDensity.resize(n);
  pool.delta.resize(n);
  pool.vorticity.resize(n);
  pool.normal.resize(n);
}

void startLiquidSubstep(LiquidPool& pool, const ParticlePool& particles) {
  buildNeighbourLists(pool, particles.p, particles.w);
  std::fill(pool.lambdaTotal.begin(), pool.lambdaTotal.end(), Real(0));
}

void projectDensity(LiquidPool& pool, ParticlePool& particles, Real maxMove,
                    const std::uint8_t* objectRuns) {
  const std::size_t n = pool.size();
  const LiquidKernels& k = pool.kernels;
  const int stride = pool.neighbourStride;
  auto runs = [&](std::size_t s) {
    return !objectRuns || objectRuns[pool.objects[pool.slotObject[s]].object] != 0;
  };
  forEachLiquidParticle(n, [&](std::size_t s) {
    pool.position[s] = particles.p[pool.particle[pool.slotParticle[s]]];
  });
  // λ of every slot from the same positions.
  forEachLiquidParticle(n, [&](std::size_t s) {
    const LiquidObject& o = pool.objects[pool.slotObject[s]];
    const Vec3 ps = pool.position[s];
    Real rho = pool.mass[s] * poly6(k, 0), others = 0;
    Vec3 own = Vec3::Zero();
    const Index* list = pool.neighbours.data() + s * stride;
    for (int c = 0; c < pool.neighbourCount[s]; ++c) {
      const Index t = list[c];
      const Vec3 d =
          pairOffset(k, ps - pool.position[t], pool.slotParticle[s], pool.slotParticle[t]);
      const Real r2 = d.squaredNorm();
      rho += pool.mass[t] * poly6(k, r2);
      // ∇W = d × the scale, kept for the Δp pass with the artificial pressure's term.
      const Real scale = spikyGradientScale(k, r2);
      pool.gradientScale[s * stride + c] = scale;
      pool.tensileTerm[s * stride + c] =
          o.tensileScale > 0 ? -o.tensileScale * tensileRatio(k, o, r2) : Real(0);
      const Vec3 g = (pool.mass[t] * scale) * d;
      own += g;
      others += pool.inverseMass[t] * g.squaredNorm();
    }
    pool.density[s] = rho;
    const Real C = rho * o.invRestDensity - 1;
    if (C <= 0 || !runs(s)) {
      pool.lambda[s] = pool.lambdaOverDensity[s] = 0;
      return;
    }
    const Real gradients =
        o.invRestDensity * o.invRestDensity * (pool.inverseMass[s] * own.squaredNorm() + others);
    pool.lambda[s] = -C / (gradients + o.epsilon);
    pool.lambdaOverDensity[s] = pool.lambda[s] * o.invRestDensity;
    pool.lambdaTotal[pool.slotParticle[s]] += pool.lambda[s];
  });
  // Δp of every slot from every λ, counting the moves shortened to maxMove.
  const auto deltaOf = [&](std::size_t s) -> bool {
    const Real ws = pool.inverseMass[s];
    if (ws == 0 || !runs(s)) {
      pool.delta[s].setZero();
      return false;
    }
    const LiquidObject& o = pool.objects[pool.slotObject[s]];
    const Vec3 ps = pool.position[s];
    const Real ls = pool.lambda[s];
    Vec3 delta = Vec3::Zero();
    const Index* list = pool.neighbours.data() + s * stride;
    for (int c = 0; c < pool.neighbourCount[s]; ++c) {
      const Index t = list[c];
      const Vec3 d =
          pairOffset(k, ps - pool.position[t], pool.slotParticle[s], pool.slotParticle[t]);
      const Real scale = (ls + pool.tensileTerm[s * stride + c]) * pool.mass[t] * o.invRestDensity +
                         pool.lambdaOverDensity[t] * pool.mass[s];
      delta += (scale * pool.gradientScale[s * stride + c]) * d;
    }
    delta *= ws;
    // At most maxMove per projection, so that a substep's density projections together never
    // carry a particle beyond the collider contacts' reach (ContactPool::extraReach).
    const Real length2 = delta.squaredNorm();
    const bool limited = length2 > maxMove * maxMove;
    if (limited) delta *= maxMove / std::sqrt(length2);
    pool.delta[s] = delta;
    return limited;
  };
  pool.limitedMoves += tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n), std::uint64_t(0),
      [&](const auto& range, std::uint64_t limited) {
        for (std::size_t s = range.begin(); s < range.end(); ++s) limited += deltaOf(s);
        return limited;
      },
      std::plus<>());
  forEachLiquidParticle(
      n, [&](std::size_t s) { particles.p[pool.particle[pool.slotParticle[s]]] += pool.delta[s]; });
}

std::vector<Real> liquidDensities(const LiquidPool& pool, std::span<const Vec3> x) {
  LiquidPool scratch;
  scratch.kernels = pool.kernels;
  scratch.objects = pool.objects;
  scratch.particle = pool.particle;
  scratch.objectOf = pool.objectOf;
  scratch.neighbourStride = pool.neighbourStride;
  const std::vector<Real> unused(x.size(), Real(1));
  buildNeighbourLists(scratch, x, unused);
  std::vector<Real> out(pool.size());
  for (std::size_t s = 0; s < pool.size(); ++s)
    out[scratch.slotParticle[s]] = densityAt(scratch, s);
  return out;
}

}  // namespace nucleon
