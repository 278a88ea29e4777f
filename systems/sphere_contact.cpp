#include "systems/sphere_contact.h"

#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "systems/contact_friction.h"

namespace nucleon {

void projectSpheres(ParticlePool& particles, std::span<const SphereCollider> spheres) {
  if (spheres.empty()) return;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        if (particles.w[i] == 0) continue;
                        Vec3& p = particles.p[i];
                        for (const SphereCollider& sphere : spheres) {
                          const Real surface = sphere.radius + sphere.thickness;
                          const Vec3 offset = p - sphere.center;
                          const Real distanceSquared = offset.squaredNorm();
                          if (distanceSquared >= surface * surface) continue;
                          const Real distance = std::sqrt(distanceSquared);
                          // At the centre the normal is undefined: push out along +y (any direction
                          // is a valid exit; up is the one a resting object expects).
                          const Vec3 normal =
                              distance > Real(1e-12) ? Vec3(offset / distance) : Vec3(0, 1, 0);
                          const Real depth = surface - distance;
                          p = sphere.center + normal * surface;
                          applyContactFriction(p, particles.x[i], normal, depth,
                                               sphere.staticFriction, sphere.friction);
                        }
                      }
                    });
}

std::size_t countSphereContacts(const ParticlePool& particles,
                                std::span<const SphereCollider> spheres, Real tolerance) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    if (particles.w[i] == 0) continue;
    for (const SphereCollider& sphere : spheres)
      if ((particles.x[i] - sphere.center).norm() <= sphere.radius + sphere.thickness + tolerance) {
        ++count;
        break;
      }
  }
  return count;
}

}  // namespace nucleon
