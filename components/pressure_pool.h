// Pressured surfaces (Material::pressure): one record per closed cloth object with pressure, its
// triangles and the incidence that gives each of its vertices the gradient of the enclosed
// volume. Static lifetime (appended when the object is added) apart from the gas amount, which
// the solve carries from substep to substep, and the multiplier, which lives for one substep.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "nucleon/material.h"
#include "nucleon/types.h"

namespace nucleon {

// Surface vertices (and triangles) per block of the volume's parallel passes.
constexpr std::size_t kPressureBlock = 1024;
// The least volume, as a share of the rest volume, at which a gas's pressure is evaluated, and
// the largest change of volume one projection of a gas may ask for, as a share of the volume it
// has (systems/solver/pressure.cpp, the damped Newton step).
constexpr double kMinPressureVolume = 0.01;
constexpr double kMaxPressureStep = 0.5;

struct PressurePool {
  // Per surface.
  std::vector<std::uint32_t> object;  // the object's index in the object table
  std::vector<Pressure> settings;     // the material's pressure block
  std::vector<double> restVolume;     // m³, enclosed in the rest shape
  std::vector<double> gas;            // c·M (Pa·m³), Gas mode
  std::vector<double> lambda;         // the volume constraint's multiplier this substep (Pa·s²)
  // The surface's vertices (global particle indices) are vertices[vertexBegin[s] …
  // vertexBegin[s + 1]) and its triangles triangles[triangleBegin[s] … triangleBegin[s + 1]).
  // Vertex k's triangles are incident[incidentBegin[k] … incidentBegin[k + 1]] (indices into
  // `triangles`): ∂V/∂x_k is a third of the sum of their area vectors ½ (x_b − x_a) × (x_c − x_a)
  // (the one-ring's other terms telescope away on a closed surface), and the volume is
  // Σ_k x_k · ∂V/∂x_k / 3.
  std::vector<Index> vertexBegin{0};
  std::vector<Index> vertices;
  std::vector<Index> triangleBegin{0};
  std::vector<std::array<Index, 3>> triangles;
  std::vector<Index> incidentBegin{0};
  std::vector<Index> incident;
  std::vector<Vec3d> areaVector;  // scratch: per triangle
  std::vector<Vec3d> gradient;    // scratch: ∂V/∂x_k of every surface vertex
  // Scratch: per block of kPressureBlock surface vertices, its share of 3V and of Σ w |∂V/∂x|²,
  // summed in block order so the sums do not depend on the thread count.
  std::vector<std::array<double, 2>> blockSums;
  // Projections whose surface enclosed less than kMinPressureVolume of its rest volume (or was
  // turned inside out): the gas pressure was taken at that volume. Read and cleared by the
  // solve's report.
  std::uint64_t collapsedProjections = 0;
  // Gas steps held to kMaxPressureStep of the volume (the damped Newton step). Read and cleared
  // likewise.
  std::uint64_t limitedSteps = 0;

  std::size_t size() const { return object.size(); }
};

}  // namespace nucleon
