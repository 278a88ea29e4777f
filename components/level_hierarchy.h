// Level hierarchy of the multigrid backend: hierarchical position based dynamics (Müller 2008,
// "Hierarchical Position Based Dynamics"), ARCHITECTURE.md §3.
//
// Built by buildLevelHierarchies (systems/setup/build_hierarchy.h) when the topology changes, never
// inside a step. One ObjectHierarchy per object that has edges (cloth, rope, solid; not particle
// clouds, not colliders), in object order. All particle indices are GLOBAL (into the particle
// pool), so a sweep reads and writes ParticlePool::p directly.
//
// Levels, finest first: levels[0] holds every particle of the object, and each next level is a
// subset of the one before (a coarse particle IS a fine particle: restriction is injection, there
// is nothing to transfer down). Particles with inverse mass 0 (pins, animated pins) are on every
// level. For level l:
//
//   particles                    sorted global indices of the level's particles.
//   edges, restLength            the level's graph. Level 0: the object's edges (the same pairs
//                                as its stretch constraints, which the fine sweeps solve; they
//                                are kept here because the parents below are read from this
//                                graph). Level l ≥ 1: the coarse constraints, UNILATERAL distance
//                                limits C = |p_i − p_j| − restLength ≤ 0 (project only when
//                                C > 0), restLength the rest-pose distance of the two particles
//                                (times 1 + the strain limit of a material that has one,
//                                Material::stretchLimit; pathRest likewise), never between two
//                                particles of inverse mass 0. Every edge joins
//                                two particles of this level, edges[e][0] < edges[e][1].
//   colorOffset                  the edges are stored in color order: color c is the edges
//                                [colorOffset[c], colorOffset[c+1]), and no two edges of one
//                                color share a particle (pins included), so a color can be swept
//                                in parallel with direct writes; colors run in sequence.
//                                colorCount() colors, colorOffset.size() == colorCount() + 1.
//   fine                         sorted global indices of the level's particles that are NOT on
//                                level l+1 (the ones prolongation moves); particles == fine ∪
//                                levels[l+1].particles. Empty on the coarsest level.
//   parentOffset, parent, weight prolongation from level l+1 to level l as CSR, indexed by the
//                                position k in `fine`: fine[k]'s parents are parent[parentOffset[k]
//                                .. parentOffset[k+1]) (global indices, all on level l+1, its
//                                neighbours in this level's graph, ascending) with weights
//                                weight[...] > 0 summing to 1. parentOffset.size() ==
//                                fine.size() + 1 (so {0} on the coarsest level).
//
// Why unilateral limits at rest-pose length (Müller 2008 §4.2: coarse constraints "only grip if
// the entire material between adjacent particles is fully stretched"): a coarse edge stands for a
// whole patch of cloth between its particles, which may buckle or fold. As an equality it would
// also forbid the patch to shorten, so the coarse level locks: cloth cannot bend at any scale
// finer than the coarse spacing (the locking that Galerkin / FAS coarse operators bring to cloth,
// Wang et al. 2018). As an upper limit it only stops stretching, which inextensible material
// never allows between any two of its points, and the rest-pose distance is that bound for flat
// rest shapes (for a curved rest shape it is shorter than the path along the surface, so a coarse
// limit there may hold the cloth tighter than its rest shape). No coarse bending: bending is a
// fine-scale property, left to the fine sweeps. The converse holds for a shape bent while the
// solve runs: over a curved patch the chord is shorter than the material, and the limit is slack
// while the material stretches. A cloth bent by a collider (draped over a sphere) cannot
// straighten, so where both particles of a coarse edge touch a curved collider (a sphere, or a
// mesh at rest; a plane bends nothing) the cascade limits its chord to the one its path would
// have at rest length instead (multigrid_cascade.h).
//
// Intended use, one coarse-to-fine cascade per substep (Müller 2008 §4), with each particle moved
// by its parents' TOTAL displacement since the cascade began, so that what the coarser levels did
// reaches every particle, not only what the last level did:
//   q ← p for the object's particles (saved once, before the coarsest level);
//   for l = L−1 … 1: sweep level l's edges as unilateral limits, color by color, then the
//                    tethers of level l's particles;
//                    for every fine particle f of level l−1:
//                      p_f ← q_f + Σ_j weight_fj (p_j − q_j) over its parents j;
//   then the ordinary fine sweeps (level 0) over the object's constraint pools.
// Pinned parents have p_j = q_j, so they contribute nothing; pinned particles are never fine.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "components/contact_pool.h"
#include "nucleon/types.h"

namespace nucleon {

struct HierarchyLevel {
  std::vector<Index> particles;  // sorted, global

  // The level's graph / coarse unilateral distance limits, in color order.
  std::vector<std::array<Index, 2>> edges;  // global, edges[e][0] < edges[e][1]
  std::vector<Real> restLength;             // rest-pose distance of the edge's two particles
  std::vector<Index> colorOffset;           // color c is edges [colorOffset[c], colorOffset[c+1])

  // Coarse levels only (empty on level 0): the material an edge stands for, as the path of one
  // to three edges of the next finer level that joins its two particles with the least rest
  // length: its particles (global) from edges[e][0] to edges[e][1], the first repeated in front of
  // a shorter path (path[e] = {a, a, f, b} for a → f → b), and that rest length, pathRest ≥
  // restLength. The cascade compares the path's current length with it to tell a stretched
  // curved patch from a slack one (multigrid_cascade.cpp, setContactLimits).
  std::vector<std::array<Index, 4>> path;
  std::vector<Real> pathRest;
  // Where this level's edges start in CascadeScratch::limit (coarse levels).
  Index scratchBase = 0;

  // Prolongation from the next (coarser) level, CSR indexed by the position in `fine`.
  std::vector<Index> fine;          // sorted, global: on this level, not on the next
  std::vector<Index> parentOffset;  // fine.size() + 1 entries
  std::vector<Index> parent;        // global, on the next level
  std::vector<Real> weight;         // > 0, summing to 1 per fine particle

  // The tethers of this level's particles, coarse levels only (the fine level's are the tether
  // pool): CSR over `particles`, the tethers of particles[k] being [tetherOffset[k],
  // tetherOffset[k+1]), each a pin (global) and its limit. Empty when the object has none.
  std::vector<Index> tetherOffset;
  std::vector<Index> tetherPin;
  std::vector<Real> tetherLimit;

  std::size_t colorCount() const { return colorOffset.empty() ? 0 : colorOffset.size() - 1; }
  std::span<const Index> parentsOf(std::size_t fineIndex) const {
    return {parent.data() + parentOffset[fineIndex], parent.data() + parentOffset[fineIndex + 1]};
  }
  std::span<const Real> weightsOf(std::size_t fineIndex) const {
    return {weight.data() + parentOffset[fineIndex], weight.data() + parentOffset[fineIndex + 1]};
  }
};

struct ObjectHierarchy {
  Index object = 0;         // index in the world's object table
  Index firstParticle = 0;  // the object's particles are [firstParticle, firstParticle + count)
  Index particleCount = 0;
  std::vector<HierarchyLevel> levels;  // finest (all particles) first; at least one
};

// The world's hierarchies: one per object with edges, in object order.
struct LevelHierarchies {
  std::vector<ObjectHierarchy> objects;
  std::size_t coarseEdges = 0;  // the edges of every coarse level of every object
};

// The cascade's per-substep scratch: the positions when it began, the limit each coarse edge is
// swept with (at HierarchyLevel::scratchBase of its level) while particles touch colliders, and
// per particle whether a collider holds it bent.
struct CascadeScratch {
  std::vector<Vec3> start;
  std::vector<Real> limit;
  std::vector<std::uint8_t> held;
  // Per coarse particle, the curved surface it rests on this cascade (multigrid_cascade.cpp): a
  // sphere collider or a static mesh (supportId; kNoSupport: none), the surface's normal there,
  // and for a mesh its contact's separating plane n · p ≥ offset.
  std::vector<Index> supportId;
  std::vector<Vec3> supportNormal;
  std::vector<Real> supportOffset;
  std::vector<Index> onSpheres;  // one level's particles on a sphere collider
  // Their collider contacts, copied out for the projections between the level's sweeps, and
  // where each came from in the substep's pool (particle_contacts.h, copyContactsOf).
  ContactPool levelContacts;
  std::vector<Index> levelContactSource;
};

}  // namespace nucleon
