#include "systems/collision/collider_contact_lanes.h"

#include <type_traits>

// Built like contact_step_lanes.cpp (CMakeLists.txt): no errno or trap flags to keep, so square
// roots, divisions and selects stay vector instructions, and one build per instruction set picked
// at load time; element-wise IEEE operations with no contraction give the same bits in each.

namespace nucleon {

static_assert(sizeof(Vec3) == 3 * sizeof(Real), "positions and normals are read as packed triples");

namespace {

// a_x b_x + a_y b_y + a_z b_z in the order of Eigen's sum of three in the library's build:
// x + (y + z) for float, (x + y) + z for double (tests/test_contact_step_lanes.cpp).
[[gnu::always_inline]] inline Real sumOfThree(Real x, Real y, Real z) {
  return std::is_same_v<Real, float> ? x + (y + z) : (x + y) + z;
}

// One collider's constants, read once for a loop or a stretch of its contacts (rather than
// gathered lane by lane: most pools hold long stretches of one collider). A plane's radius is 0,
// a sphere's positive (ColliderPool).
struct Collider {
  const Real* point;
  const Real* normal;
  Real radius, thickness, kinetic, sticking;
};

inline Collider colliderOf(const ColliderPool& colliders, Index k) {
  return {colliders.point[k].data(), colliders.normal[k].data(), colliders.radius[k],
          colliders.thickness[k],    colliders.friction[k],      colliders.staticFriction[k]};
}

// The end of the stretch of contacts from `first` (< end) on that share first's collider.
inline std::size_t sameColliderEnd(const ContactPool& contacts, std::size_t first,
                                   std::size_t end) {
  const Index* colliderOf = contacts.collider.data();
  std::size_t last = first + 1;
  while (last < end && colliderOf[last] == colliderOf[first]) ++last;
  return last;
}

// surfaceAt of particle_contacts.cpp at y, operation for operation: the signed gap to the contact
// surface (the plane's n · (y − point) − thickness, or the sphere's |y − centre| − radius −
// thickness) and the outward normal (the plane's, or the direction from the centre, (0, 1, 0) at
// the centre itself). Where only the gap is used, the compiler drops the normal's divisions.
struct Surface {
  Real gap, nx, ny, nz;
};

template <bool Plane>
[[gnu::always_inline]] inline Surface surfaceOf(const Collider& collider, Real yx, Real yy,
                                                Real yz) {
  const Real ox = yx - collider.point[0], oy = yy - collider.point[1], oz = yz - collider.point[2];
  const Real* n = collider.normal;
  if constexpr (Plane)
    return {sumOfThree(n[0] * ox, n[1] * oy, n[2] * oz) - collider.thickness, n[0], n[1], n[2]};
  const Real distance = std::sqrt(sumOfThree(ox * ox, oy * oy, oz * oz));
  const bool away = distance > Real(1e-12);
  return {distance - collider.radius - collider.thickness, away ? ox / distance : Real(0),
          away ? oy / distance : Real(1), away ? oz / distance : Real(0)};
}

// inReach of particle_contacts.cpp for a motion from x to e whose start's gap is known, before its
// extra reach: the nearer end's gap, min(gap(x), gap(e)) with std::min's choice, and |e − x| +
// reach. The motion reaches the collider where gap < reach + extra.
struct Approach {
  Real gap, reach;
};

template <bool Plane>
[[gnu::always_inline]] inline Approach approachOf(const Collider& collider, Real contactReach,
                                                  const Real* x, Real startGap, Real ex, Real ey,
                                                  Real ez) {
  const Real mx = ex - x[0], my = ey - x[1], mz = ez - x[2];
  const Real reach = std::sqrt(sumOfThree(mx * mx, my * my, mz * mz)) + contactReach;
  const Real endGap = surfaceOf<Plane>(collider, ex, ey, ez).gap;
  return {endGap < startGap ? endGap : startGap, reach};
}

// What countCollidersInReach and countMissingContacts read and write, for their loops.
struct ReachLanes {
  const Real* x;
  const Real* v;
  const Real* w;
  const Real* to;          // the second ends, or null
  const Real* extraReach;  // or null
  // Where given (the particles' runs in the pool), only particles without a contact are counted,
  // and the missing test runs beside the count.
  const Index* runStart;
  Real h, contactReach;
  Index* count;
  Index* colliderBits;
};

// The loop for one collider, with or without a second end to reach, an extra reach per particle
// and the missing test (Missing: the particles without a contact only, and whether one's motion to
// the second end comes within reach without its extra reach): choices made outside the loop (a
// load under a mask cost more than the rest of the lane). These templates are inlined into each
// instruction set's build of their caller (a lambda there was compiled apart, for the baseline
// set).
template <bool Plane, bool Reached, bool Extra, bool Missing>
[[gnu::always_inline]] inline void addCollidersInReach(const Collider& collider,
                                                       const ReachLanes& lanes, Index bit,
                                                       std::size_t begin, std::size_t end,
                                                       int& missing) {
  static_assert(Reached || !Missing, "the missing test is about the second end");
  const Real *x = lanes.x, *v = lanes.v, *w = lanes.w, *to = lanes.to;
  const Real* extraReach = lanes.extraReach;
  const Index* runStart = lanes.runStart;
  const Real h = lanes.h, contactReach = lanes.contactReach;
  Index* count = lanes.count;
  Index* colliderBits = lanes.colliderBits;
  int anyMissing = 0;
#pragma omp simd reduction(| : anyMissing)
  for (std::size_t i = begin; i < end; ++i) {
    const Real* xi = x + 3 * i;
    const Real* vi = v + 3 * i;
    const Real extra = Extra ? extraReach[i] : Real(0);
    const Real startGap = surfaceOf<Plane>(collider, xi[0], xi[1], xi[2]).gap;
    const Approach predicted =
        approachOf<Plane>(collider, contactReach, xi, startGap, xi[0] + h * vi[0],
                          xi[1] + h * vi[1], xi[2] + h * vi[2]);
    bool touches = predicted.gap < predicted.reach + extra;
    bool eligible = w[i] != 0;
    if constexpr (Missing) eligible = eligible & (runStart[i] == runStart[i + 1]);
    if constexpr (Reached) {
      const Real* ti = to + 3 * i;
      const Approach reached =
          approachOf<Plane>(collider, contactReach, xi, startGap, ti[0], ti[1], ti[2]);
      touches = touches | (reached.gap < reached.reach + extra);
      if constexpr (Missing) anyMissing |= (eligible & (reached.gap < reached.reach)) ? 1 : 0;
    }
    const bool counted = eligible & touches;
    count[i] += counted ? Index(1) : Index(0);
    colliderBits[i] |= counted ? bit : Index(0);
  }
  missing |= anyMissing;
}

template <bool Plane, bool Reached, bool Missing>
[[gnu::always_inline]] inline void addCollidersInReach(const Collider& collider,
                                                       const ReachLanes& lanes, Index bit,
                                                       std::size_t begin, std::size_t end,
                                                       int& missing) {
  if (lanes.extraReach)
    addCollidersInReach<Plane, Reached, true, Missing>(collider, lanes, bit, begin, end, missing);
  else
    addCollidersInReach<Plane, Reached, false, Missing>(collider, lanes, bit, begin, end, missing);
}

template <bool Plane>
[[gnu::always_inline]] inline void addCollidersInReach(const Collider& collider,
                                                       const ReachLanes& lanes, Index bit,
                                                       std::size_t begin, std::size_t end,
                                                       int& missing) {
  if (!lanes.to)
    addCollidersInReach<Plane, false, false>(collider, lanes, bit, begin, end, missing);
  else if (lanes.runStart)
    addCollidersInReach<Plane, true, true>(collider, lanes, bit, begin, end, missing);
  else
    addCollidersInReach<Plane, true, false>(collider, lanes, bit, begin, end, missing);
}

// Both counts over particles [begin, end): every collider's loop, a bit each. Returns the missing
// test's answer (false where lanes.runStart is null).
[[gnu::always_inline]] inline bool countInReach(const ColliderPool& colliders,
                                                const ReachLanes& lanes, std::size_t begin,
                                                std::size_t end) {
  for (std::size_t i = begin; i < end; ++i) lanes.count[i] = lanes.colliderBits[i] = 0;
  int missing = 0;
  for (std::size_t k = 0; k < colliders.size(); ++k) {
    const Collider collider = colliderOf(colliders, static_cast<Index>(k));
    const Index bit = Index(1) << k;
    if (collider.radius == 0)
      addCollidersInReach<true>(collider, lanes, bit, begin, end, missing);
    else
      addCollidersInReach<false>(collider, lanes, bit, begin, end, missing);
  }
  return missing != 0;
}

// markInsideColliders' loop for one collider.
template <bool Plane>
[[gnu::always_inline]] inline void markInside(const Collider& collider, const Real* p,
                                              std::size_t begin, std::size_t end,
                                              std::uint8_t* inside) {
#pragma omp simd
  for (std::size_t i = begin; i < end; ++i) {
    const Real* y = p + 3 * i;
    inside[i - begin] |=
        surfaceOf<Plane>(collider, y[0], y[1], y[2]).gap < 0 ? std::uint8_t(1) : std::uint8_t(0);
  }
}

// setPredictedSurfaces over contacts [first, last), all on one collider.
template <bool Plane>
[[gnu::always_inline]] inline void setSurfacesOnOne(ContactPool& contacts, const Collider& collider,
                                                    const ParticlePool& particles, Real h,
                                                    std::size_t first, std::size_t last) {
  const Index* particleOf = contacts.particle.data();
  Real* contactNormal = contacts.normal.data()->data();
  Real* depth = contacts.depth.data();
  const Real* x = particles.x.data()->data();
  const Real* v = particles.v.data()->data();
#pragma omp simd
  for (std::size_t c = first; c < last; ++c) {
    const Index i = 3 * particleOf[c];  // far below 2³² / 3
    // The prediction as predictPositions makes it.
    const Surface s = surfaceOf<Plane>(collider, x[i] + h * v[i], x[i + 1] + h * v[i + 1],
                                       x[i + 2] + h * v[i + 2]);
    contactNormal[3 * c] = s.nx;
    contactNormal[3 * c + 1] = s.ny;
    contactNormal[3 * c + 2] = s.nz;
    depth[c] = -s.gap;
  }
}

// projectSingleContacts over contacts [first, last), all on one collider: the new positions go to
// the pool's `moved`.
template <bool Plane>
[[gnu::always_inline]] inline void projectOnOne(ContactPool& contacts, const Collider& collider,
                                                const ParticlePool& particles, std::size_t first,
                                                std::size_t last) {
  const Index* particleOf = contacts.particle.data();
  Real* contactNormal = contacts.normal.data()->data();
  Real* depth = contacts.depth.data();
  Real* lambda = contacts.lambda.data();
  Real* friction = contacts.friction.data()->data();
  const Real* p = particles.p.data()->data();
  Real* moved = contacts.moved.data()->data();
  const Real* x = particles.x.data()->data();
#pragma omp simd
  for (std::size_t c = first; c < last; ++c) {
    const Index i = 3 * particleOf[c];  // far below 2³² / 3
    Real px = p[i], py = p[i + 1], pz = p[i + 2];
    const Surface s = surfaceOf<Plane>(collider, px, py, pz);
    const Real gap = s.gap, nx = s.nx, ny = s.ny, nz = s.nz;
    contactNormal[3 * c] = nx;
    contactNormal[3 * c + 1] = ny;
    contactNormal[3 * c + 2] = nz;
    depth[c] = -gap;
    // The push out: C = gap ≥ 0 against an immovable collider, Δλ = −C.
    const bool inside = gap < 0;
    px = inside ? px - gap * nx : px;
    py = inside ? py - gap * ny : py;
    pz = inside ? pz - gap * nz : pz;
    const Real pushed = inside ? lambda[c] - gap : lambda[c];
    lambda[c] = pushed;
    // Friction over the substep, where there was a normal impulse: the tangential motion had
    // friction not acted (what it removed so far, F, added back), bounded by μ λ (Coulomb).
    const Real mx = px - x[i], my = py - x[i + 1], mz = pz - x[i + 2];
    const Real along = sumOfThree(nx * mx, ny * my, nz * mz);
    const Real fx = friction[3 * c], fy = friction[3 * c + 1], fz = friction[3 * c + 2];
    const Real ux = (mx - nx * along) + fx, uy = (my - ny * along) + fy,
               uz = (mz - nz * along) + fz;
    const Real length = std::sqrt(sumOfThree(ux * ux, uy * uy, uz * uz));
    const bool slides = length > collider.sticking * pushed;
    const Real bound = collider.kinetic * pushed / length;
    const Real scale = bound < Real(1) ? bound : Real(1);  // std::min(1, bound)
    const Real rx = slides ? ux * scale : ux, ry = slides ? uy * scale : uy,
               rz = slides ? uz * scale : uz;
    Real cx = rx - fx, cy = ry - fy, cz = rz - fz;
    const Real across = sumOfThree(nx * cx, ny * cy, nz * cz);
    cx = cx - nx * across;
    cy = cy - ny * across;
    cz = cz - nz * across;
    const bool rubs = !(pushed <= 0);
    moved[3 * c] = rubs ? px - cx : px;
    moved[3 * c + 1] = rubs ? py - cy : py;
    moved[3 * c + 2] = rubs ? pz - cz : pz;
    friction[3 * c] = rubs ? fx + cx : fx;
    friction[3 * c + 1] = rubs ? fy + cy : fy;
    friction[3 * c + 2] = rubs ? fz + cz : fz;
  }
}

}  // namespace

#if defined(__x86_64__)
[[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif
void countCollidersInReach(const ColliderPool& colliders, const ParticlePool& particles, Real h,
                           Real contactReach, const Real* extraReach, const Vec3* reached,
                           std::size_t begin, std::size_t end, Index* count,
                           Index* colliderBits) {
  const ReachLanes lanes{particles.x.data()->data(),
                         particles.v.data()->data(),
                         particles.w.data(),
                         reached ? reached->data() : nullptr,
                         extraReach,
                         nullptr,
                         h,
                         contactReach,
                         count,
                         colliderBits};
  countInReach(colliders, lanes, begin, end);
}

#if defined(__x86_64__)
[[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif
bool countMissingContacts(const ColliderPool& colliders, const ParticlePool& particles, Real h,
                          Real contactReach, const Real* extraReach, const Index* runStart,
                          std::size_t begin, std::size_t end, Index* count, Index* colliderBits) {
  const ReachLanes lanes{particles.x.data()->data(),
                         particles.v.data()->data(),
                         particles.w.data(),
                         particles.p.data()->data(),
                         extraReach,
                         runStart,
                         h,
                         contactReach,
                         count,
                         colliderBits};
  return countInReach(colliders, lanes, begin, end);
}

#if defined(__x86_64__)
[[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif
void setPredictedSurfaces(ContactPool& contacts, const ColliderPool& colliders,
                          const ParticlePool& particles, Real h, std::size_t begin,
                          std::size_t end) {
  for (std::size_t first = begin; first < end;) {
    const std::size_t last = sameColliderEnd(contacts, first, end);
    const Collider collider = colliderOf(colliders, contacts.collider[first]);
    if (collider.radius == 0)
      setSurfacesOnOne<true>(contacts, collider, particles, h, first, last);
    else
      setSurfacesOnOne<false>(contacts, collider, particles, h, first, last);
    first = last;
  }
}

#if defined(__x86_64__)
[[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif
void markInsideColliders(const ColliderPool& colliders, const ParticlePool& particles,
                         std::size_t begin, std::size_t end, std::uint8_t* inside) {
  const Real* p = particles.p.data()->data();
  for (std::size_t i = begin; i < end; ++i) inside[i - begin] = 0;
  for (std::size_t k = 0; k < colliders.size(); ++k) {
    const Collider collider = colliderOf(colliders, static_cast<Index>(k));
    if (collider.radius == 0)
      markInside<true>(collider, p, begin, end, inside);
    else
      markInside<false>(collider, p, begin, end, inside);
  }
}

#if defined(__x86_64__)
[[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif
void projectSingleContacts(ContactPool& contacts, const ColliderPool& colliders,
                           ParticlePool& particles, std::size_t begin, std::size_t end) {
  for (std::size_t first = begin; first < end;) {
    const std::size_t last = sameColliderEnd(contacts, first, end);
    const Collider collider = colliderOf(colliders, contacts.collider[first]);
    if (collider.radius == 0)
      projectOnOne<true>(contacts, collider, particles, first, last);
    else
      projectOnOne<false>(contacts, collider, particles, first, last);
    first = last;
  }
  // The positions go back by particle (a scatter, which the lanes above cannot do).
  const Index* particleOf = contacts.particle.data();
  for (std::size_t c = begin; c < end; ++c) particles.p[particleOf[c]] = contacts.moved[c];
}

}  // namespace nucleon
