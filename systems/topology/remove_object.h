// Removing an object between steps (World::removeObject). The pools index particles and objects
// directly (a sweep reads pool.particles[c] into the particle pool), so removal compacts them:
// the object's particle range and its entry in the object table are taken out, every index past
// them moves down, and whatever named the object goes with it. The tables derived from the
// topology (colouring, incidence, levels, collision primitives, the sweep plan) are rebuilt
// afterwards, as after a tear.
#pragma once

#include <cstdint>
#include <vector>

#include "components/constraint_pools.h"
#include "components/kinematic_tracks.h"
#include "components/objects.h"
#include "components/particles.h"
#include "systems/setup/build_collision_primitives.h"

namespace nucleon {

// What is removed: object `object` of the object table and its particles
// [firstParticle, firstParticle + particleCount) (a tearable cloth's spare particles included).
struct ObjectRemoval {
  Index object = 0;
  Index firstParticle = 0;
  Index particleCount = 0;

  bool removesParticle(Index i) const {
    return i >= firstParticle && i - firstParticle < particleCount;
  }
  // A surviving particle's index after the removal.
  Index particle(Index i) const { return i < firstParticle ? i : i - particleCount; }
  // A surviving object's index after the removal.
  Index objectIndex(Index o) const { return o < object ? o : o - 1; }
};

// The particle pool without the object's range; phases past the object move down.
void removeParticles(ParticlePool& particles, const ObjectRemoval& removal);

// Every constraint on one of the removed particles leaves its pool (built-in, registered, rigid
// clusters, liquids) and the others are renumbered. Attachments keep their rows, so that the
// indices World::addAttachment returned stay valid: one that touched the object is marked
// removed, as World::removeAttachment does. Pressured surfaces are rebuilt from `objects` (the
// object table after the removal) and keep their gas. Returns the attachments it marked.
std::size_t removeObjectConstraints(ConstraintPools& pools,
                                    const std::vector<ObjectRecord>& objects,
                                    const ObjectRemoval& removal);

// The object's kinematic tracks leave; the others are renumbered and keep their targets.
void removeObjectTracks(KinematicTracks& kinematics, const ObjectRemoval& removal);

// Exclusions that named the object leave; vertex sets lose its particles (a rule left with an
// empty side leaves too).
void removeObjectExclusions(std::vector<std::uint64_t>& excludedObjectPairs,
                            std::vector<VertexSetExclusion>& excludedVertexSets,
                            const ObjectRemoval& removal);

}  // namespace nucleon
