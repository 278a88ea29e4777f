// The tether family's own sweep. A tether joins a free vertex to a pin, which no sweep moves, so
// tethers of different vertices never interact and a vertex's own tethers form a short chain.
// The derived tables store the pool in layers (layerTethers): layer k holds the k-th tether of
// every vertex that has more than k, vertices ranked by decreasing tether count, so that rank r
// has its tethers at layerStart[k] + r for every layer that reaches it. A sweep then takes each
// vertex once, applies its tethers in order and writes it back: Gauss–Seidel within the vertex,
// every vertex independent, which is the same result for every backend and thread count, with
// no color barrier and, eight vertices at a time, one gather and one scatter of the vertex
// however many tethers hold it.
//
// A tether is hard (α = 0) and undamped, so its projection does not depend on λ: with w the
// vertex's inverse mass and the pin immovable, Δλ = −C/w moves the vertex by −C n. λ is left at 0.
#pragma once

#include "components/constraint_pool.h"
#include "nucleon/solver_settings.h"
#include "systems/solver/constraint_sweeps.h"

namespace nucleon {

// Permutes the tether pool into layers and sets its coloring to them (each layer is a valid
// color: it holds one tether per vertex, and pins are never written). The first particle of a
// tether is its free vertex, the second its pin.
void layerTethers(TetherConstraints& pool);

// One sweep of the tether family. With an object filter (per-object schedules) it falls back to
// the generic sweep of `kind`, which the layered coloring also serves.
void solveTethers(SolverKind kind, TetherConstraints& pool, const SweepContext& context);

}  // namespace nucleon
