// Tearing of cloth (Material::tear; ARCHITECTURE.md §2, "Tearing"): between steps, edges that
// stayed over-stretched long enough split the cloth at one of their vertices, which takes a spare
// particle reserved for it when the cloth was made, so that every object keeps one contiguous
// range of particles.
#pragma once

#include <cstddef>
#include <vector>

#include "components/collision_primitives.h"
#include "components/constraint_pools.h"
#include "components/objects.h"
#include "components/particles.h"
#include "nucleon/material.h"
#include "nucleon/statistics.h"

namespace nucleon {

// The spare particles a tearable cloth of `vertexCount` vertices reserves (Tear::maxNewVertices).
Index tearSpareParticles(const Tear& tear, std::size_t vertexCount);

// After a step of dt seconds: advances every tearable cloth's clock of each over-stretched edge
// and splits the cloth at the edges whose clock reached Tear::time, strongest strain first (then
// edge order: the same splits at any thread count). A vertex splits at most once per call, and the
// edges of a vertex already split in this call wait for the next. Each split gives the vertex's
// triangles on the far side (from the edge's other end) of the plane through it perpendicular to
// the edge to a new copy, shares its mass by the triangles' rest areas and keeps the velocity;
// the object's complex, surface and constraints in `pools` (tethers included, from the new
// complex) are then rebuilt. Returns whether any cloth changed: the derived tables (colouring,
// incidence, levels, collision primitives, sweep plan) must then be rebuilt, and the broad
// phase's carried pairs dropped.
bool tearCloths(std::vector<ObjectRecord>& objects, ParticlePool& particles, ConstraintPools& pools,
                double dt, TearReport& report);

// The constraints of a torn cloth (object number `object`) again, from its complex as it is now:
// its old ones leave the built-in pools and the new ones are appended (a tear, or a checkpoint
// restoring a torn cloth). Its particles at inverse mass 0 are held, as pins are.
void rebuildTornConstraints(const ObjectRecord& record, std::uint32_t object,
                            const ParticlePool& particles, ConstraintPools& pools);

// Marks the torn vertices that now stand farther than their contact distance from every other
// copy of the same original (TearState::opened), and enters them into
// primitives.particleOrigin, so that from the next step pairs across the cut collide.
void openTornLips(std::vector<ObjectRecord>& objects, const ParticlePool& particles,
                  CollisionPrimitives& primitives);

}  // namespace nucleon
