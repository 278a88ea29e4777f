// The collision geometry of every object as primitive lists, in structure of arrays: points are
// spheres, edges capsules and triangles slabs, each with the radius (half-width) of its object's
// collision thickness. Static lifetime: built with the derived tables when the topology changes;
// the positions are read from the particle pool (x at the start of a substep, p at its end).
//
// Which primitives an object contributes follows its collision flags (vertices, edges, faces, as
// in the original's nCloth settings) and its kind: cloth gives its vertices, edges and triangles;
// a rope its vertices and edges; a solid the vertices, edges and triangles of its boundary; a
// particle object its points; a collider mesh its vertices, edges and triangles. A point no
// colliding edge of its object uses is `isolated`: only isolated points need point–edge and
// point–point pairs, since the edges of every other point already carry those contacts.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <span>
#include <vector>

#include "nucleon/types.h"

namespace nucleon {

enum CollisionFlags : std::uint8_t {
  kCollideVertices = 1u << 0,
  kCollideEdges = 1u << 1,
  kCollideFaces = 1u << 2,
  kCollideAll = kCollideVertices | kCollideEdges | kCollideFaces,
};

// An object's contact coefficients (nucleon/material.h).
struct ObjectSurface {
  Real friction = 0, staticFriction = 0, restitution = 0, stickiness = 0;
};

struct CollisionPrimitives {
  // Points.
  std::vector<Index> pointParticle;
  std::vector<Real> pointRadius;
  std::vector<std::uint32_t> pointObject;
  std::vector<std::uint8_t> pointIsolated;  // 1 if no edge of its object uses the point
  // Edges: two particle indices, ascending.
  std::vector<std::array<Index, 2>> edgeParticles;
  std::vector<Real> edgeRadius;
  std::vector<std::uint32_t> edgeObject;
  // Triangles: three particle indices in the object's orientation.
  std::vector<std::array<Index, 3>> triangleParticles;
  std::vector<Real> triangleRadius;
  std::vector<std::uint32_t> triangleObject;

  // A triangle of the same object that contains each point and each edge (kNoTriangle where
  // none does): the frame whose rigid motion the fail-safe carries particles by when a
  // kinematic point or edge meets them (primitive_contacts.h).
  static constexpr Index kNoTriangle = ~Index{0};
  std::vector<Index> pointTriangle;
  std::vector<Index> edgeTriangle;
  // Which of its boundary features each triangle owns: bit k (k = 0..2) its vertex k, bit 3 + k
  // its edge from vertex k to vertex k + 1 (mod 3). The lowest-numbered triangle containing a
  // feature owns it. A point meets the features of a mesh once: a vertex–face pair whose closest
  // point lies on a vertex or edge that its triangle does not own is the owner's pair again, and
  // makes no contact (primitive_contacts.h, "One contact per feature"). Empty: every triangle owns
  // all of its features.
  std::vector<std::uint8_t> triangleOwnership;
  // Per object: the CollisionFlags it collides with (empty: all).
  std::vector<std::uint8_t> objectFlags;
  // Per object: the coefficients its contacts mix (friction, restitution, stickiness).
  std::vector<ObjectSurface> objectSurface;

  // Object pairs that never collide, as (min << 32 | max), sorted; (a, a) turns off the
  // self-collision of object a.
  std::vector<std::uint64_t> excludedPairs;

  std::size_t points() const { return pointParticle.size(); }
  std::size_t edges() const { return edgeParticles.size(); }
  std::size_t triangles() const { return triangleParticles.size(); }
  std::size_t total() const { return points() + edges() + triangles(); }
  // The smallest radius of any primitive (0 if there is none): set with the lists, so that the
  // broad phase's bounds need no pass over them.
  Real smallestRadius = 0;

  static std::uint64_t pairKey(std::uint32_t a, std::uint32_t b) {
    return a < b ? (std::uint64_t{a} << 32 | b) : (std::uint64_t{b} << 32 | a);
  }
  bool excluded(std::uint32_t objectA, std::uint32_t objectB) const {
    return std::binary_search(excludedPairs.begin(), excludedPairs.end(),
                              pairKey(objectA, objectB));
  }

  // Vertex sets that never collide with each other (World::excludeCollisions with vertex lists):
  // per particle, the mask of the sets it is in (empty when there are none), and per set the
  // mask of the sets it never meets. A primitive is in a set when all of its particles are.
  std::vector<std::uint32_t> particleSets;
  std::array<std::uint32_t, 32> setExclusions{};

  // Torn cloth (TearState): per particle, the particle of the untorn cloth it descends from, for
  // the vertices of a cut whose lips have opened; kNoOrigin for every other (empty when no lip
  // has opened). Two primitives holding different particles of one origin lie across a cut:
  // coincident in the rest shape, yet free to collide.
  static constexpr Index kNoOrigin = ~Index{0};
  std::vector<Index> particleOrigin;
  bool acrossCut(std::span<const Index> a, std::span<const Index> b) const {
    if (particleOrigin.empty()) return false;
    for (Index i : a)
      for (Index j : b)
        if (i != j && particleOrigin[i] != kNoOrigin && particleOrigin[i] == particleOrigin[j])
          return true;
    return false;
  }
  bool setsExcluded(std::span<const Index> a, std::span<const Index> b) const {
    std::uint32_t maskA = ~0u, maskB = ~0u;
    for (Index i : a) maskA &= particleSets[i];
    for (Index j : b) maskB &= particleSets[j];
    for (std::uint32_t bits = maskA; bits != 0; bits &= bits - 1)
      if (setExclusions[static_cast<std::size_t>(std::countr_zero(bits))] & maskB) return true;
    return false;
  }
  void clear() {
    pointParticle.clear(), pointRadius.clear(), pointObject.clear(), pointIsolated.clear();
    edgeParticles.clear(), edgeRadius.clear(), edgeObject.clear();
    pointTriangle.clear(), edgeTriangle.clear(), triangleOwnership.clear(), objectFlags.clear();
    triangleParticles.clear(), triangleRadius.clear(), triangleObject.clear();
    objectSurface.clear(), excludedPairs.clear(), particleSets.clear();
    particleOrigin.clear();
    setExclusions.fill(0);
    smallestRadius = 0;
  }
};

}  // namespace nucleon
