// The sweep paths a constraint pool may take besides the generic sweep of each backend: the
// `paths` column of the family table (NUCLEON_CONSTRAINT_FAMILIES in nucleon/constraint_family.h).
// Each is an optimisation of the generic sweep for one shape of pool, whose result it equals up
// to rounding (the batches contract multiply-adds), and each falls back to the generic sweep
// where it does not apply (an object filter, damping, a build without AVX2).
#pragma once

namespace nucleon {

enum SweepPath : unsigned {
  kGenericSweep = 0,
  // Distance constraints eight at a time with AVX2 (distance_batch.h), in colored Gauss–Seidel
  // and in Jacobi's slot path, for pools without damping.
  kDistanceBatch = 1u << 0,
  // Jacobi's vertex-centric sweep (jacobi_vertex.h), for pools of hard, undamped distance
  // constraints.
  kVertexJacobi = 1u << 1,
  // The tethers' own sweep by vertex, in layers (tether_sweep.h), in every backend.
  kTetherLayers = 1u << 2,
  // Angular constraints (dihedral hinges, angles) eight at a time with AVX2 (angular_batch.h), in
  // colored Gauss–Seidel and in Jacobi's slot path, for pools without damping.
  kAngularBatch = 1u << 3,
};

}  // namespace nucleon
