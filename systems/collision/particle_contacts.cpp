#include "systems/collision/particle_contacts.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "systems/collision/collider_contact_lanes.h"

namespace nucleon {
namespace {

constexpr std::size_t kParticleGrain = 4096;
constexpr std::size_t kContactGrain = 512;
// The particles resolveMissedContacts tests in lanes at a time, their flags on the stack.
constexpr std::size_t kInsideChunk = 2048;

// Signed gap C = distance to the surface − thickness (negative: inside) and the outward normal.
struct SurfacePoint {
  Real gap;
  Vec3 normal;
};

inline SurfacePoint surfaceAt(const ColliderPool& colliders, std::size_t k, const Vec3& y) {
  switch (colliders.shape[k]) {
    case ColliderShape::Plane:
      return {colliders.normal[k].dot(y - colliders.point[k]) - colliders.thickness[k],
              colliders.normal[k]};
    case ColliderShape::Sphere: {
      const Vec3 offset = y - colliders.point[k];
      const Real distance = offset.norm();
      // At the centre the normal is undefined: any direction is a valid exit, and up is the one
      // a resting object expects.
      const Vec3 normal = distance > Real(1e-12) ? Vec3(offset / distance) : Vec3(0, 1, 0);
      return {distance - colliders.radius[k] - colliders.thickness[k], normal};
    }
  }
  return {1, Vec3(0, 1, 0)};
}

// Whether particle i, moving from x to x + h v, may reach collider k's contact surface in this
// substep: its motion plus kContactReach, from either end.
inline bool inReach(const ColliderPool& colliders, std::size_t k, const Vec3& x,
                    const Vec3& predicted, Real extraReach = 0) {
  const Real reach = (predicted - x).norm() + kContactReach + extraReach;
  return std::min(surfaceAt(colliders, k, x).gap, surfaceAt(colliders, k, predicted).gap) < reach;
}

// One contact: push out along the normal (C = gap ≥ 0, a unilateral constraint whose particle
// has the collider as an immovable partner, so Δλ = −C), then friction over the substep.
inline void projectContact(ContactPool& contacts, const ColliderPool& colliders,
                           ParticlePool& particles, std::size_t c) {
  const Index i = contacts.particle[c];
  const Index k = contacts.collider[c];
  Vec3& p = particles.p[i];
  const SurfacePoint s = surfaceAt(colliders, k, p);
  contacts.normal[c] = s.normal;
  contacts.depth[c] = -s.gap;
  if (s.gap < 0) {
    p -= s.gap * s.normal;
    contacts.lambda[c] -= s.gap;
  }
  const Real lambda = contacts.lambda[c];
  if (lambda <= 0) return;  // no normal impulse this substep, so no friction
  const Vec3 motion = p - particles.x[i];
  const Vec3 tangential = motion - s.normal * s.normal.dot(motion);
  // The tangential motion of the substep had friction not acted: what it has removed so far is
  // added back, so that the Coulomb bound applies to the whole substep once, however many
  // rounds project this contact.
  const Vec3 unopposed = tangential + contacts.friction[c];
  const Real length = unopposed.norm();
  Vec3 removed = unopposed;
  if (length > colliders.staticFriction[k] * lambda)
    removed *= std::min(Real(1), colliders.friction[k] * lambda / length);
  // Only the tangential part of the change is applied: on a curved collider F was taken about
  // earlier normals, and a step along the tangent plane never re-enters a convex surface.
  Vec3 change = removed - contacts.friction[c];
  change -= s.normal * s.normal.dot(change);
  p -= change;
  contacts.friction[c] += change;
}

// A particle's contacts, in pool order [first, last]. Friction moves a particle along one
// collider's tangent plane, which at a corner (a floor and a wall, two walls) can be into another
// collider: its static friction held a particle of water 0.16 mm inside the wall next to it for
// as long as it rested in the corner. So a particle with several contacts is pushed out of each
// again, along the normals only, after all of them have been projected.
inline void projectRun(ContactPool& contacts, const ColliderPool& colliders,
                       ParticlePool& particles, std::size_t first, std::size_t last) {
  for (std::size_t c = first; c <= last; ++c) projectContact(contacts, colliders, particles, c);
  if (last == first) return;
  Vec3& p = particles.p[contacts.particle[first]];
  for (std::size_t c = first; c <= last; ++c) {
    const SurfacePoint s = surfaceAt(colliders, contacts.collider[c], p);
    if (s.gap < 0) {
      p -= s.gap * s.normal;
      contacts.lambda[c] -= s.gap;
    }
  }
}

// Whether particle i gets a contact with collider k: its motion from x to `predicted`, or to
// `reached` where given, comes within reach (plus its extra reach, where the pool has one).
inline bool needsContact(const ContactPool& contacts, const ColliderPool& colliders,
                         const ParticlePool& particles, std::size_t i, std::size_t k,
                         const Vec3& predicted, const Vec3* reached) {
  const Real extra = contacts.extraReach.empty() ? Real(0) : contacts.extraReach[i];
  return inReach(colliders, k, particles.x[i], predicted, extra) ||
         (reached && inReach(colliders, k, particles.x[i], *reached, extra));
}

// Whether the lanes (collider_contact_lanes.h) can take this pool's colliders: they tell a plane
// from a sphere by the radius (0 for a plane), which the pool's colliders must then keep to, and
// mark the colliders a particle reaches in one word.
bool fitsLanes(const ColliderPool& colliders) {
  if (colliders.size() > kLaneColliders) return false;
  for (std::size_t k = 0; k < colliders.size(); ++k) {
    const bool plane = colliders.shape[k] == ColliderShape::Plane && colliders.radius[k] == 0;
    const bool sphere = colliders.shape[k] == ColliderShape::Sphere && colliders.radius[k] > 0;
    if (!plane && !sphere) return false;
  }
  return true;
}

// The runs that start in contacts [begin, end), each finished even past `end`. Stretches of
// particles with one contact each, most of a pool, go to the lanes where `lanes` allows
// (collider_contact_lanes.h): they share nothing, and each lane gives projectRun's bits.
void projectRunsStartingIn(ContactPool& contacts, const ColliderPool& colliders,
                           ParticlePool& particles, std::size_t begin, std::size_t end,
                           bool lanes) {
  const Index* particleOf = contacts.particle.data();
  const std::size_t count = contacts.size();
  std::size_t c = begin;
  while (c != end && c > 0 && particleOf[c - 1] == particleOf[c]) ++c;  // the task before's
  while (c < end) {
    // Single runs from c on: each contact's particle differs from the next one's.
    std::size_t single = c;
    while (lanes && single != end &&
           (single + 1 == count || particleOf[single + 1] != particleOf[single]))
      ++single;
    if (single > c) projectSingleContacts(contacts, colliders, particles, c, single);
    if (single == end) return;
    std::size_t last = single;
    while (last + 1 < count && particleOf[last + 1] == particleOf[single]) ++last;
    projectRun(contacts, colliders, particles, single, last);
    c = last + 1;
  }
}

}  // namespace

void detectContacts(ContactPool& contacts, const ColliderPool& colliders,
                    const ParticlePool& particles, Real h, std::span<const Vec3> reached) {
  auto touches = [&](std::size_t i, std::size_t k, const Vec3& predicted) {
    return needsContact(contacts, colliders, particles, i, k, predicted,
                        reached.empty() ? nullptr : &reached[i]);
  };
  const std::size_t n = particles.size();
  contacts.runStart.resize(n + 1);
  if (colliders.size() == 0) {
    std::fill(contacts.runStart.begin(), contacts.runStart.end(), Index(0));
    contacts.resize(0);
    return;
  }
  // In blocks of particles, two passes over each: its counts and their prefix sum within the block,
  // then (after the sum over the blocks) its runs. Integer sums: the same offsets for any
  // partitioning, and the pool in particle order.
  const bool lanes = fitsLanes(colliders);
  if (lanes) contacts.reachedColliders.resize(n);
  const Real* extraReach = contacts.extraReach.empty() ? nullptr : contacts.extraReach.data();
  const std::size_t blocks = (n + kParticleGrain - 1) / kParticleGrain;
  contacts.blockStart.resize(blocks + 1);
  Index* blockStart = contacts.blockStart.data();
  Index* runStart = contacts.runStart.data();
  const auto firstOf = [](std::size_t b) { return b * kParticleGrain; };
  const auto endOf = [n](std::size_t b) { return std::min(n, (b + 1) * kParticleGrain); };
  // Pass 1: contacts per particle. Same prediction as predictPositions, bit for bit. Planes and
  // spheres are counted in lanes, which give the scalar predicate's counts.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t b = r.begin(); b != r.end(); ++b) {
                        const std::size_t first = firstOf(b), end = endOf(b);
                        if (lanes) {
                          countCollidersInReach(colliders, particles, h, kContactReach, extraReach,
                                                reached.empty() ? nullptr : reached.data(), first,
                                                end, runStart, contacts.reachedColliders.data());
                        } else {
                          for (std::size_t i = first; i != end; ++i) {
                            Index count = 0;
                            if (particles.w[i] != 0) {
                              const Vec3 predicted = particles.x[i] + h * particles.v[i];
                              for (std::size_t k = 0; k < colliders.size(); ++k)
                                count += touches(i, k, predicted);
                            }
                            runStart[i] = count;
                          }
                        }
                        Index sum = 0;
                        for (std::size_t i = first; i != end; ++i) {
                          const Index count = runStart[i];
                          runStart[i] = sum;
                          sum += count;
                        }
                        blockStart[b + 1] = sum;
                      }
                    });
  blockStart[0] = 0;
  for (std::size_t b = 0; b < blocks; ++b) blockStart[b + 1] += blockStart[b];
  const Index total = blockStart[blocks];
  runStart[n] = total;
  contacts.resize(total);
  // Pass 2: the block's runs where the blocks before it end, then their contacts.
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, blocks), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t b = r.begin(); b != r.end(); ++b) {
          const std::size_t first = firstOf(b), end = endOf(b);
          for (std::size_t i = first; i != end; ++i) runStart[i] += blockStart[b];
          if (lanes) {
            // The runs from the colliders marked, then their surfaces in lanes.
            for (std::size_t i = first; i != end; ++i) {
              Index c = runStart[i];
              for (Index bits = contacts.reachedColliders[i]; bits != 0; bits &= bits - 1, ++c) {
                contacts.particle[c] = static_cast<Index>(i);
                contacts.collider[c] = static_cast<Index>(std::countr_zero(bits));
                contacts.lambda[c] = 0;
                contacts.friction[c] = Vec3::Zero();
              }
            }
            setPredictedSurfaces(contacts, colliders, particles, h, blockStart[b],
                                 blockStart[b + 1]);
            continue;
          }
          for (std::size_t i = first; i != end; ++i) {
            Index c = runStart[i];
            // The next block's first run starts where this block ends.
            if (c == (i + 1 == end ? blockStart[b + 1] : runStart[i + 1])) continue;
            const Vec3 predicted = particles.x[i] + h * particles.v[i];
            for (std::size_t k = 0; k < colliders.size(); ++k) {
              if (!touches(i, k, predicted)) continue;
              const SurfacePoint surface = surfaceAt(colliders, k, predicted);
              contacts.particle[c] = static_cast<Index>(i);
              contacts.collider[c] = static_cast<Index>(k);
              contacts.normal[c] = surface.normal;
              contacts.depth[c] = -surface.gap;
              contacts.lambda[c] = 0;
              contacts.friction[c] = Vec3::Zero();
              ++c;
            }
          }
        }
      });
}

void projectContacts(ContactPool& contacts, const ColliderPool& colliders, ParticlePool& particles,
                     SolverKind kind) {
  const std::size_t count = contacts.size();
  if (count == 0) return;
  if (kind == SolverKind::GaussSeidel) {
    for (std::size_t c = 0; c < count;) {
      std::size_t last = c;
      while (last + 1 < count && contacts.particle[last + 1] == contacts.particle[c]) ++last;
      projectRun(contacts, colliders, particles, c, last);
      c = last + 1;
    }
    return;
  }
  // A task owns the runs that start in its range (finishing a run past the range's end), so each
  // particle is written by one task and its contacts go in pool order.
  const bool lanes = fitsLanes(colliders);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, kContactGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      projectRunsStartingIn(contacts, colliders, particles, r.begin(), r.end(),
                                            lanes);
                    });
}

void projectContactsOf(ContactPool& contacts, const ColliderPool& colliders,
                       ParticlePool& particles, std::span<const Index> listed) {
  if (contacts.size() == 0) return;
  const auto project = [&](std::size_t k) {
    const Index i = listed[k];
    if (contacts.runStart[i] != contacts.runStart[i + 1])
      projectRun(contacts, colliders, particles, contacts.runStart[i],
                 contacts.runStart[i + 1] - 1);
  };
  if (listed.size() < kParticleGrain) {
    for (std::size_t k = 0; k < listed.size(); ++k) project(k);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, listed.size(), kParticleGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k != r.end(); ++k) project(k);
                    });
}

void copyContactsOf(const ContactPool& contacts, std::span<const Index> listed, ContactPool& copy,
                    std::vector<Index>& source) {
  std::size_t total = 0;
  for (const Index i : listed) total += contacts.runStart[i + 1] - contacts.runStart[i];
  copy.resize(total);
  source.resize(total);
  std::size_t c = 0;
  for (const Index i : listed)
    for (Index k = contacts.runStart[i]; k != contacts.runStart[i + 1]; ++k, ++c) {
      source[c] = k;
      copy.particle[c] = contacts.particle[k];
      copy.collider[c] = contacts.collider[k];
      copy.normal[c] = contacts.normal[k];
      copy.depth[c] = contacts.depth[k];
      copy.lambda[c] = contacts.lambda[k];
      copy.friction[c] = contacts.friction[k];
    }
}

void projectCopiedContacts(ContactPool& copy, const ColliderPool& colliders,
                           ParticlePool& particles) {
  if (copy.size() == 0) return;
  const bool lanes = fitsLanes(colliders);
  if (copy.size() < kParticleGrain) {
    projectRunsStartingIn(copy, colliders, particles, 0, copy.size(), lanes);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, copy.size(), kContactGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      projectRunsStartingIn(copy, colliders, particles, r.begin(), r.end(), lanes);
                    });
}

void returnCopiedContacts(const ContactPool& copy, std::span<const Index> source,
                          ContactPool& contacts) {
  for (std::size_t c = 0; c < copy.size(); ++c) {
    const Index k = source[c];
    contacts.normal[k] = copy.normal[c];
    contacts.depth[k] = copy.depth[c];
    contacts.lambda[k] = copy.lambda[c];
    contacts.friction[k] = copy.friction[c];
  }
}

bool contactsMissing(const ContactPool& contacts, const ColliderPool& colliders,
                     const ParticlePool& particles) {
  if (colliders.size() == 0) return false;
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, particles.size(), kParticleGrain), false,
      [&](const tbb::blocked_range<std::size_t>& r, bool missing) {
        for (std::size_t i = r.begin(); i != r.end() && !missing; ++i) {
          if (particles.w[i] == 0 || contacts.runStart[i] != contacts.runStart[i + 1]) continue;
          for (std::size_t k = 0; k < colliders.size() && !missing; ++k)
            missing = inReach(colliders, k, particles.x[i], particles.p[i]);
        }
        return missing;
      },
      [](bool a, bool b) { return a || b; });
}

std::size_t addReachedContacts(ContactPool& contacts, const ColliderPool& colliders,
                               const ParticlePool& particles, Real h) {
  const std::size_t n = particles.size();
  if (colliders.size() == 0 || contacts.runStart.size() != n + 1) return 0;
  contacts.reachedCount.resize(n);
  Index* count = contacts.reachedCount.data();
  // Pass 1: whether any particle is missing its contacts (contactsMissing's test), and how many
  // contacts each particle without one gets from the predicate of detectContacts with reached = p.
  struct Found {
    bool missing = false;
    std::size_t added = 0;
  };
  // Planes and spheres in lanes, which give the scalar predicate's counts and test.
  const bool lanes = fitsLanes(colliders);
  if (lanes) contacts.reachedColliders.resize(n);
  const Real* extraReach = contacts.extraReach.empty() ? nullptr : contacts.extraReach.data();
  const Found found = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kParticleGrain), Found{},
      [&](const tbb::blocked_range<std::size_t>& r, Found sum) {
        if (lanes) {
          sum.missing = countMissingContacts(colliders, particles, h, kContactReach, extraReach,
                                             contacts.runStart.data(), r.begin(), r.end(), count,
                                             contacts.reachedColliders.data()) ||
                        sum.missing;
          for (std::size_t i = r.begin(); i != r.end(); ++i) sum.added += count[i];
          return sum;
        }
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          count[i] = 0;
          if (particles.w[i] == 0 || contacts.runStart[i] != contacts.runStart[i + 1]) continue;
          const Vec3 predicted = particles.x[i] + h * particles.v[i];
          for (std::size_t k = 0; k < colliders.size(); ++k) {
            sum.missing = sum.missing || inReach(colliders, k, particles.x[i], particles.p[i]);
            count[i] +=
                needsContact(contacts, colliders, particles, i, k, predicted, &particles.p[i]);
          }
          sum.added += count[i];
        }
        return sum;
      },
      [](Found a, Found b) {
        return Found{a.missing || b.missing, a.added + b.added};
      });
  if (!found.missing || found.added == 0) return 0;
  // Pass 2, from the last particle back: each run moves up by the contacts added before its end
  // (never down, so moving back to front overwrites nothing still to be read), and the new runs
  // are written in the gaps, in collider order. Runs before the first new one stay where they are.
  const std::size_t oldTotal = contacts.size();
  contacts.resize(oldTotal + found.added);
  Index write = static_cast<Index>(oldTotal + found.added);
  Index oldEnd = contacts.runStart[n];
  contacts.runStart[n] = write;
  for (std::size_t i = n; i-- > 0 && write != oldEnd;) {
    const Index oldBegin = contacts.runStart[i];
    if (count[i] > 0) {
      const Vec3 predicted = particles.x[i] + h * particles.v[i];
      Index c = write - count[i];
      for (std::size_t k = 0; k < colliders.size(); ++k) {
        if (!needsContact(contacts, colliders, particles, i, k, predicted, &particles.p[i]))
          continue;
        const SurfacePoint surface = surfaceAt(colliders, k, predicted);
        contacts.particle[c] = static_cast<Index>(i);
        contacts.collider[c] = static_cast<Index>(k);
        contacts.normal[c] = surface.normal;
        contacts.depth[c] = -surface.gap;
        ++c;
      }
      write -= count[i];
    } else {
      for (Index c = oldEnd; c-- > oldBegin;) {
        --write;
        contacts.particle[write] = contacts.particle[c];
        contacts.collider[write] = contacts.collider[c];
        contacts.normal[write] = contacts.normal[c];
        contacts.depth[write] = contacts.depth[c];
      }
    }
    contacts.runStart[i] = write;
    oldEnd = oldBegin;
  }
  // Every contact starts the rest of the substep afresh, as from a detection: multipliers and
  // friction at zero.
  std::fill(contacts.lambda.begin(), contacts.lambda.end(), Real(0));
  std::fill(contacts.friction.begin(), contacts.friction.end(), Vec3::Zero());
  return found.added;
}

std::size_t resolveMissedContacts(const ContactPool& contacts, const ColliderPool& colliders,
                                  ParticlePool& particles) {
  if (colliders.size() == 0) return 0;
  const bool lanes = fitsLanes(colliders);
  const auto repair = [&](std::size_t i) {
    if (particles.w[i] == 0 || contacts.runStart[i] != contacts.runStart[i + 1]) return false;
    bool moved = false;
    for (std::size_t k = 0; k < colliders.size(); ++k) {
      const SurfacePoint s = surfaceAt(colliders, k, particles.p[i]);
      if (s.gap < 0) {
        particles.p[i] -= s.gap * s.normal;
        moved = true;
      }
    }
    return moved;
  };
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, particles.size(), kParticleGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t repaired) {
        if (!lanes) {
          for (std::size_t i = r.begin(); i != r.end(); ++i) repaired += repair(i);
          return repaired;
        }
        // Most particles are outside every collider: the lanes find the few that are not, and
        // only those go through the repair (which moves nothing until a gap is negative).
        std::array<std::uint8_t, kInsideChunk> inside;
        for (std::size_t begin = r.begin(); begin < r.end(); begin += kInsideChunk) {
          const std::size_t end = std::min(r.end(), begin + kInsideChunk);
          markInsideColliders(colliders, particles, begin, end, inside.data());
          // Particles with contacts sit on the surface, many a rounding inside it: the test of
          // repair() leaves them out, before its call.
          const Index* runStart = contacts.runStart.data();
          for (std::size_t i = begin; i != end; ++i)
            if (inside[i - begin] & (runStart[i] == runStart[i + 1])) repaired += repair(i);
        }
        return repaired;
      },
      std::plus<>());
}

std::size_t countTouchingParticles(const ColliderPool& colliders, const ParticlePool& particles,
                                   Real tolerance) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    if (particles.w[i] == 0) continue;
    for (std::size_t k = 0; k < colliders.size(); ++k)
      if (surfaceAt(colliders, k, particles.x[i]).gap <= tolerance) {
        ++count;
        break;
      }
  }
  return count;
}

Real colliderGap(const ColliderPool& colliders, const Vec3& y) {
  Real gap = std::numeric_limits<Real>::infinity();
  for (std::size_t k = 0; k < colliders.size(); ++k)
    gap = std::min(gap, surfaceAt(colliders, k, y).gap);
  return gap;
}

std::size_t countParticlesInsideColliders(const ColliderPool& colliders,
                                          const ParticlePool& particles, Real tolerance) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    if (particles.w[i] == 0) continue;
    for (std::size_t k = 0; k < colliders.size(); ++k)
      if (surfaceAt(colliders, k, particles.x[i]).gap < -colliders.thickness[k] - tolerance) {
        ++count;
        break;
      }
  }
  return count;
}

}  // namespace nucleon
