// Shape matching clusters (Material::rigidity; Müller et al. 2005): one cluster per object with
// rigidity, its particles, their masses and their rest offsets from the cluster's rest centre of
// mass. Static lifetime (appended when the object is added).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "nucleon/types.h"

namespace nucleon {

// Cluster particles per block of the cluster's parallel sums.
constexpr std::size_t kShapeMatchBlock = 1024;

struct ShapeMatchPool {
  // Per cluster.
  std::vector<std::uint32_t> object;  // the object's index in the object table
  std::vector<Real> rigidity;         // the material's rigidity in (0, 1]
  std::vector<double> mass;           // kg, the cluster's total
  // Particle k of cluster c is particles[particleBegin[c] + k], mass masses[…], rest offset
  // rest[…] from the rest centre of mass (Σ m r = 0).
  std::vector<Index> particleBegin{0};
  std::vector<Index> particles;
  std::vector<double> masses;
  std::vector<Vec3d> rest;
  // Scratch: per block of kShapeMatchBlock particles, its Σ m p (3) and Σ m p rᵀ (9), summed in
  // block order so the sums do not depend on the thread count.
  std::vector<std::array<double, 12>> blockSums;

  std::size_t size() const { return object.size(); }
};

}  // namespace nucleon
