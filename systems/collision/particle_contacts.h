// Contacts of particles with the collider list (ground, spheres): the per-substep contact pool.
//
//   detectContacts         start of the substep: every free particle whose motion x → x + h v
//                          comes within reach of a collider gets a contact (reads x, v, w,
//                          colliders; writes the contact pool)
//   projectContacts        after each sweep round: C = gap(p) ≥ 0 with gap = distance to the
//                          surface − thickness, pushed out along the normal, then Coulomb friction
//   resolveMissedContacts  end of the solve: a particle the sweeps moved into a collider although
//                          it had no contact is pushed out and counted as a repair
//
// Friction (position-based, Macklin et al. 2014 §6, taken over the whole substep): with λ_n the
// normal correction accumulated over the substep and d the particle's tangential motion over the
// substep had friction not acted, friction removes all of d if |d| ≤ μ_s λ_n (sticking) and
// μ_k λ_n of it otherwise (sliding). The displacement already removed is kept per contact, so
// projecting again after more sweeps re-evaluates the same law instead of adding to it: the
// result does not depend on the sweep count, and friction holds against sliding that the
// constraints drive, not only against the motion of a re-penetration.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "components/collider_pool.h"
#include "components/contact_pool.h"
#include "components/particles.h"
#include "nucleon/solver_settings.h"

namespace nucleon {

// Beyond its own motion over the substep, how close (m) to a collider's contact surface a
// particle must start or be predicted to end for a contact to be made: the room the sweeps have to
// move it towards the collider before the pool would miss it (resolveMissedContacts catches and
// counts what it misses).
constexpr Real kContactReach = Real(0.01);

// Refills `contacts` for the substep of length h (particles' predicted position x + h v).
// Deterministic: contacts come out in particle order whatever the thread count. With `reached`
// (where a solve has since moved the particles), a particle also gets a contact with a collider
// that its motion x → reached comes within reach of: the re-detection after the multigrid
// cascade, whose coarse corrections can carry a particle much farther than the sweeps do.
void detectContacts(ContactPool& contacts, const ColliderPool& colliders,
                    const ParticlePool& particles, Real h, std::span<const Vec3> reached = {});

// Whether a free particle that has no contact in the pool has come within reach of a collider at
// its current position p (then the pool needs a re-detection with reached = p).
bool contactsMissing(const ContactPool& contacts, const ColliderPool& colliders,
                     const ParticlePool& particles);

// The re-detection after the multigrid cascade, done in place: when contactsMissing would say so,
// every free particle without a contact gets the contacts detectContacts(…, reached = p) would
// give it, inserted into the pool in particle order, and every contact's multiplier and friction
// start again at zero. The pool then has a full re-detection's contacts except that a particle
// that had contacts keeps exactly those (the full one would add a second collider its motion to p
// reached, and drop a contact that only an earlier re-detection's reach had made), and kept
// contacts keep the normal and depth of their last projection (the projection that follows sets
// both anew). Returns the contacts added (0: the pool was left as it was).
std::size_t addReachedContacts(ContactPool& contacts, const ColliderPool& colliders,
                               const ParticlePool& particles, Real h);

// Projects every contact of the pool onto particles.p. Gauss–Seidel goes through the pool in
// order; the parallel backends project the runs of different particles in parallel (they share
// nothing) and each run in order, which gives the same result for any thread count.
void projectContacts(ContactPool& contacts, const ColliderPool& colliders, ParticlePool& particles,
                     SolverKind kind);

// The same for the contacts of the listed particles only (ascending, each once), in parallel over
// the list: the multigrid cascade's projection after a coarse level's sweeps.
void projectContactsOf(ContactPool& contacts, const ColliderPool& colliders,
                       ParticlePool& particles, std::span<const Index> listed);

// A level of the multigrid cascade projects the contacts of the same few particles between each
// of its sweeps: they are copied into a compact pool once (`copy`, and where each came from,
// `source`), projected there as projectContactsOf projects them (each particle's run in order,
// single contacts in lanes: the same bits), and written back (normals, depths, multipliers,
// friction) before anything else reads the pool.
void copyContactsOf(const ContactPool& contacts, std::span<const Index> listed, ContactPool& copy,
                    std::vector<Index>& source);
void projectCopiedContacts(ContactPool& copy, const ColliderPool& colliders,
                           ParticlePool& particles);
void returnCopiedContacts(const ContactPool& copy, std::span<const Index> source,
                          ContactPool& contacts);

// Pushes out of the colliders every free particle that ended a solve inside one without having a
// contact in the pool; returns how many were repaired.
std::size_t resolveMissedContacts(const ContactPool& contacts, const ColliderPool& colliders,
                                  ParticlePool& particles);

// Free particles within `tolerance` of some collider's contact surface at x: the contacts the
// stats report.
std::size_t countTouchingParticles(const ColliderPool& colliders, const ParticlePool& particles,
                                   Real tolerance);

// The smallest signed gap of point y over the colliders: its distance to a collider's surface
// less that collider's thickness (negative inside the contact layer); +∞ when there are none.
Real colliderGap(const ColliderPool& colliders, const Vec3& y);

// Free particles at x behind some collider's surface itself (deeper than its thickness, by more
// than `tolerance`): the contacts failed them. A run's stats count the frames that end with any.
std::size_t countParticlesInsideColliders(const ColliderPool& colliders,
                                          const ParticlePool& particles, Real tolerance);

}  // namespace nucleon
