// The multigrid backend's coarse-to-fine cascade (hierarchical position based dynamics, Müller
// 2008 §4; ARCHITECTURE.md §3): before the fine sweeps of a substep, each inextensible or
// strain-limited (Material::stretchLimit) object's coarser levels are swept as unilateral
// distance limits, coarsest first, and every level's particles that are not on the next coarser
// one follow their parents' total displacement since the cascade began. Long-range stretch then
// travels across the object in a few coarse sweeps instead of one ring per fine sweep; the fine
// sweeps (colored Gauss–Seidel, every family, contacts) then work on a nearly converged shape.
#pragma once

#include <span>
#include <vector>

#include "components/collider_pool.h"
#include "components/contact_pool.h"
#include "components/level_hierarchy.h"
#include "components/objects.h"
#include "components/particles.h"
#include "components/primitive_contact_pool.h"
#include "nucleon/types.h"

namespace nucleon {

// Runs the cascade on particles.p for every hierarchy of at least two levels whose object is
// inextensible (stretch compliance 0) or strain-limited (Material::stretchLimit: its coarse limits
// are 1 + the limit times their rest lengths; a soft object's limits at rest length would stiffen
// it), with sweepsOfLevel(sweepsPerLevel, l) sweeps of coarse level l. Colors of a level run in
// sequence, the edges of a color in parallel (no two share a particle), prolongation in parallel
// per particle (on the calling thread after a level small enough to be swept there): the result
// does not depend on the thread count. While the substep has contacts, the hook is called with
// the level's particles resting on a sphere collider (where there are any and the level has
// several sweeps) before the level's sweeps as `hook(context, onSphere, BeforeSweeps)` and
// between two of them as `hook(context, onSphere, BetweenSweeps)`, after the sweeps of every level
// as `hook(context, level.particles, AfterLevel)`, and after the last prolongation as
// `hook(context, {}, AfterCascade)` (every particle): the solve projects its contacts there, as it
// does after every fine sweep round, so that a particle the cascade pulls toward a collider is held
// by its contact instead of being carried into it. A level's sweeps move only its own particles,
// and prolongation then overwrites every other particle that moves, so the hook needs to settle
// only the level's particles (the solve settles all of them after a level while there are primitive
// contacts, whose projection moves particles of any level; between sweeps it projects the level's
// collider contacts only). A level particle resting on a static mesh is put back onto that
// contact's plane between sweeps by the cascade itself. `contacts` are the substep's contacts (none
// by default). Prolongation leaves a particle with primitive contacts where its contacts put it. A
// coarse edge whose two particles are held bent, by a sphere collider or by a primitive contact
// with a particle of inverse mass 0 at rest (a static mesh collider), is swept with a limit that
// sees the stretch of a curved patch (the chord its path would have at rest length, when that is
// shorter than the rest distance); one whose two particles rest on the same sphere or static mesh
// where it curves away between them, with at most the chord of an arc of rest length turning as the
// surface's normals turn; the others with their rest distance; `scratch` holds those limits and the
// cascade's start positions. Every coarse step is over-relaxed by `relaxation` (ω in [1, 2):
// SolverSettings::cascadeRelaxation). Returns the coarse-edge projections and tether projections
// performed.
enum class CascadeMoment { BeforeSweeps, BetweenSweeps, AfterLevel, AfterCascade };
using CascadeHook = void (*)(void* context, std::span<const Index> moved, CascadeMoment moment);

// The substep's contacts as the cascade reads them; a null or empty pool is none.
struct CascadeContacts {
  const ContactPool* colliderContacts = nullptr;  // with `colliders`, which they index
  const ColliderPool* colliders = nullptr;
  const PrimitiveContactPool* primitiveContacts = nullptr;
};

// The sweeps of coarse level l ≥ 1: sweepsPerLevel[l − 1], or its last value beyond the list; 0
// for an empty list. A 0 for level 1 turns the cascade off.
int sweepsOfLevel(std::span<const int> sweepsPerLevel, std::size_t level);
std::size_t runMultigridCascade(const LevelHierarchies& hierarchies,
                                std::span<const ObjectRecord> objects, ParticlePool& particles,
                                CascadeScratch& scratch, std::span<const int> sweepsPerLevel,
                                CascadeHook afterLevel = nullptr, void* context = nullptr,
                                const CascadeContacts& contacts = {}, Real relaxation = 1);

// The coarse-edge projections one cascade performs (for throughput and work figures).
std::size_t cascadeProjections(const LevelHierarchies& hierarchies,
                               std::span<const ObjectRecord> objects,
                               std::span<const int> sweepsPerLevel);

}  // namespace nucleon
