#include "systems/solver/supported_particles.h"

namespace nucleon {

namespace {

// Reweighs the ends of every two-particle constraint between a supported particle and a free
// one that does not rise above the support's tangent plane (see the header): the supported end's
// inverse mass times `scale`, both then times (w_a + w_b) / (s_a w_a + s_b w_b), so their sum,
// which XPBD weighs the compliance against (Δλ = −(C + α̃λ) / (w_a + w_b + α̃)), stays what it was.
// Every other end keeps its inverse mass; with `restore`, every end on a supported particle gets it
// back.
void reweighEnds(ConstraintPools& constraints, const ContactPool& contacts,
                 const ParticlePool& particles, Real scale, bool restore) {
  const std::vector<Index>& supported = contacts.supportedParticles;
  const std::vector<Index>& slotOf = contacts.supportedSlot;
  constraints.forEachBuiltin([&](auto& pool) {
    if constexpr (std::remove_reference_t<decltype(pool)>::kArity == 2) {
      if (pool.endInverseMass.empty() || pool.incidence.offset.empty()) return;
      for (std::size_t s = 0; s < supported.size(); ++s) {
        const Index i = supported[s];
        const Vec3& normal = contacts.supportedNormal[s];
        for (Index e = pool.incidence.offset[i]; e < pool.incidence.offset[i + 1]; ++e) {
          const Index c = pool.incidence.slot[e] / 2, end = pool.incidence.slot[e] % 2;
          const Index other = pool.particles[c][1 - end];
          const Real wSupported = particles.w[i], wOther = particles.w[other];
          std::array<Real, 2>& w = pool.endInverseMass[c];
          w[end] = wSupported;
          w[1 - end] = wOther;
          if (restore || slotOf[other] != 0 || wOther == 0) continue;
          const Vec3 toOther = particles.p[other] - particles.p[i];
          if (!(normal.dot(toOther) <= kRisingCosine * toOther.norm())) continue;
          const Real sum = wSupported + wOther, weighed = scale * wSupported + wOther;
          w[end] = scale * wSupported * sum / weighed;
          w[1 - end] = wOther * sum / weighed;
        }
      }
    }
  });
}

}  // namespace

std::size_t weighSupportedParticles(ConstraintPools& constraints, ContactPool& contacts,
                                    const PrimitiveContactPool& primitiveContacts,
                                    const ParticlePool& particles, Real scale) {
  std::vector<Index>& supported = contacts.supportedParticles;
  std::vector<Vec3>& normals = contacts.supportedNormal;
  supported.clear();
  normals.clear();
  if (scale == 1 || primitiveContacts.size() == 0) return 0;
  std::vector<Index>& slotOf = contacts.supportedSlot;
  if (slotOf.size() != particles.size()) slotOf.assign(particles.size(), 0);
  // A particle's first pressed contact gives its support's normal.
  const auto support = [&](Index i, const Vec3& normal) {
    if (particles.w[i] == 0 || slotOf[i] != 0) return;
    supported.push_back(i);
    normals.push_back(normal);
    slotOf[i] = static_cast<Index>(supported.size());
  };
  for (std::size_t c = 0; c < primitiveContacts.size(); ++c) {
    if (!(primitiveContacts.lambda[c] > 0 && primitiveContacts.friction[c] > 0)) continue;
    const auto& ids = primitiveContacts.particles[c];
    const auto& coefficient = primitiveContacts.coefficient[c];
    bool againstKinematic = false;
    for (int k = 0; k < 4; ++k) againstKinematic |= coefficient[k] != 0 && particles.w[ids[k]] == 0;
    if (!againstKinematic) continue;
    // The contact keeps n · Σ c_k x_k at its distance: particle k is pushed out along c_k n.
    for (int k = 0; k < 4; ++k)
      if (coefficient[k] != 0)
        support(ids[k], coefficient[k] > 0 ? primitiveContacts.normal[c]
                                           : Vec3(-primitiveContacts.normal[c]));
  }
  reweighEnds(constraints, contacts, particles, scale, false);
  return supported.size();
}

void releaseSupportedParticles(ConstraintPools& constraints, ContactPool& contacts,
                               const ParticlePool& particles) {
  if (contacts.supportedParticles.empty()) return;
  reweighEnds(constraints, contacts, particles, Real(1), true);
  for (Index i : contacts.supportedParticles) contacts.supportedSlot[i] = 0;
  contacts.supportedParticles.clear();
  contacts.supportedNormal.clear();
}

}  // namespace nucleon
