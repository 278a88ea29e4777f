// Quality measures of a state (ARCHITECTURE.md §6): strain, energy, finiteness, volume, a state
// hash. Pure functions of the pools, used by the stats output, tests and benchmarks.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "components/constraint_pool.h"
#include "components/particles.h"

namespace nucleon {

struct StrainStats {
  double max = 0;   // max |L/L0 − 1|
  double mean = 0;  // mean |L/L0 − 1|
};
// Constraints with a zero rest length are skipped (their strain is undefined).
StrainStats measureStrain(const StretchConstraints& constraints, std::span<const Vec3> x);

// The whole picture of the stretch pool's strain s = L/L0 − 1, for the stats and tests: a
// maximum alone is decided by one edge, and |s| hides whether the cloth stretches or buckles.
struct StrainDistribution {
  double max = 0;             // max |s|
  double mean = 0;            // mean |s|
  double p99 = 0;             // 99th percentile of |s|, nearest rank
  double maxStretch = 0;      // max(s, 0): largest L/L0 − 1
  double maxCompression = 0;  // max(−s, 0): largest 1 − L/L0
  std::size_t count = 0;      // constraints measured
};
// Constraints with a zero rest length or a non-finite length are skipped (non-finite positions
// are what countNonFinite reports). Exact: the percentile comes from nth_element on a scratch
// copy of the strains, so this allocates; it is for measuring, never for the step.
StrainDistribution measureStrainDistribution(const StretchConstraints& constraints,
                                             std::span<const Vec3> x);

// Nearest-rank percentile of `values` for fraction q in (0, 1]: the value of rank ⌈q n⌉ in
// ascending order, i.e. the smallest value that at least a fraction q of them do not exceed.
// Reorders `values`; 0 when empty.
double nearestRankPercentile(std::vector<double>& values, double q);

// Largest (d − d_rest)/d_rest over the tethers (particles[c] = {free vertex, pin}); 0 when the
// pool is empty or no tether is longer than its rest distance (a tether only limits from above).
double maxTetherViolation(const TetherConstraints& tethers, std::span<const Vec3> x);

double kineticEnergy(const ParticlePool& particles);  // Σ ½ m |v|² over free particles
double potentialEnergy(const ParticlePool& particles, const Vec3& gravity);  // Σ −m g·x
std::size_t countNonFinite(const ParticlePool& particles);  // non-finite x or v components

// Volume enclosed by a closed, consistently oriented triangle surface (divergence theorem:
// V = Σ (a · (b × c)) / 6). Indices are offset by `first` into x.
double enclosedVolume(std::span<const std::array<Index, 3>> surface, std::span<const Vec3> x,
                      Index first);

// 64-bit FNV-1a over the bytes of every position and velocity.
std::uint64_t hashState(const ParticlePool& particles);

}  // namespace nucleon
