// Particles supported by a kinematic body, made heavier in the colored sweeps of two-particle
// constraints (colored-gs, and multigrid's colored smoother); SolverSettings::
// supportedInverseMassScale sets by how much (default 0.1; 1 turns it off).
//
// A cloth draped over a body hangs its skirt from the few particles its contacts hold (a box's
// corner, a table's edge). A Gauss–Seidel projection of an edge between a supported particle and a
// free one hanging below it moves both by their inverse masses, so half of each correction pushes
// the supported particle into the body, and the contacts undo that half between sweep rounds: the
// weight reaches the support at half the rate per sweep, through every edge of the chain, and ten
// sweeps leave the edges by the support stretched (a 128² sheet on a turning box: edges beyond 3
// times their length). In a two-particle constraint between a supported particle and a free one
// (unless it rises from it: kRisingCosine), the supported end's inverse mass is scaled by k < 1, so
// the projection moves the free particle instead, as mass scaling does for stacks (Macklin et al.
// 2014, "Unified particle physics for real-time applications"; the shock propagation of Guendelman
// et al. 2003). Both ends are then rescaled to keep their sum, which the compliance is weighed
// against: a spring between them is as stiff as before, a constraint between two supported
// particles is untouched, and a constraint met before is met after; what changes is where a
// correction goes, so such a projection does not conserve momentum between the two, and a
// frictionless contact supports nothing.
//
// Only contacts against a kinematic body's primitives (a collider mesh, a pinned group) support:
// that is where sharp features hold a skirt. The analytic colliders are left out. On a sphere
// the multigrid cascade already keeps its coarse particles on the support and carries the weight,
// and weighing left a 128² drape more stretched (mean strain 1.56% → 1.77%). On a plane or the
// ground nothing hangs, and weighing only made the particles that had struck it hold back those
// still sliding (high_drop's worst frame 1.12 → 1.75, wall_slam's 1.38 → 1.65). Measurements:
// bench/results/2core-AMD-EPYC/torture.md, "Supported particles weighed by default".
#pragma once

#include "components/constraint_pools.h"
#include "components/contact_pool.h"
#include "components/particles.h"
#include "components/primitive_contact_pool.h"

namespace nucleon {

// A free neighbour rises from a supported particle when the edge between them points out of the
// support's tangent plane, away from the support, by more than this cosine (about 17°): a
// particle that has just struck the support, its neighbours still falling onto it. Such an edge
// is left unweighed: weighed, the struck particles held back the sliding ones as a friction the
// contact does not have, and a sheet whose corner struck the ground stretched an edge to 3.2
// times its length.
inline constexpr Real kRisingCosine = Real(0.3);

// Finds the particles supported this substep (a contact with friction that has pressed, λ > 0,
// against primitives of a kinematic body: particles of inverse mass 0; contacts within reach that
// have not pressed, and contacts with the analytic colliders, support nothing) and reweighs the
// ends of the two-particle constraints on them in the pools' endInverseMass, which the colored
// sweeps read (their batches always, their generic projections while SweepContext::weighedEnds is
// set); with scale = 1 it does nothing. Returns how many particles are supported. The
// particle pool keeps every inverse mass as it is: contacts and the cascade read that.
std::size_t weighSupportedParticles(ConstraintPools& constraints, ContactPool& contacts,
                                    const PrimitiveContactPool& primitiveContacts,
                                    const ParticlePool& particles, Real scale);

// Gives the supported particles' entries their inverse masses back, and empties the supported list.
void releaseSupportedParticles(ConstraintPools& constraints, ContactPool& contacts,
                               const ParticlePool& particles);

}  // namespace nucleon
