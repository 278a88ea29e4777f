// Builds the level hierarchies of the multigrid backend (components/level_hierarchy.h, which
// documents the tables and how a solver uses them; ARCHITECTURE.md §3) from each object's
// simplicial complex, rest positions and inverse masses.
//
// Per object with edges (cloth, rope, solid), level by level (Müller 2008, "Hierarchical Position
// Based Dynamics", §4):
//  - coarse particles: the level's particles in increasing index order, all coarse at first; a
//    particle becomes fine if it has at least k coarse neighbours in the level's graph and each
//    of its fine neighbours would keep at least k. Particles with inverse mass 0 stay coarse, so
//    pins are on every level. Every fine particle therefore ends with ≥ k coarse neighbours, and a
//    particle with fewer than k neighbours (a rope's end, an isolated vertex) is never fine, so
//    no fine particle lacks a parent. Regular grids (gridCloth's layout) are instead decimated
//    two to one along each axis, keeping the last row and column and the pins (settings);
//  - the next level's graph joins two coarse particles that are neighbours, or that share a fine
//    neighbour, at this level (Müller), or whose fine neighbours are neighbours (settings: it
//    keeps levels connected); limits between two particles of inverse mass 0 are left out. Rest
//    lengths are rest-pose distances;
//  - each coarse edge keeps its path: the one to three edges of this level that join its two
//    particles (as the link above found them) with the least rest length;
//  - parents of a fine particle: its coarse neighbours, weighted ŵ_j = 1 / (d_j / max d + ε) with
//    d_j the rest distance, normalised to sum 1 (closer parents weigh more);
//  - edges colored greedily in (i, j) order, each taking the lowest color free at both ends.
// Levels stop at a level of at most `smallestLevel` particles, or when the next level would keep
// more than (1 − minimumShrink) of this one's: a level that removes fewer than a tenth of the
// particles costs a sweep and moves almost nothing (a pinned row, which stays on every level,
// ends a cloth's hierarchy this way).
//
// Cost: linear in the edges and particles of each level, on one core; measured (Release, float,
// two-core EPYC under load) at about 40 ms for a 256×256 cloth (65,536 particles, 195,585 edges,
// 7 levels). It allocates the tables it returns; it is meant to run when the topology changes,
// never inside a step. The result depends only on the input: building twice gives identical
// tables.
#pragma once

#include <cstddef>
#include <vector>

#include "components/constraint_pool.h"
#include "components/level_hierarchy.h"
#include "components/objects.h"
#include "components/particles.h"

namespace nucleon {

struct HierarchySettings {
  // k: the coarse neighbours every fine particle keeps (Müller 2008 uses 2). At least 1.
  int coarseNeighbours = 2;
  // A level with at most this many particles is the coarsest: one more level would save little
  // work and a sweep of it is already cheap.
  std::size_t smallestLevel = 32;
  // The next level must drop at least this fraction of the particles, else this is the coarsest.
  double minimumShrink = 0.1;
  // Decimate regular grids (gridCloth's layout, shapes.h) two to one along each axis, keeping
  // the last row and column and the pins, instead of the greedy selection. Measured on a 256×256
  // cloth, the greedy selection's levels were 65,536, 16,513, 3,804, 544, 76, 14 particles in
  // uneven staircases with empty patches; decimation gives 65,536, 16,641, 4,225, 1,089, 289,
  // 81, 25, each level a grid with both diagonals of every cell.
  bool decimateGrids = true;
  // Also join two coarse particles whose fine neighbours are neighbours of each other. Müller
  // 2008 joins only neighbours and particles that share a fine neighbour, and that alone can cut
  // a level apart: on a 256×256 grid cloth under the greedy selection, the third level onward
  // was mostly chains of degree 2, each level kept about half of the one before, and the
  // coarsest fell into 21 pieces that no coarse constraint joins. With this link every edge of
  // a level maps to an edge (or one particle) of the next, since every fine particle has a
  // coarse neighbour, so a level is connected wherever the object is; it is the sparsity of the
  // Galerkin coarse operator PᵀAP for these parents.
  bool linkThroughFineEdges = true;
  // ε of the parent weights: bounds a parent's weight at 1/ε times the farthest's when its rest
  // distance is 0.
  double weightEpsilon = 1e-3;
};

// Replaces `out` with the hierarchies of `objects` (every object of kind Cloth, Rope or Solid
// whose complex has edges), reading particles.restPosition and particles.w.
void buildLevelHierarchies(LevelHierarchies& out, const std::vector<ObjectRecord>& objects,
                           const ParticlePool& particles, const HierarchySettings& settings = {});

// Copies each tether whose free particle is on a coarse level into that level (tetherOffset,
// tetherPin, tetherLimit), so the cascade holds coarse particles to their pins as the fine sweeps
// hold every particle: without them the coarse levels let the cloth stretch away from its pins
// and only the fine sweeps pull it back (cloth_hang_256, 120 frames, cascade and 8 fine sweeps:
// mean strain 0.77% without, 0.49% with them projected after each level's sweeps). Call after
// buildLevelHierarchies and whenever the tethers change.
void attachLevelTethers(LevelHierarchies& hierarchies, const TetherConstraints& tethers,
                        std::size_t particleCount);

}  // namespace nucleon
