#include "systems/ground_contact.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace nucleon {

void projectGround(ParticlePool& particles, const GroundPlane& ground) {
  const Real surface = ground.height + ground.thickness;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        Vec3& p = particles.p[i];
                        const Real depth = surface - p.y();
                        if (depth <= 0 || particles.w[i] == 0) continue;
                        p.y() = surface;
                        // Tangential motion of this substep so far.
                        Vec3 slide = p - particles.x[i];
                        slide.y() = 0;
                        const Real length = slide.norm();
                        if (length <= ground.staticFriction * depth) {
                          p.x() = particles.x[i].x();
                          p.z() = particles.x[i].z();
                        } else {
                          p -= slide * std::min(Real(1), ground.friction * depth / length);
                        }
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
