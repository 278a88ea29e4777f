// Contacts between collision primitives (vertex–face, edge–edge, vertex–edge, vertex–vertex), as
// structure of arrays: unilateral constraints solved with the other families. Per-substep
// lifetime: refilled from the candidate pairs every substep into storage that keeps its capacity.
//
// Every contact is the same linear form over up to four particles (ARCHITECTURE.md §4):
//   C(p) = n · Σ_k c_k p_k − distance ≥ 0
// with the fixed unit normal n, pointing from the second primitive to the first, and coefficients
// c_k: the first primitive's interpolation weights with a plus sign, the second's with a minus sign
// (vertex–face: 1, −b0, −b1, −b2; edge–edge: 1−s, s, −(1−t), −t). Unused slots have c_k = 0. n, the
// weights and the distance are fixed when the contact is made, at the pair's time of impact within
// the substep (or its start), which makes the constraint a separating plane that the sweeps hold
// however far the primitives were predicted to travel through each other.
//
// For the parallel backends the corrections are gathered per particle through a CSR incidence
// (particle → (contact, slot)) built with the pool, in contact order, or, in a round with few
// pressed contacts, scattered from those alone in the same order: the result does not depend on
// the thread count.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "nucleon/types.h"

namespace nucleon {

// One contact as the narrow phase makes it, before it is stored in the pool.
struct PrimitiveContactRecord {
  std::array<Index, 4> particles{};
  std::array<Real, 4> coefficient{};
  Vec3 normal = Vec3::Zero();
  Real distance = 0, friction = 0, staticFriction = 0, restitution = 0, stickiness = 0;
  Real approachSpeed = 0;
  Real inverseMass = 0;
};

struct PrimitiveContactPool {
  std::vector<std::array<Index, 4>> particles;
  std::vector<std::array<Real, 4>> coefficient;  // c_k; 0 for unused slots
  std::vector<Vec3> normal;
  std::vector<Real> distance;  // the radii summed: the separation the contact keeps
  // The normal correction accumulated over the substep, as the separation it restored (m): what
  // Coulomb's law bounds the relative tangential motion by.
  std::vector<Real> lambda;
  std::vector<Real> friction;  // Coulomb μ_k of the pair
  std::vector<Real> staticFriction;
  std::vector<Real> restitution;    // e of the pair
  std::vector<Real> stickiness;     // separation (m) beyond `distance` that is still pulled back
  std::vector<Real> approachSpeed;  // n · Σ c_k v_k when the contact was made (< 0: closing)
  std::vector<Real> inverseMass;    // Σ w_k c_k²: the generalised inverse mass along n

  // Per-contact scratch of the parallel backends: the step Δλ of the last projection.
  std::vector<Real> step;
  // CSR incidence for the parallel gather: contacts touching particle i are
  // incidence[incidenceOffset[i] .. incidenceOffset[i+1]) as (contact << 2 | slot).
  std::vector<Index> incidenceOffset;
  std::vector<Index> incidence;
  std::vector<Real> incidenceCoefficient;  // c_k of each incidence entry, beside it
  // Static (set with the derived tables): per particle, 1 for a liquid's; empty when the world
  // has none. A contact with a liquid particle is mass-split in the parallel rounds
  // (projectPrimitiveContacts), so that a cloth pressed by many particles carries their weight.
  std::vector<std::uint8_t> splitParticle;
  std::vector<std::uint8_t> splitStep;  // scratch of a round: 1 where the step was split
  std::vector<Index> touched;           // particles with at least one contact, ascending
  std::vector<Index> incidenceCursor;   // scratch of the incidence's parallel build
  // The scatter's per-particle sums of a round with few pressed contacts (zero between rounds):
  // Σ c_k × correction over the particle's pressed contacts in contact order, their count, and
  // the particles that have any.
  std::vector<Vec3> pressedSum;
  std::vector<Index> pressedCount;
  std::vector<Index> pressedParticles;

  // Friction scratch of the parallel backends: the tangential correction of each contact.
  std::vector<Vec3> tangentStep;

  // Narrow-phase scratch: the contacts each fixed chunk of candidates made, and where each
  // chunk's contacts start in the pool.
  std::vector<std::vector<PrimitiveContactRecord>> chunkContacts;
  std::vector<std::size_t> chunkOffset;
  // Per candidate pair: its distance at the start of the substep; whether the fail-safe must test
  // it with CCD.
  std::vector<double> startDistance;
  std::vector<double> formerStartDistance;  // scratch: the distances before a re-detection
  std::vector<std::uint8_t> suspect;
  // Per particle: the fail-safe round that last moved it, plus one (0: none), so that a round
  // re-tests only the pairs the one before changed.
  std::vector<int> failsafeRound;
  // Scratch per collision primitive, by list (points, edges, triangles): the most any of its
  // particles strays (the narrow phase) or deviates (the fail-safe), and whether the fail-safe's
  // last round moved one of them, so that a scan over the pairs reads one value per primitive
  // instead of every particle's.
  std::array<std::vector<double>, 3> primitiveDeviation;
  std::array<std::vector<std::uint8_t>, 3> primitiveMoved;
  std::array<std::vector<double>, 3> primitiveTravel;  // … and the most one travels, |p − x|
  // The narrow phase's stray beside the primitive's radius: one record read per side of a pair.
  struct StrayAndRadius {
    double stray;
    double radius;
  };
  std::array<std::vector<StrayAndRadius>, 3> primitiveStray;
  // Per particle: what the fail-safe holds it to (primitive_contacts.h, resolveCrossings): its
  // precedence (0: its own predicted motion, 1: its impact zone's rigid motion, higher: carried
  // by the rigid motion of a kinematic body, a lower object and triangle first), and, when
  // carried, that motion x → R x + t.
  std::vector<std::uint64_t> carryPrecedence;
  static constexpr std::uint64_t kImpactZonePrecedence = 1;
  // The particles the fail-safe carried with a body in its last pass and their inverse masses,
  // while the sweeps after it hold them pinned (solve_constraints.cpp): scratch whose capacity
  // is kept.
  std::vector<Index> held;
  std::vector<Real> heldInverseMass;
  std::vector<Mat3d> carryRotation;
  std::vector<Vec3d> carryTranslation;
  // Per carried particle: its distance, at the substep's start, from the body it is carried with
  // (the start distance of the pair that set the carry), which weighs a squeeze between two
  // bodies; and the precedence of a squeezed particle, above every body's.
  std::vector<double> carryGap;
  static constexpr std::uint64_t kSqueezedPrecedence = ~std::uint64_t{0};
  // The fail-safe's impact zones (precedence 1): per particle, its parent in the zone forest
  // (kNoZone: in none), the slot of its zone in `zones` when it is a zone's root, and the position
  // the solve gave it (the motion whose momentum its zone keeps); per zone, its sums.
  static constexpr Index kNoZone = ~Index{0};
  struct ImpactZone {
    double mass = 0;
    Vec3d center = Vec3d::Zero();        // centre of mass at the start of the substep
    Vec3d motion = Vec3d::Zero();        // mean motion over the substep (linear momentum / mass)
    Vec3d angular = Vec3d::Zero();       // angular momentum of the motion about the centre (× h)
    Mat3d inertia = Mat3d::Zero();       // inertia tensor about the centre
    Mat3d rotation = Mat3d::Identity();  // the turn of the share of the motion it takes
    Vec3d turn = Vec3d::Zero();          // the whole turn over the substep, as a rotation vector
    // The share of its rigid motion it takes (moveImpactZones): 1, or less where the whole would
    // enter a collider; 0: held where the substep began (momentum lost, counted).
    double share = 1;
    bool deeper = false;  // scratch: the share takes a particle into a collider
    // The one plane collider its motion took a particle into, and along which it slid (−1: none,
    // −2: several).
    int plane = -1;
  };
  std::vector<Index> zoneParent;
  std::vector<Index> zoneSlot;
  std::vector<Vec3> failsafeFrom;
  std::vector<ImpactZone> zones;

  // What the narrow phase learned of each pair, kept from substep to substep so that a pair far
  // from contact is not measured again (primitive_contacts.h, "Lower bounds"):
  // per candidate pair, a lower bound on its distance over the motion from the start of the
  // substep to `predicted` (−∞ where none is known), valid for candidate set `boundVersion`;
  std::vector<double> lowerBound;
  std::vector<double> formerLowerBound;  // scratch: the bounds before the set changed
  std::uint64_t boundVersion = 0;        // CandidatePairs::version; 0: none
  // per particle, the predicted position the bounds were taken over, and scratch: how far each
  // particle's final position strays from it (the fail-safe), and how far its start strays from
  // it plus how far its motion strays from the mean motion (the narrow phase).
  std::vector<Vec3> predicted;
  std::vector<double> deviation;
  std::vector<double> stray;
  std::vector<Vec3d> chunkMotion;        // scratch: the motions summed per fixed chunk
  std::vector<std::size_t> chunkMovers;  // … and how many particles each sum has

  std::size_t size() const { return particles.size(); }
  void store(std::size_t slot, const PrimitiveContactRecord& c) {
    particles[slot] = c.particles, coefficient[slot] = c.coefficient, normal[slot] = c.normal;
    distance[slot] = c.distance, lambda[slot] = 0, friction[slot] = c.friction;
    staticFriction[slot] = c.staticFriction, restitution[slot] = c.restitution;
    stickiness[slot] = c.stickiness, approachSpeed[slot] = c.approachSpeed;
    inverseMass[slot] = c.inverseMass;
  }
  void resize(std::size_t n) {
    particles.resize(n), coefficient.resize(n), normal.resize(n), distance.resize(n);
    lambda.resize(n), friction.resize(n), staticFriction.resize(n), restitution.resize(n);
    stickiness.resize(n), approachSpeed.resize(n), inverseMass.resize(n), step.resize(n),
        tangentStep.resize(n);
  }
};

}  // namespace nucleon
