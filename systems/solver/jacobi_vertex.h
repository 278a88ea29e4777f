// The vertex-centric ("gather-only") Jacobi sweep of hard, undamped distance constraints: the
// same mass-split, averaged, Chebyshev-accelerated sweep as the slot path of constraint_sweeps.h,
// computed per particle instead of per constraint.
//
// With α = 0 and no damping, constraint c = (i, j) with split inverse masses W_i, W_j moves i by
//   Δx_i^c = W_i s_c (p_i − p_j),  s_c = −C_c / ((W_i + W_j) |p_i − p_j|),  C_c = |p_i − p_j| −
//   L_c,
// (Macklin et al. 2016, eq. 18, the α̃λ term vanishing), and the slot path's gather moves i by the
// average over its n_i slots. Since W_i = n_i w_i, that average is
//   Δx_i = γ (1/n_i) Σ_c W_i s_c (p_i − p_j) = γ w_i Σ_c s_c (p_i − p_j),
// which each particle can compute alone from the positions of its neighbours: no slot is written
// and read back, and the scatter of the constraint-centric pass disappears. Each constraint is
// evaluated twice, once from each end, at about a third of the slot path's memory traffic.
//
// Chebyshev (jacobi_chebyshev.h): the slot path keeps u_c = ω γ Δx_c + (ω − 1) u_c,prev per slot,
// whose average over i's slots is ω γ Δx_i + (ω − 1) (i's previous move by this family). So one
// history vector per particle, the previous move, carries the same recurrence. The adaptive
// restart (carry only while the new step does not oppose the history) is then per particle
// instead of per slot: the one place where the two paths differ beyond rounding. Measured on
// cloth_hang_256 (jacobi, 10 sweeps, 120 frames), mean and 99th-percentile strain agree within
// 0.3% (0.2562 / 1.594 against 0.2554 / 1.590), but the maximum, one edge, comes out 1 to 11%
// higher at the frames sampled (1.871 against 1.792 at the end): the per-slot rule also drops the
// history of a single constraint that overshoots, the per-particle rule only a whole move. With
// ρ = 0 (no history) the two paths give the same statistics to four digits.
//
// Two passes, so that no position changes while another particle reads it: the first computes
// every particle's move into the history, the second adds it to p. The multipliers are booked
// the same way: the first pass stores every slot's multiplier step in its lane (a vector store),
// the second adds each constraint's end-0 value to λ_c (a gather), since booking them one lane at
// a time inside the first pass cost about 30% of the sweep. Eight particles at a time with
// AVX2 and FMA where distanceBatchesAvailable() (float builds on such CPUs), one at a time
// otherwise, with the same arithmetic. Blocks of eight particles from particle 0 and a fixed slot
// order per particle: bitwise the same result for any thread count.
#pragma once

#include <array>
#include <span>

#include "components/constraint_graph.h"
#include "components/particles.h"
#include "nucleon/types.h"

namespace nucleon {

// Builds the slot rows of a two-particle family from its tuples, rest lengths, incidence and
// split inverse masses (the derived tables).
VertexSlotRows buildVertexSlotRows(std::span<const std::array<Index, 2>> constraints,
                                   std::span<const Real> rest, const ParticleIncidence& incidence,
                                   std::span<const Real> splitInverseMass);

struct VertexJacobiStep {
  Real factor = 1;       // the step's scale: ω γ on accelerated sweeps, γ on plain ones
  Real sheetFactor = 1;  // the same with the sheet relaxation, for particles with rows.sheet = 1
  Real carry = 0;        // ω − 1; 0 on plain sweeps, which neither read nor carry the history
};

// One sweep: moves `positions` (p); `move` is the pool's per-particle history
// (ConstraintPool::vertexMove), read when step.carry ≠ 0 and overwritten with this sweep's moves.
// Each lane of the rows gets its slot's factor · Δλ in `laneLambda` (ConstraintPool::
// vertexLaneLambda): added to what the lane holds when `accumulate`, else stored. The multipliers
// are booked once for all the sweeps so summed (bookVertexLambda), not after every sweep: a
// hard constraint's λ enters no sweep (its α̃λ term vanishes), and the gather that booked them
// was 7–8% of a hanging cloth's step. Summed in the lane in sweep order and added to a λ that
// was zero, λ_c is bitwise what booking after every sweep gave.
void solveDistanceJacobiVertex(const VertexSlotRows& rows, std::span<Real> move,
                               std::span<Real> laneLambda, std::span<Vec3> positions,
                               const VertexJacobiStep& step, bool accumulate);

// λ_c += the lane sum of constraint c's end-0 slot, for every constraint.
void bookVertexLambda(const VertexSlotRows& rows, std::span<const Real> laneLambda,
                      std::span<Real> lambda);

}  // namespace nucleon
