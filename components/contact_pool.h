// Contacts between particles and colliders, as structure of arrays. Unlike the constraint pools
// (static: built when the topology changes), this pool has a per-substep lifetime: the contact
// system refills it at the start of every substep from the particles' motion, into storage that
// keeps its capacity, so that a steady-state step allocates nothing.
//
// Contacts are stored in increasing particle order, and a particle's contacts are consecutive
// (in collider order). Contacts of different particles share nothing, so the runs of one
// particle are the pool's independent groups: the parallel backends project the runs in
// parallel and each run in order, which is the pool's coloring (the k-th contact of every
// particle forms color k) without a table.
#pragma once

#include <cstdint>
#include <vector>

#include "nucleon/types.h"

namespace nucleon {

struct ContactPool {
  std::vector<Index> particle;  // the particle in contact
  std::vector<Index> collider;  // index into ColliderPool
  std::vector<Vec3> normal;     // unit contact normal, out of the collider, at the last projection
  std::vector<Real> depth;      // penetration at the last projection (negative: a gap)
  // Accumulated over the substep (XPBD multipliers, in metres of correction): the normal push-out
  // λ_n, and the tangential displacement friction has removed, F. Friction bounds the whole
  // tangential motion of the substep by μ λ_n (Coulomb), so both must cover the whole substep.
  std::vector<Real> lambda;
  std::vector<Vec3> friction;
  // Scratch of the projection in lanes (collider_contact_lanes.h): each contact's particle's new
  // position, written back by particle after the lanes.
  std::vector<Vec3> moved;
  // Scratch of the solve (systems/solver/supported_particles.h): the particles a pressed,
  // frictional contact with a collider or a kinematic body supports in this substep, the outward
  // normal of that support at each, and per particle its place in the list plus one (0: none).
  std::vector<Index> supportedParticles;
  std::vector<Vec3> supportedNormal;
  std::vector<Index> supportedSlot;

  // Static (set with the derived tables): per particle, how much farther than its own motion it
  // is looked for within a collider's reach; empty when none is. A liquid particle's is the kernel
  // radius times kLiquidContactReach: the most the density projections of a substep move it, and
  // one pushed into a wall without a contact would have to be repaired.
  std::vector<Real> extraReach;

  // Build scratch: per particle, how many contacts it has (then, after the scan, where its run
  // starts). Sized to the particle count once, reused every substep.
  std::vector<Index> runStart;
  // Scratch of the re-detection after the multigrid cascade (addReachedContacts): per particle,
  // the contacts it gains.
  std::vector<Index> reachedCount;
  // Scratch of the detection in lanes: per particle, bit k set where it gets a contact with
  // collider k.
  std::vector<Index> reachedColliders;
  // Build scratch: where each block of particles' runs start (the detection's sum over blocks).
  std::vector<Index> blockStart;

  std::size_t size() const { return particle.size(); }
  // Sizes every column to n. Within the reserved capacity this never allocates.
  void resize(std::size_t n) {
    particle.resize(n);
    collider.resize(n);
    normal.resize(n);
    depth.resize(n);
    lambda.resize(n);
    friction.resize(n);
    moved.resize(n);
  }
};

}  // namespace nucleon
