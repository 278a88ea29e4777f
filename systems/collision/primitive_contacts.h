// Contacts between collision primitives: from the broad phase's candidate pairs to unilateral
// constraints solved with the other families, and the fail-safe that leaves no crossing.
//
//   detectPrimitiveContacts   after the broad phase: each candidate pair whose motion may bring
//                             it within its contact distance (plus the margin) becomes a contact,
//                             with normal and weights at its time of impact (space-time CCD)
//   projectPrimitiveContacts  after each sweep round: C = n · Σ c_k p_k − distance ≥ 0
//   applyPrimitiveFriction    end of the solve: Coulomb friction on the substep's relative
//                             tangential motion, bounded by μ λ_n (Macklin et al. 2014 §6)
//   resolveCrossings          end of the solve: the final motion x → p of every candidate pair
//                             is checked by CCD at zero thickness; the free particles of a
//                             crossing pair are held to one rigid motion: that of their impact
//                             zone, merged from overlapping crossings, which keeps the linear
//                             and angular momentum of its particles (Bridson, Fedkiw and
//                             Anderson 2002 §7.4; Harmon et al. 2008), or the rigid motion of a
//                             kinematic side (a turning collider, a pinned ring), until none is
//                             left: a bounded fail-safe that keeps an intersection-free state
//                             intersection-free. A particle carried with one translating collider
//                             body that crosses another (a squeeze to less than its contact
//                             distance) is held in the gap between the two, each body's motion
//                             weighed by the particle's start distance from the other (counted:
//                             squeezes); between turning bodies the squeeze stays unresolved
//   applyRestitution          after the update: closing contacts bounce with restitution e
//
// Pairs within one object that are closer than their contact distance in the rest shape get no
// contact (the mesh's own constraints hold them), but they are still checked for crossings.
//
// One contact per feature. Two primitives of a mesh that share a vertex or an edge are equally
// close to a point near it, at the same point: a pellet over a cloth's edge is within reach of
// both triangles, of the edge, and of the edges around it by their ends. One constraint is kept
// per feature (Bridson et al. 2002 test every pair; a duplicate only weighs the same push twice
// in the Jacobi average and costs a projection): a vertex–face pair makes a contact only where
// its closest point lies inside the face or on a vertex or edge that the face owns
// (CollisionPrimitives::triangleOwnership), and an edge–edge pair closest at an end of an edge,
// or a point–edge pair, none where the point's vertex–face pairs with the edge's triangles carry
// it. On cloth_self this cut the contacts per substep from 29.8 k to 7.4 k, on
// cloth_drop_sphere from 202 k to 48 k, with fewer crossings left to the fail-safe on both.
//
// Lower bounds. Most candidate pairs never come near each other (neighbours in a sheet, layers
// of a pile two apart), and measuring them again every substep was most of the narrow phase.
// The narrow phase keeps, per pair, a lower bound L on the pair's distance over the predicted
// motion x → p it measured, and per particle the p it was measured for. A point of a primitive
// is a convex combination of its particles, so it strays from where the prediction put it by at
// most the most any of its particles strays, and moves, relative to any common translation ū, by
// at most the most any of its particles does. Hence, with D_k = |x_k − p_k(last)| and
// M_k = |p_k − x_k − ū| (ū the mean motion of the free particles), over the next substep the
// pair's distance is at least L − max_A D − max_B D − max_A M − max_B M: a pair whose bound so
// carried still exceeds its reach is passed over, keeping the smaller bound, and only the others
// are measured. The pair set is followed from substep to substep through
// CandidatePairs::formerIndex. In the same way the fail-safe passes over a pair whose bound
// exceeds how far its particles' final positions strayed from the prediction: it cannot have
// crossed.
#pragma once

#include <cstddef>

#include "components/candidate_pairs.h"
#include "components/collider_pool.h"
#include "components/collision_primitives.h"
#include "components/particles.h"
#include "components/primitive_contact_pool.h"
#include "nucleon/solver_settings.h"
#include "nucleon/types.h"

namespace nucleon {

struct ObjectRecord;

// How much farther than its contact distance a pair may be and still get a contact (m): the room
// the sweeps have to move the primitives together after detection. The broad phase inflates
// boxes by half of it beyond the radius, and every particle stays inside bounds that keep
// primitives with disjoint boxes apart (boundSlack), so no crossing can escape the candidate set.
// 2.5 mm rather than 5: on a 128² cloth of 4 mm thickness it cut candidates by a third and
// contacts by 60% (a step 303 → 237 ms) with the same strain and no intersection, and on the
// bundled collision scenes it left every figure the tests check unchanged.
constexpr Real kPrimitiveContactMargin = Real(0.0025);

// Refills `contacts` from the candidate pairs (x: start of the substep, p: predicted end, v:
// velocity before the solve). Deterministic: contacts come out in candidate order.
void detectPrimitiveContacts(PrimitiveContactPool& contacts, const CandidatePairs& candidates,
                             const CollisionPrimitives& primitives, const ParticlePool& particles);

// The per-particle incidence of the contacts (PrimitiveContactPool::incidence, touched) that the
// parallel backends' projection reads; detectPrimitiveContacts builds it after filling the pool.
void buildContactIncidence(PrimitiveContactPool& contacts, std::size_t particleCount);

// Projects every contact onto particles.p: the parallel backends move each particle by the mean
// of its pressed contacts' corrections, all taken from the same positions (summed in contact
// order, so the same bits at any thread count), gathered per particle, or scattered from the
// pressed contacts alone when they are few. Gauss–Seidel does the same for the contacts against a
// body (a side without free particles: a collider mesh, a pinned group), then projects the
// contacts between free particles one after another in pool order, whose equal and opposite
// pushes keep momentum.
void projectPrimitiveContacts(PrimitiveContactPool& contacts, ParticlePool& particles,
                              SolverKind kind);

// Coulomb friction over the substep's relative tangential motion of each contact that pushed;
// split by backend and contact as the projection is.
void applyPrimitiveFriction(PrimitiveContactPool& contacts, ParticlePool& particles,
                            SolverKind kind);

struct CrossingReport {
  std::size_t clamped = 0;       // particles pulled back inside their broad-phase bounds
  std::size_t crossings = 0;     // crossing pairs the fail-safe found (summed over its rounds)
  std::size_t stopped = 0;       // particle positions it reset
  std::size_t carried = 0;       // … of which carried by a kinematic body's motion
  std::size_t squeezed = 0;      // squeezes between two bodies it held a particle in the gap of
  std::size_t zones = 0;         // impact zones it moved as rigid bodies
  std::size_t stoppedZones = 0;  // … of them stopped or slowed, momentum lost
  // zone turns of a quarter or more in one substep, left out (the zone only translated)
  std::size_t turnsDropped = 0;
  // pairs still crossing when its round limit was reached (and, from the solve, particles it
  // carried out of their bounds for good)
  std::size_t unresolved = 0;
  int rounds = 0;
  // passes after which the sweeps ran again with the carried particles pinned (solve_constraints)
  std::size_t relaxations = 0;
};

// The distance of every candidate pair at the start of the substep (particles.x) into
// contacts.startDistance, for the fail-safe: after the candidates were found again for the
// solve's actual motion (the ones detectPrimitiveContacts measured belong to the earlier set).
// After an incremental re-detection (CandidatePairs::formerIndex) only the new pairs are measured;
// the others keep theirs.
void measureStartDistances(PrimitiveContactPool& contacts, const CandidatePairs& candidates,
                           const CollisionPrimitives& primitives, const ParticlePool& particles);

// Keeps the solve's final motion crossing-free (see the header comment): first clamps every free
// particle into its bounds (CandidatePairs::pathPoint and boundSlack; the world finds the pairs
// again for the actual motion when the solve leaves them, so this only guards), then the CCD
// rounds. An impact zone whose rigid motion would take a particle into the contact layer of a
// collider without a mesh (the ground, a plane, a sphere) stops where the substep began instead
// (counted with the stopped zones): the start is outside every collider and crossing-free.
CrossingReport resolveCrossings(PrimitiveContactPool& contacts, const CandidatePairs& candidates,
                                const CollisionPrimitives& primitives,
                                const ColliderPool& colliders, ParticlePool& particles);

// Restitution of closing contacts after the velocity update (v = (p − x)/h already holds the
// inelastic response): the relative normal velocity becomes at least −e times its approach value.
void applyRestitution(const PrimitiveContactPool& contacts, ParticlePool& particles);

}  // namespace nucleon
