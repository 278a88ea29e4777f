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

}  // namespace

#if defined(__x86_64__)
[[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif
void projectSingleContacts(ContactPool& contacts, const ColliderPool& colliders,
                           ParticlePool& particles, std::size_t begin, std::size_t end) {
  const Index* particleOf = contacts.particle.data();
  const Index* colliderOf = contacts.collider.data();
  Real* contactNormal = contacts.normal.data()->data();
  Real* depth = contacts.depth.data();
  Real* lambda = contacts.lambda.data();
  Real* friction = contacts.friction.data()->data();
  const Real* point = colliders.point.data()->data();
  const Real* planeNormal = colliders.normal.data()->data();
  const Real* radius = colliders.radius.data();
  const Real* thickness = colliders.thickness.data();
  const Real* kinetic = colliders.friction.data();
  const Real* sticking = colliders.staticFriction.data();
  const Real* p = particles.p.data()->data();
  Real* moved = contacts.moved.data()->data();
  const Real* x = particles.x.data()->data();
#pragma omp simd
  for (std::size_t c = begin; c < end; ++c) {
    const Index i = 3 * particleOf[c], k = colliderOf[c], k3 = 3 * k;  // far below 2³² / 3
    Real px = p[i], py = p[i + 1], pz = p[i + 2];
    // surfaceAt: a plane's signed distance, or a sphere's distance from its centre.
    const Real ox = px - point[k3], oy = py - point[k3 + 1], oz = pz - point[k3 + 2];
    // A plane's radius is 0, a sphere's positive (ColliderPool): the shape, read as a float lane.
    const bool plane = radius[k] == 0;
    const Real planeGap =
        sumOfThree(planeNormal[k3] * ox, planeNormal[k3 + 1] * oy, planeNormal[k3 + 2] * oz) -
        thickness[k];
    const Real distance = std::sqrt(sumOfThree(ox * ox, oy * oy, oz * oz));
    const bool away = distance > Real(1e-12);
    const Real sphereGap = distance - radius[k] - thickness[k];
    const Real gap = plane ? planeGap : sphereGap;
    const Real nx = plane ? planeNormal[k3] : away ? ox / distance : Real(0);
    const Real ny = plane ? planeNormal[k3 + 1] : away ? oy / distance : Real(1);
    const Real nz = plane ? planeNormal[k3 + 2] : away ? oz / distance : Real(0);
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
    const bool slides = length > sticking[k] * pushed;
    const Real bound = kinetic[k] * pushed / length;
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
  // The positions go back by particle (a scatter, which the lanes above cannot do).
  for (std::size_t c = begin; c < end; ++c) particles.p[particleOf[c]] = contacts.moved[c];
}

}  // namespace nucleon
