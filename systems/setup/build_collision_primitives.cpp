#include "systems/setup/build_collision_primitives.h"

#include <algorithm>
#include <limits>
#include <map>
#include <set>

namespace nucleon {
namespace {

void addPoint(CollisionPrimitives& out, Index particle, Real radius, std::uint32_t object,
              bool isolated) {
  out.pointParticle.push_back(particle);
  out.pointRadius.push_back(radius);
  out.pointObject.push_back(object);
  out.pointIsolated.push_back(isolated ? 1 : 0);
}

}  // namespace

void buildCollisionPrimitives(CollisionPrimitives& out, const std::vector<ObjectRecord>& objects,
                              const std::vector<std::uint64_t>& excludedObjectPairs,
                              const std::vector<VertexSetExclusion>& excludedVertexSets,
                              std::size_t particleCount) {
  out.clear();
  if (!excludedVertexSets.empty()) {
    out.particleSets.assign(particleCount, 0);
    for (std::size_t r = 0; r < excludedVertexSets.size() && r < 16; ++r) {
      const std::uint32_t a = 2 * static_cast<std::uint32_t>(r), b = a + 1;
      for (Index i : excludedVertexSets[r].a) out.particleSets[i] |= 1u << a;
      for (Index i : excludedVertexSets[r].b) out.particleSets[i] |= 1u << b;
      out.setExclusions[a] |= 1u << b;
      out.setExclusions[b] |= 1u << a;
    }
  }
  out.excludedPairs = excludedObjectPairs;
  for (std::uint32_t o = 0; o < objects.size(); ++o)
    if (!objects[o].material.selfCollision)
      out.excludedPairs.push_back(CollisionPrimitives::pairKey(o, o));
  // Liquids meet each other through their density constraints, not as colliding points.
  for (std::uint32_t a = 0; a < objects.size(); ++a)
    for (std::uint32_t b = a; b < objects.size(); ++b)
      if (objects[a].material.liquid.enabled && objects[b].material.liquid.enabled)
        out.excludedPairs.push_back(CollisionPrimitives::pairKey(a, b));
  std::sort(out.excludedPairs.begin(), out.excludedPairs.end());
  out.excludedPairs.erase(std::unique(out.excludedPairs.begin(), out.excludedPairs.end()),
                          out.excludedPairs.end());
  // An object that can meet nothing (alone with its self-collision off, or a collider among
  // colliders, which never respond to each other) contributes no primitives, so that a world
  // without possible collisions pays nothing for them.
  auto canCollide = [&](std::uint32_t a, std::uint32_t b) {
    if (out.excluded(a, b)) return false;
    return objects[a].kind != ObjectKind::Collider || objects[b].kind != ObjectKind::Collider;
  };
  for (std::uint32_t o = 0; o < objects.size(); ++o) {
    const ObjectRecord& record = objects[o];
    const Material& m = record.material;
    const Index first = record.firstParticle;
    const Real radius = m.thickness;
    // A liquid's adhesion is the stickiness of its contacts.
    const Real stickiness =
        m.liquid.enabled ? std::max(m.stickiness, m.liquid.adhesion) : m.stickiness;
    out.objectSurface.push_back({m.friction, m.staticFriction, m.restitution, stickiness});
    out.objectFlags.push_back(static_cast<std::uint8_t>((m.collideVertices ? kCollideVertices : 0) |
                                                        (m.collideEdges ? kCollideEdges : 0) |
                                                        (m.collideFaces ? kCollideFaces : 0)));
    bool meetsAnything = false;
    for (std::uint32_t other = 0; other < objects.size() && !meetsAnything; ++other)
      meetsAnything = canCollide(o, other);
    if (!meetsAnything) continue;

    // The simplices that bound the object: a solid collides through its boundary surface only,
    // everything else through all of its simplices.
    std::vector<std::array<Index, 2>> edges;
    std::vector<std::array<Index, 3>> triangles;
    std::vector<std::uint8_t> onSurface(record.particleCount, 0);
    if (record.kind == ObjectKind::Solid) {
      triangles = record.surface;
      std::set<std::array<Index, 2>> unique;
      for (const auto& t : triangles)
        for (int k = 0; k < 3; ++k) {
          const Index a = t[k], b = t[(k + 1) % 3];
          unique.insert({std::min(a, b), std::max(a, b)});
        }
      edges.assign(unique.begin(), unique.end());
    } else {
      triangles.assign(record.complex.triangles.vertices.begin(),
                       record.complex.triangles.vertices.end());
      for (const auto& e : record.complex.edges.vertices)
        edges.push_back({std::min(e[0], e[1]), std::max(e[0], e[1])});
    }
    std::vector<std::uint8_t> inEdge(record.particleCount, 0);
    // A point is isolated when no colliding edge carries its contacts.
    if (m.collideEdges)
      for (const auto& e : edges) inEdge[e[0]] = inEdge[e[1]] = 1;
    for (const auto& t : triangles)
      for (Index v : t) onSurface[v] = 1;
    for (const auto& e : edges) onSurface[e[0]] = onSurface[e[1]] = 1;

    // The first colliding triangle of the object that contains each vertex and edge, by the
    // primitives' numbering (none when the object's faces do not collide).
    const Index firstTriangle = static_cast<Index>(out.triangles());
    std::vector<Index> vertexTriangle(record.particleCount, CollisionPrimitives::kNoTriangle);
    std::map<std::array<Index, 2>, Index> edgeTriangle;
    if (m.collideFaces)
      for (Index t = static_cast<Index>(triangles.size()); t-- > 0;)
        for (int k = 0; k < 3; ++k) {
          const Index a = triangles[t][k], b = triangles[t][(k + 1) % 3];
          vertexTriangle[a] = firstTriangle + t;
          edgeTriangle[{std::min(a, b), std::max(a, b)}] = firstTriangle + t;
        }
    if (m.collideVertices)
      for (Index v = 0; v < record.particleCount; ++v) {
        // Interior vertices of a solid never reach another object before its surface does.
        if (record.kind == ObjectKind::Solid && !onSurface[v]) continue;
        addPoint(out, first + v, radius, o, !inEdge[v]);
        out.pointTriangle.push_back(vertexTriangle[v]);
      }
    if (m.collideEdges)
      for (const auto& e : edges) {
        out.edgeParticles.push_back({first + e[0], first + e[1]});
        out.edgeRadius.push_back(radius);
        out.edgeObject.push_back(o);
        const auto found = edgeTriangle.find(e);
        out.edgeTriangle.push_back(found == edgeTriangle.end() ? CollisionPrimitives::kNoTriangle
                                                               : found->second);
      }
    if (m.collideFaces)
      for (Index t = 0; t < static_cast<Index>(triangles.size()); ++t) {
        const auto& vertices = triangles[t];
        std::uint8_t owns = 0;
        for (int k = 0; k < 3; ++k) {
          const Index a = vertices[k], b = vertices[(k + 1) % 3];
          if (vertexTriangle[a] == firstTriangle + t) owns |= std::uint8_t(1u << k);
          if (edgeTriangle.at({std::min(a, b), std::max(a, b)}) == firstTriangle + t)
            owns |= std::uint8_t(1u << (3 + k));
        }
        out.triangleOwnership.push_back(owns);
        out.triangleParticles.push_back(
            {first + vertices[0], first + vertices[1], first + vertices[2]});
        out.triangleRadius.push_back(radius);
        out.triangleObject.push_back(o);
      }
  }
  // The opened lips of torn cloths (TearState::opened), by the particle they descend from.
  for (const ObjectRecord& record : objects) {
    const TearState& tear = record.tear;
    for (Index v = 0; v < tear.opened.size() && v < tear.origin.size(); ++v) {
      if (!tear.opened[v] || record.firstParticle + v >= particleCount) continue;
      if (out.particleOrigin.empty()) out.particleOrigin.assign(particleCount, out.kNoOrigin);
      out.particleOrigin[record.firstParticle + v] = record.firstParticle + tear.origin[v];
    }
  }
  Real smallest = std::numeric_limits<Real>::infinity();
  for (const auto* radii : {&out.pointRadius, &out.edgeRadius, &out.triangleRadius})
    for (Real r : *radii) smallest = std::min(smallest, r);
  out.smallestRadius = out.total() > 0 ? smallest : Real(0);
}

}  // namespace nucleon