// Liquids (Material::liquid): the particles of every liquid object, their SPH parameters, and the
// neighbour lists and scratch of the density constraints (position-based fluids, ARCHITECTURE.md
// §2). The particle list and parameters have a static lifetime (appended when a liquid is added);
// the hash grid, the neighbour lists and the scratch are refilled every substep into storage
// that keeps its capacity, so a step allocates nothing once the lists have reached their size.
#pragma once

#include <cstdint>
#include <vector>

#include "nucleon/material.h"
#include "nucleon/types.h"

namespace nucleon {

// The most neighbours a particle keeps (a particle at rest density has about 33 at kernel scale
// 2 and 113 at 3); those beyond are dropped and counted (LiquidPool::droppedNeighbours).
constexpr int kMaxLiquidNeighbours = 192;

// The kernels' constants for one kernel radius H (Müller et al. 2003): poly6 for the density,
// W(r) = 315/(64π H⁹) (H² − r²)³; the spiky kernel's gradient for the constraint gradients,
// ∇W(r) = −45/(π H⁶) (H − r)² r̂; Akinci's cohesion spline for surface tension.
struct LiquidKernels {
  Real radius = 0;    // H
  Real radius2 = 0;   // H²
  Real poly6 = 0;     // 315/(64π H⁹)
  Real spiky = 0;     // 45/(π H⁶)
  Real cohesion = 0;  // 32/(π H⁹)
};

// One liquid object's constants, derived from its material when it is added.
struct LiquidObject {
  std::uint32_t object = 0;  // index in the object table
  Index begin = 0, end = 0;  // its particles are particles[begin … end) of the pool's list
  Liquid settings;
  Real particleMass = 0;    // kg
  Real invRestDensity = 0;  // 1/ρ0
  Real spacing = 0;         // d = (m/ρ0)^(1/3)
  // ε of the density constraints and the artificial pressure's scale, both relative to an
  // interior particle's Σ w |∇C|² at rest (its denominator without ε), computed on the lattice.
  Real epsilon = 0;
  Real tensileScale = 0;      // k / (Σ w |∇C|²)_rest, in the multiplier's units
  Real tensileReference = 0;  // 1 / W(Δq)
};

// How far a liquid particle is looked for within a collider's reach beyond its own motion, in
// kernel radii (ContactPool::extraReach); the density projections of a substep together move a
// particle at most that far (projectDensity's maxMove is this over the substep's sweeps). Two:
// a wave striking a wall at 4 m/s, 1.7 cm per substep at 2 cm spacing, asked for moves of up to
// one kernel radius in a projection of three.
constexpr Real kLiquidContactReach = 2;

struct LiquidPool {
  LiquidKernels kernels;  // every liquid of a world has the same kernel radius
  std::vector<LiquidObject> objects;
  std::vector<Index> particle;          // global particle indices, object by object
  std::vector<std::uint32_t> objectOf;  // per liquid particle: its entry in `objects`

  // Per substep: the particles in *slots*, sorted by the hash grid's cell key (stable: in list
  // order within a key), so that a cell's particles, and most of a particle's neighbours, are
  // next to each other in memory. The sweeps work on the slots' copies of the positions and
  // velocities and write their moves back to the particle pool.
  std::vector<std::uint32_t> cellKey;     // per liquid particle
  std::vector<Index> slotParticle;        // per slot: the liquid particle (index into `particle`)
  std::vector<Index> cellStart;           // per key: its first slot; hash table size + 1 entries
  std::vector<Index> cellCursor;          // scratch of the sort
  std::vector<std::uint32_t> slotObject;  // per slot: its entry in `objects`
  std::vector<Real> mass;                 // per slot, kg
  std::vector<Real> inverseMass;          // per slot, the particle's w
  std::vector<Vec3> position;             // per slot: p in the solve, x in the velocity pass
  std::vector<Vec3> velocity;             // per slot, in the velocity pass
  // Neighbours of each slot (slots, within H, itself excluded), in a fixed order:
  // neighbours[s·neighbourStride …] with neighbourCount[s] of them. The stride is the largest any
  // liquid's kernel scale asks for (neighbourStride in neighbour_grid.h).
  int neighbourStride = 0;
  std::vector<Index> neighbours;
  std::vector<std::uint16_t> neighbourCount;
  // Per neighbour entry, from a projection's λ pass for its Δp pass (the positions are the same):
  // the spiky gradient's scale (∇W = (x_i − x_j) × it) and the artificial pressure's term.
  std::vector<Real> gradientScale;
  std::vector<Real> tensileTerm;
  // Per-slot scratch of the projections and the velocity pass.
  std::vector<Real> density;            // ρ (kg/m³), from the last evaluation
  std::vector<Real> lambda;             // λ of the last projection
  std::vector<Real> lambdaOverDensity;  // λ/ρ0 of the same, as the Δp pass reads it
  std::vector<Vec3> delta;              // Δp, or the new velocity in the velocity pass
  std::vector<Vec3> vorticity;          // ω
  std::vector<Vec3> normal;             // Akinci's surface normal n = H Σ (m_j/ρ_j) ∇W
  // Per liquid particle (list order): the sum of its multipliers over the substep's projections,
  // Λ. Its pressure is −ρ0 Λ / (m h²): the SPH pressure force's move h² Σ −m (p_i + p_j)/ρ0² ∇W
  // is the projections' Σ (λ_i + λ_j)/ρ0 ∇W at equal masses (w = 1/m).
  std::vector<Real> lambdaTotal;
  // Projections whose move of a particle was shortened to the most a projection may move it
  // (projectDensity), counted per particle; read and cleared by the solve's report.
  std::uint64_t limitedMoves = 0;
  // Neighbours dropped beyond the stride, summed over substeps since creation.
  std::uint64_t droppedNeighbours = 0;

  std::size_t size() const { return particle.size(); }
};

}  // namespace nucleon
