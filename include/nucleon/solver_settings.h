// Which backend solves the constraints, and how many substeps and sweeps it takes.
#pragma once

#include <string>
#include <vector>

#include "nucleon/schedule.h"
#include "nucleon/types.h"

namespace nucleon {

enum class SolverKind { GaussSeidel, Jacobi, ColoredGaussSeidel, Multigrid };
const char* toString(SolverKind kind);
// Parses "gauss-seidel", "jacobi", "colored-gs", "multigrid"; returns false on anything else.
bool parseSolverKind(const std::string& name, SolverKind& out);

struct SolverSettings {
  // Gauss–Seidel here, the one backend every constraint family, registered ones included, is
  // converged by; a scene file's default is multigrid (Scene::solver), whose coarse levels do not
  // see registered families (World::warnings says so where both meet).
  SolverKind kind = SolverKind::GaussSeidel;
  int iterations = 10;  // sweeps per substep of every family, when `schedule` is empty
  int substeps = 1;     // substeps per step(dt)
  // Substeps raised for fast animation (ARCHITECTURE.md §2): a step takes as many substeps as it
  // needs for no kinematic particle (of a collider, animated, moved by targets or by a velocity,
  // or of an animated pin group) to travel farther than
  // `maxKinematicTravel` metres in one of them, `substeps` at the least and `maxSubsteps` at the
  // most. A blade or a box that moves several contact distances in a substep outruns the
  // contacts and the sweeps that propagate its push: the cloth is caught and stretched; a flag
  // whipped by its pinned edge folds through itself.
  // Negative (the default): kKinematicTravelShare of the smallest contact distance between a
  // collider's or a pinned object's primitives and the primitives that move; 0: never raised.
  Real maxKinematicTravel = -1;
  // Substeps raised for fast impacts: a step takes as many substeps as it needs for the median
  // free particle of a mesh or curve to travel at most `maxImpactTravel` metres in one of them
  // while any free particle of it may reach a collider within the step (within its travel and
  // the contact distance of a plane, a sphere or a mesh collider's box), with `substeps` and
  // `maxSubsteps` as above. A sheet striking a post at several edge lengths per substep has its
  // struck particles stopped while the bulk of it goes on: its edges stretch to several times
  // their length before the sweeps can pull them back. Negative (the default):
  // kImpactTravelShare of each object's median edge length; 0: never raised.
  Real maxImpactTravel = -1;
  // The most substeps a step may be raised to (1–10000); 0 (the default): 8 × substeps, and at
  // least 16. Steps that would need more take this many, and are counted.
  int maxSubsteps = 0;
  // Jacobi relaxation γ in (0, 2): the plain step moves each particle by γ times the average of
  // its constraints' corrections, before the Chebyshev acceleration scales it (ARCHITECTURE.md
  // §3, jacobi). Ignored by the Gauss–Seidel backends.
  Real relaxation = 1;
  // Jacobi's γ in (0, 2) for the particles of an inextensible sheet or solid: those with at
  // least three constraints in a pool of hard, undamped distance constraints, which the
  // vertex-centric sweep takes (ARCHITECTURE.md §3, jacobi). Averaging n_i ≥ 3 corrections in
  // different directions moves a particle a fraction of what an ordered sweep would, and
  // over-relaxing recovers part of it (successive over-relaxation of averaged constraints,
  // Macklin et al. 2014, "Unified Particle Physics for Real-Time Applications"). The particles
  // of chains keep `relaxation`: over-relaxed, a swinging rope gains energy.
  Real sheetRelaxation = Real(1.7);
  // Colored-gs and multigrid's colored smoother (their batches): the factor k ∈ [0.001, 1] on
  // the inverse mass of a particle that a pressed, frictional contact with a kinematic body's
  // primitives (a collider mesh, a pinned group) supports, in its two-particle constraints with
  // free particles (those rising from its support excepted), both ends then rescaled to keep
  // their sum (systems/solver/supported_particles.h). Below 1 a drape's weight reaches its
  // support in fewer sweeps: at 0.1 a 128² sheet on a box's corners no longer stretches edges to
  // 3 times their length. 1 turns it off. Ignored by the other sweeps, by the analytic
  // colliders' contacts and by the generic projections (the double build, a CPU without AVX2).
  Real supportedInverseMassScale = Real(0.1);
  // Jacobi's Chebyshev acceleration: the estimate ρ ∈ [0, 0.9999] of the plain iteration's
  // spectral radius (0: no acceleration). Higher converges faster on a hanging cloth and
  // extrapolates harder through contacts (ARCHITECTURE.md §3, jacobi). Ignored by the others.
  Real chebyshevRho = Real(0.98);
  // Multigrid: sweeps of each coarse level in the coarse-to-fine cascade that precedes the fine
  // sweeps of every substep (ARCHITECTURE.md §3), level 1 (the finest coarse level) first; a
  // level beyond the list takes its last value. Few sweeps where a level is large, many where
  // it is small: a level has a quarter of the particles of the one below, so sixteen sweeps of
  // level 3 cost what one of level 1 does. Empty, or 0 for level 1: no cascade.
  std::vector<int> sweepsPerLevel = {1, 4, 16, 32};
  // Multigrid: the over-relaxation ω in [1, 2) of the cascade's coarse sweeps (successive
  // over-relaxation of their Gauss–Seidel sweeps: each coarse step is ω times the plain PBD
  // step). A coarse level's job is to carry a correction far in few sweeps, which
  // over-relaxation speeds up; 1 is the plain cascade. Measured (bench/results/2core-AMD-EPYC/
  // solver_speed.md §15): at 1.5 hanging cloths end with less strain at the same cost, and a
  // cloth draped on a sphere too; but the cascade does not see attachments, and over-relaxed it
  // pulls a cloth away from its handles harder (the banner of attachments.json lagged its pulled
  // handle by 15 mm instead of 6), so the default stays 1 and the fast hanging-cloth scenes
  // (cloth_hang_128_fast, cloth_hang_256_fast) set 1.5.
  Real cascadeRelaxation = 1;
  // Multigrid: the cascade also runs again after every `cascadeEvery` fine sweep rounds (0: only
  // before the first), each time from the positions the fine sweeps left.
  int cascadeEvery = 0;
  // Multigrid: the backend of its fine sweeps, colored-gs (default), jacobi or gauss-seidel (not
  // multigrid). The cascade is the same for all three (ARCHITECTURE.md §3).
  SolverKind smoother = SolverKind::ColoredGaussSeidel;
  // False: every constraint pool takes its backend's generic sweep instead of the optimised
  // paths the family table gives it (AVX2 distance batches, the vertex-centric Jacobi sweep, the
  // tethers' layered sweep), whose results equal the generic sweep's up to rounding. A reference
  // for testing those paths and registered families against the built-in ones; slower.
  bool optimizedPaths = true;
  // Per-family sweep counts and order; empty = every family `iterations` times, in the order
  // stretch, tether, shear, bend, twist, volume.
  Schedule schedule;
};

// The default travel of an animated particle per substep as a share of the smallest contact
// distance between an animated object and a moving primitive (SolverSettings::
// maxKinematicTravel). Measured on scenes of the torture suite at their 2 scene substeps: a 16 cm
// box driven through a pinned curtain at 3.2 m/s (contact distance 10 mm) ended frames with edges
// beyond 3× their rest length at 8.9 mm per substep and none at 7.6; a propeller blade striking
// a sheet at 4.4 m/s (8 mm) at 14.7 mm and none at 12.2; a flag whipped ±0.2 m by its pinned
// edge at 4 m/s (10 mm) left crossings unresolved at 8.4 mm and none at 7.4.
constexpr double kKinematicTravelShare = 0.75;

// The default travel per substep of the median free particle of an object that may strike a
// collider, as a share of the object's median edge length (SolverSettings::maxImpactTravel).
// Measured on the torture suite at its 2 scene substeps: a 64² sheet (19 mm edges) striking a
// 6 cm post at 8 m/s, 67 mm per substep, had edges beyond 3× their rest length in 5 frames, and
// none at 4 substeps (33 mm, 1.75 edges). cloth_drop_sphere (falling at up to 4 m/s onto its
// sphere, 16.7 mm per substep on 15.7 mm edges) and cloth_self (2 substeps, 20.5 mm edges) stay
// below it; cloth_sphere (1 substep, 31.7 mm edges, 4.4 m/s) takes 2 in the steps of its strike.
constexpr double kImpactTravelShare = 1.5;

// After a step raised for an impact, the next holds its count while the world's largest stretch
// strain exceeds kImpactHoldStrain, for at most kImpactHoldSteps steps after the last raise for
// travel: a crumple goes on folding after the bulk of the object has slowed down (a sheet slammed
// edge-first into a wall at 10 m/s stretched its edges to 4 times their length when the count
// fell back; held at 0.3 it is clean, and at 0.5 a sheet striking a post reached 3 times).
constexpr double kImpactHoldStrain = 0.3;
constexpr int kImpactHoldSteps = 15;

// The substeps a step of the world takes: `substeps`, raised to what `travel` (the farthest an
// animated particle goes over the step, m) needs for at most `limit` per substep (limit
// ≤ 0: never raised), and held to the settings' maximum. `capped` says whether the maximum held it.
int substepsForTravel(const SolverSettings& settings, double travel, double limit, bool& capped);

// The backend of the constraint sweeps: multigrid's smoother under multigrid, else the backend.
inline SolverKind fineSweepKind(const SolverSettings& settings) {
  return settings.kind == SolverKind::Multigrid ? settings.smoother : settings.kind;
}

}  // namespace nucleon
