// The second half of a Jacobi sweep, shared by every constraint family: each particle sums the
// corrections its constraints computed (from the same state), in the fixed slot order of the
// incidence table, and moves by their average times a factor s:
//   Δx_i = s · (Σ_c Δx_i^c) / n_i        (constraint averaging, Macklin et al. 2014 §4.2)
// The sweep (constraint_sweeps.h) folds the relaxation γ and the Chebyshev weight into the slots
// and passes s = 1. Fixed order and no atomics: the result is bitwise the same for any thread
// count.
#pragma once

#include <span>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "components/constraint_graph.h"
#include "components/particles.h"

namespace nucleon {

inline void gatherJacobiCorrections(const ParticleIncidence& incidence,
                                    std::span<const Vec3> correction, ParticlePool& particles,
                                    Real scale) {
  const std::size_t n = incidence.offset.size() - 1;
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, n, 2048),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const Index begin = incidence.offset[i], end = incidence.offset[i + 1];
          if (begin == end) continue;
          Vec3 sum = Vec3::Zero();
          for (Index s = begin; s < end; ++s) sum += correction[incidence.slot[s]];
          particles.p[i] += (scale / Real(end - begin)) * sum;
        }
      },
      tbb::static_partitioner());
}

}  // namespace nucleon
