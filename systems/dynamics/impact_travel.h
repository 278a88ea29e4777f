// How far the free particles of meshes and curves that may strike a collider travel in a step,
// in their own edge lengths: the measure behind the substeps raised for fast impacts
// (SolverSettings::maxImpactTravel).
#pragma once

#include <span>
#include <vector>

#include "components/collider_pool.h"
#include "components/objects.h"
#include "components/particles.h"

namespace nucleon {

// What impactTravelRatio works in, kept from step to step so that a step allocates nothing once
// the capacities have grown: the travels of one object's free particles, and the boxes of the
// mesh colliders' vertices with the colliders' thicknesses.
struct ImpactTravelScratch {
  struct ColliderBox {
    Vec3d lower, upper;
    double thickness;
  };
  std::vector<double> travels;
  std::vector<ColliderBox> boxes;
};

// Per object, the median rest length of its edges (a grid's diagonals and a degenerate edge do
// not move it); 0 for a collider and for an object without edges.
std::vector<double> medianEdgeLengths(const std::vector<ObjectRecord>& objects,
                                      const ParticlePool& particles);

// The median travel |v| dt of the free particles of an object with edges that may strike a
// collider within the step, divided by its limit (the largest such ratio over the objects):
// `fixedLimit` metres if positive, else `share` times the object's median edge length. An object
// may strike one when any of its free particles is within its own travel plus the contact
// distance (the object's thickness plus the collider's, plus `colliderTravel`, the farthest a
// collider moves in the step) of a plane, a sphere or the box of a mesh collider's vertices.
// The median, because the stretch comes from the bulk of the object going on while a collider
// stops part of it (a sheet falling onto a post at 8 m/s); a free fall with nothing near raises
// nothing. Non-finite velocities count as no travel. Ratios at or below `floor` (the caller's
// substeps: they raise nothing) are not computed: the result is then `floor`.
double impactTravelRatio(const std::vector<ObjectRecord>& objects,
                         std::span<const double> edgeLength, const ParticlePool& particles,
                         const ColliderPool& colliders, double fixedLimit, double share, double dt,
                         double colliderTravel, double floor, ImpactTravelScratch& scratch);

}  // namespace nucleon
