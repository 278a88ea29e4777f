// Quality measures of a state (ARCHITECTURE.md §6): strain, energy, finiteness, volume, a state hash.
// Pure functions of the pools, used by the stats output, tests and benchmarks.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "components/constraint_pool.h"
#include "components/particles.h"

namespace nucleon {

struct StrainStats {
  double max = 0;   // max |L/L0 − 1|
  double mean = 0;  // mean |L/L0 − 1|
};
// Constraints with a zero rest length are skipped (their strain is undefined).
StrainStats measureStrain(const StretchConstraints& constraints, std::span<const Vec3> x);

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
