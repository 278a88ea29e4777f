#include "systems/solver/supported_particles.h"

namespace nucleon {

namespace {

// Reweighs the ends of every two-particle constraint on a supported particle (see the header): with
// both ends supported, or one pinned, as they were; else the supported end's inverse mass times
// `scale`, both then times (w_a + w_b) / (s_a w_a + s_b w_b), so their sum, which XPBD weighs the
// compliance against (Δλ = −(C + α̃λ) / (w_a + w_b + α̃)), stays what it was. With `restore`, every
// such end gets its inverse mass back.
void reweighEnds(ConstraintPools& constraints, std::span<const Index> supported,
                 const std::vector<std::uint8_t>& isSupported, const ParticlePool& particles,
                 Real scale, bool restore) {
  constraints.forEachBuiltin([&](auto& pool) {
    if constexpr (std::remove_reference_t<decltype(pool)>::kArity == 2) {
      if (pool.endInverseMass.empty() || pool.incidence.offset.empty()) return;
      for (Index i : supported)
        for (Index e = pool.incidence.offset[i]; e < pool.incidence.offset[i + 1]; ++e) {
          const Index c = pool.incidence.slot[e] / 2, end = pool.incidence.slot[e] % 2;
          const Index other = pool.particles[c][1 - end];
          const Real wSupported = particles.w[i], wOther = particles.w[other];
          std::array<Real, 2>& w = pool.endInverseMass[c];
          w[end] = wSupported;
          w[1 - end] = wOther;
          if (restore || isSupported[other] != 0 || wOther == 0) continue;
          const Real sum = wSupported + wOther, weighed = scale * wSupported + wOther;
          w[end] = scale * wSupported * sum / weighed;
          w[1 - end] = wOther * sum / weighed;
        }
    }
  });
}

}  // namespace

std::size_t weighSupportedParticles(ConstraintPools& constraints, ContactPool& contacts,
                                    const ColliderPool& colliders,
                                    const PrimitiveContactPool& primitiveContacts,
                                    const ParticlePool& particles, Real scale) {
  std::vector<Index>& supported = contacts.supportedParticles;
  supported.clear();
  if (scale == 1 || (contacts.size() == 0 && primitiveContacts.size() == 0)) return 0;
  std::vector<std::uint8_t>& isSupported = contacts.supportedMark;
  if (isSupported.size() != particles.size()) isSupported.assign(particles.size(), 0);
  const auto hold = [&](Index i) {
    if (particles.w[i] == 0 || isSupported[i] != 0) return;
    isSupported[i] = 1;
    supported.push_back(i);
  };
  for (std::size_t c = 0; c < contacts.size(); ++c)
    if (contacts.lambda[c] > 0 && colliders.friction[contacts.collider[c]] > 0)
      hold(contacts.particle[c]);
  for (std::size_t c = 0; c < primitiveContacts.size(); ++c) {
    if (!(primitiveContacts.lambda[c] > 0 && primitiveContacts.friction[c] > 0)) continue;
    const auto& ids = primitiveContacts.particles[c];
    const auto& coefficient = primitiveContacts.coefficient[c];
    bool againstKinematic = false;
    for (int k = 0; k < 4; ++k) againstKinematic |= coefficient[k] != 0 && particles.w[ids[k]] == 0;
    if (!againstKinematic) continue;
    for (int k = 0; k < 4; ++k)
      if (coefficient[k] != 0) hold(ids[k]);
  }
  reweighEnds(constraints, supported, isSupported, particles, scale, false);
  for (Index i : supported) isSupported[i] = 0;
  return supported.size();
}

void releaseSupportedParticles(ConstraintPools& constraints, ContactPool& contacts,
                               const ParticlePool& particles) {
  if (contacts.supportedParticles.empty()) return;
  reweighEnds(constraints, contacts.supportedParticles, contacts.supportedMark, particles, Real(1),
              true);
  contacts.supportedParticles.clear();
}

}  // namespace nucleon
