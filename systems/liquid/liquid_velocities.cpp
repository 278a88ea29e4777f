#include "systems/liquid/liquid_velocities.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "systems/liquid/sph_kernels.h"

namespace nucleon {
void applyLiquidVelocities(LiquidPool& pool, ParticlePool& particles, Real h) {
  bool viscosity = false, vorticity = false, tension = false;
  for (const LiquidObject& o : pool.objects) {
    viscosity = viscosity || o.settings.viscosity > 0;
    vorticity = vorticity || o.settings.vorticity > 0;
    tension = tension || o.settings.surfaceTension > 0;
  }
  if (!viscosity && !vorticity && !tension) return;
  const std::size_t n = pool.size();
  const LiquidKernels& k = pool.kernels;
  const int stride = pool.neighbourStride;
  const Vec3* x = pool.position.data();
  const Vec3* v = pool.velocity.data();

  // The slots' positions, velocities and densities at the end of the substep.
  forEachLiquidParticle(n, [&](std::size_t s) {
    const Index particle = pool.particle[pool.slotParticle[s]];
    pool.position[s] = particles.x[particle];
    pool.velocity[s] = particles.v[particle];
  });
  forEachLiquidParticle(n, [&](std::size_t s) {
    Real rho = pool.mass[s] * poly6(k, 0);
    const Index* list = pool.neighbours.data() + s * stride;
    for (int c = 0; c < pool.neighbourCount[s]; ++c)
      rho += pool.mass[list[c]] * poly6(k, (x[s] - x[list[c]]).squaredNorm());
    pool.density[s] = rho;
  });
  // Vorticity and surface normals, which the next pass reads at the neighbours.
  if (vorticity || tension)
    forEachLiquidParticle(n, [&](std::size_t s) {
      Vec3 omega = Vec3::Zero(), normal = Vec3::Zero();
      const Index* list = pool.neighbours.data() + s * stride;
      for (int c = 0; c < pool.neighbourCount[s]; ++c) {
        const Index t = list[c];
        const Vec3 d = pairOffset(k, x[s] - x[t], pool.slotParticle[s], pool.slotParticle[t]);
        const Vec3 g = (pool.mass[t] / pool.density[t]) * spikyGradient(k, d, d.squaredNorm());
        omega += g.cross(v[t] - v[s]);
        normal += g;
      }
      pool.vorticity[s] = omega;
      pool.normal[s] = k.radius * normal;
    });
  forEachLiquidParticle(n, [&](std::size_t s) {
    const Vec3 vs = v[s];
    if (pool.inverseMass[s] == 0) {
      pool.delta[s] = vs;
      return;
    }
    const LiquidObject& o = pool.objects[pool.slotObject[s]];
    const Liquid& settings = o.settings;
    const Real omega = vorticity ? pool.vorticity[s].norm() : 0;
    Vec3 xsph = Vec3::Zero(), eta = Vec3::Zero(), tensionAcceleration = Vec3::Zero();
    const Index* list = pool.neighbours.data() + s * stride;
    for (int c = 0; c < pool.neighbourCount[s]; ++c) {
      const Index t = list[c];
      const Vec3 d = pairOffset(k, x[s] - x[t], pool.slotParticle[s], pool.slotParticle[t]);
      const Real r2 = d.squaredNorm(), volume = pool.mass[t] / pool.density[t];
      if (settings.viscosity > 0) xsph += volume * poly6(k, r2) * (v[t] - vs);
      if (settings.vorticity > 0)
        eta += volume * (pool.vorticity[t].norm() - omega) * spikyGradient(k, d, r2);
      if (settings.surfaceTension > 0 && r2 < k.radius2) {
        const Real r = std::sqrt(r2);
        const Real K = 2 / (o.invRestDensity * (pool.density[s] + pool.density[t]));
        Vec3 pull = pool.normal[s] - pool.normal[t];
        if (r > Real(1e-12)) pull += pool.mass[t] * cohesionSpline(k, r) * (d / r);
        tensionAcceleration -= K * pull;
      }
    }
    Vec3 out = vs + settings.viscosity * xsph + h * settings.surfaceTension * tensionAcceleration;
    const Real etaNorm = eta.norm();
    if (settings.vorticity > 0 && etaNorm > Real(1e-12))
      out += h * settings.vorticity * (eta / etaNorm).cross(pool.vorticity[s]);
    pool.delta[s] = out;
  });
  forEachLiquidParticle(
      n, [&](std::size_t s) { particles.v[pool.particle[pool.slotParticle[s]]] = pool.delta[s]; });
}

}  // namespace nucleon
