#include "systems/ground_contact.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "systems/contact_friction.h"

namespace nucleon {

void projectGround(ParticlePool& particles, const GroundPlane& ground) {
  const Real surface = ground.height + ground.thickness;
  const Vec3 up(0, 1, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        Vec3& p = particles.p[i];
                        const Real depth = surface - p.y();
                        if (depth <= 0 || particles.w[i] == 0) continue;
                        p.y() = surface;
                        applyContactFriction(p, particles.x[i], up, depth, ground.staticFriction,
                                             ground.friction);
                      }
                    });
}

std::size_t countGroundContacts(const ParticlePool& particles, const GroundPlane& ground,
                                Real tolerance) {
  const Real surface = ground.height + ground.thickness + tolerance;
  std::size_t count = 0;
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (particles.w[i] != 0 && particles.x[i].y() <= surface) ++count;
  return count;
}

}  // namespace nucleon
