// What an object is made of: mass, compliances, the families it has, collision thickness.
#pragma once

#include "nucleon/types.h"

namespace nucleon {

// Pressure of the air a closed cloth surface holds (Nucleus's pressure; ARCHITECTURE.md §2).
//   Gas: an ideal gas at constant temperature, P·V = c·M, with c·M (Pa·m³) the amount of gas
//     inside. The surface is pushed outwards by P − ambient per unit area, solved with the
//     constraints as one compliant constraint on the enclosed volume V whose force is that
//     pressure difference (its compliance at V is the gas's own, V / P). A pump adds gas, a leak
//     lets the gas above ambient out.
//   KeepVolume: V is held at volumeScale × its rest volume (an incompressible filling, or a
//     compliant one with `compliance`).
// The surface must be closed and consistently oriented (every edge shared by exactly two
// triangles that run it in opposite directions); anything else is an error naming the object.
enum class PressureMode { Off, Gas, KeepVolume };
struct Pressure {
  PressureMode mode = PressureMode::Off;
  Real ambient = Real(101325);  // Pa: the pressure outside (sea-level air)
  // Gas: the pressure above ambient at the rest volume when the object is created (Pa, ≥ 0), so
  // c·M starts at (ambient + startPressure) × rest volume.
  Real startPressure = 0;
  // Gas: the pump's rate in m³ of air at ambient pressure per second (c·M grows by
  // ambient × pumpRate per second) while the world's time is below pumpStop (s).
  Real pumpRate = 0;
  double pumpStop = 1e30;
  // Gas: air tightness as a leak rate (1/s): from leakStart (s) on, the gas beyond the rest
  // fill (ambient × rest volume, what the rest shape holds at ambient pressure) escapes as
  // d(c·M)/dt = −leakRate (c·M − ambient × rest volume), and a surface holding less draws air in
  // at the same rate: a leaking balloon goes back to its rest shape with time constant
  // 1/leakRate wherever it is squeezed or pumped. 0: air tight.
  Real leakRate = 0;
  double leakStart = 0;
  // KeepVolume: the held volume as a multiple of the rest volume, and the constraint's
  // compliance in m³/Pa (0: hard).
  Real volumeScale = 1;
  Real compliance = 0;
};

// A liquid (Nucleus's nParticles liquid simulation): the particles of a particle cloud keep the
// liquid's rest density, estimated by SPH, with one density constraint each (position-based
// fluids, Macklin and Müller 2013; ARCHITECTURE.md §2). Each particle weighs mass / count, so its
// share of the liquid's volume is d³ = mass / (count × restDensity), d the particle spacing at
// rest; the kernels reach kernelScale × d. A cubic lattice at spacing d is at rest density
// (within 1% for kernelScale 2), so a block of particles with mass = restDensity × count × s³
// starts at rest; a block packed closer expands to the rest density. The particles collide with
// other objects as points of radius `thickness` (take about d / 2) and with the colliders; two
// liquids do not collide, they mix through their density constraints.
struct Liquid {
  bool enabled = false;
  Real restDensity = 1000;  // kg/m³ (water)
  // Kernel support radius over the rest spacing d, in [1.5, 4]: more neighbours per particle
  // (about 4.2 × kernelScale³) give a smoother estimate at a higher cost.
  Real kernelScale = 2;
  // Constraint-force mixing of the density constraints (PBF's ε), as a share of an interior
  // particle's Σ w |∇C|² at rest, in [1e-6, 10]: softer, and robust where neighbours are few.
  Real relaxation = Real(0.01);
  // Artificial pressure against clumping (PBF's s_corr = −k (W(r)/W(Δq))^n, eq. 13): k as a
  // share of the multiplier a 100% density error gets in the interior at rest, in [0, 1]; Δq as
  // a share of the kernel radius in [0.01, 0.9]; n a whole number in [1, 8].
  Real tensileStrength = Real(0.001);
  Real tensileDistance = Real(0.2);
  int tensileExponent = 4;
  // XSPH viscosity (PBF eq. 17): each particle's velocity moves by c Σ (m_j/ρ_j)(v_j − v_i) W
  // once per substep, c in [0, 1].
  Real viscosity = Real(0.01);
  // Vorticity confinement (PBF eq. 16, Fedkiw et al. 2001): an acceleration ε (N × ω) that puts
  // back the swirl the solve damps, ε in m/s, [0, 100].
  Real vorticity = 0;
  // Surface tension (Akinci et al. 2013: cohesion between particles and a curvature term that
  // shrinks the surface), γ in [0, 1]. The cohesion's pull on a particle, γ Σ m_j C(r), does not
  // depend on the particle size at a given rest density: for water, 0.005–1 rounds a cube into a
  // ball within a second, and at 2 the pull outran two substeps and threw the particles apart.
  Real surfaceTension = 0;
  // Adhesion to other objects (m ≥ 0): the stickiness of the liquid's contacts with other
  // objects' primitives: a particle that leaves a surface by less than this is pulled back.
  Real adhesion = 0;
};

// Tearing of a cloth (Nucleus's nCloth tearable surface; ARCHITECTURE.md §2, "Tearing"): an edge
// whose stretch strain L/L0 − 1 stays above `strain` for `time` seconds of consecutive steps splits
// the cloth there: one of its vertices is duplicated and its triangles are shared between the two
// copies. Off while `strain` is 0. Cloth only, without pressure or rigidity.
struct Tear {
  Real strain = 0;  // threshold, in (0, 1000]: 0.5 tears an edge held at 1.5 times its rest length
  Real time = 0;    // seconds the strain must stay above the threshold, in [0, 1000]
  // Spare particles reserved after the cloth's own, one per split vertex; when they run out,
  // further tears are refused and counted. −1: a quarter of the cloth's vertices, at least 64.
  int maxNewVertices = -1;
  bool enabled() const { return strain > 0; }
};

// The constraint of a cloth hinge (two triangles on an interior edge) that is flat at rest.
//  - Dihedral: C = φ, the dihedral angle (atan2 of the two triangles' normals).
//  - Isometric: C = ‖Σ_k K_k x_k‖ with constant weights K from the rest shape (Bergou et al. 2006,
//    "A quadratic bending model for inextensible surfaces"), which is exactly 2 sin(|φ|/2) while
//    the hinge keeps its edge lengths: the same energy as Dihedral to second order in φ (the
//    same compliance means the same stiffness for small bends), softer for sharp folds (at 90°
//    1.41 against 1.57), and a projection without normals, arctangents or divisions per hinge
//    beyond one. It reads an in-plane, non-affine distortion of the hinge as a bend.
enum class BendModel { Dihedral, Isometric };

struct Material {
  // Mass of the whole object in kg, spread over its particles in proportion to the length, area
  // or volume around each (lumped mass). Must be positive and finite.
  Real mass = 1;
  // XPBD compliance (inverse stiffness, m/N) of the stretch constraints; 0 is inextensible.
  Real stretchCompliance = 0;
  Real compressionCompliance = 0;
  // Bending, off by default: for cloth, type 3 (dihedral) across every interior edge; for ropes,
  // type 2 (angle) at every vertex where two segments meet. Compliance in rad/(N·m).
  bool bending = false;
  Real bendCompliance = 0;
  // How a cloth hinge whose rest shape is flat is projected (BendModel). Hinges bent at rest,
  // and every rope, keep the dihedral angle.
  BendModel bendModel = BendModel::Dihedral;
  // Shear of cloth, off by default: type 2 (angle) at each corner of each triangle, in rad/(N·m).
  // Stretch on all three edges already holds a triangle's shape; shear matters when the
  // stretch is soft.
  bool shear = false;
  Real shearCompliance = 0;
  // Twist of ropes, off by default: type 3 (dihedral) of each four consecutive points whose rest
  // shape is not straight (a straight run has no defined dihedral), in rad/(N·m).
  bool twist = false;
  Real twistCompliance = 0;
  // Long-range attachments (Kim, Chentanez and Müller 2012) of inextensible (stretch compliance
  // 0) or strain-limited (stretchLimit) cloth and ropes that have pins: each free vertex may not
  // move farther from a pin than its geodesic distance to it in the rest shape (along the
  // surface), times 1 + the strain limit. Pins joined by edges form a cluster, and a vertex is
  // held by the nearest pin of each of its nearest clusters (up to four), so a cloth held at
  // separate points does not split where the nearest pin changes.
  // A unilateral, hard limit: it stops a pinned cloth from stretching away from its pins when
  // the sweeps are too few to carry its weight, and costs one projection per vertex and cluster
  // held (two for a cloth hung from two corners, one for a pinned row).
  bool tethers = true;
  // The strain at which the long-range limits grip: the tethers, and the coarse limits of the
  // multigrid backend's cascade (each a distance ≤ (1 + stretchLimit) × its rest length).
  // Negative (the default): 0 for inextensible stretch, where no two points of the material can
  // move apart beyond their rest distance; none for compliant stretch (stretchCompliance > 0),
  // whose stretch under a load has no bound a limit could know in advance, so such a material
  // gets neither tethers nor a cascade. A value ≥ 0 is a strain limit (Provot 1995): it gives
  // compliant cloth and ropes both (a solid, which has no tethers, the cascade), elastic up to
  // that strain and hard beyond it, at the cost of the material's response to loads that would
  // stretch it further.
  Real stretchLimit = -1;
  // The strain at which this material's long-range limits grip, or a negative value when it has
  // none (stretchLimit's default for compliant stretch).
  Real longRangeStrain() const {
    if (stretchLimit >= 0) return stretchLimit;
    return stretchCompliance == 0 ? 0 : -1;
  }
  // Stiffness-proportional damping time τ (s) of every constraint of the object: the constraint
  // force is −(C + τ dC/dt)/α. 0 = undamped. With α = 0 it makes C relax as e^(−t/τ).
  Real damping = 0;
  // Volume constraints of a solid's tetrahedra (m³/N); 0 keeps every tet's volume.
  Real volumeCompliance = 0;
  // Collision thickness in m: radius of points and edges, half-width of triangle slabs. Two
  // primitives keep (their radii summed) apart. 0 is legal: the primitives may touch but never
  // pass through each other. Within one object, pairs of primitives closer than that in the rest
  // shape get no contact (the mesh itself holds them apart), so a cloth's thickness should stay
  // below half its edge length for layers of it to keep their distance.
  Real thickness = Real(0.01);
  // Which primitives of the object collide (as nCloth's collision flags): its vertices (as
  // spheres), its edges (capsules) and its faces (slabs). Points with no edge always collide as
  // points when `collideVertices` is set.
  bool collideVertices = true;
  bool collideEdges = true;
  bool collideFaces = true;
  // Collisions of the object with itself (cloth folding onto itself, a rope coiling). Off by
  // default: it costs a broad phase over the object's own primitives every substep, which a
  // hanging or flying cloth that never meets itself does not need. Collisions between different
  // objects are always on (excludeCollisions turns a pair off).
  bool selfCollision = false;
  // Coulomb friction of primitive contacts (μ_k sliding, μ_s sticking); a pair uses the mean of
  // its two objects' coefficients.
  Real friction = Real(0.3);
  Real staticFriction = Real(0.4);
  // Restitution of impacts in [0, 1]: 0 inelastic, 1 elastic; a pair uses the larger value.
  Real restitution = 0;
  // Stickiness (m): primitives in contact that separate by less than this are pulled back to
  // the contact distance, so the object clings (0 = none); a pair uses the larger value.
  Real stickiness = 0;
  // Cloth only: the pressure of the volume its closed surface encloses (off by default).
  Pressure pressure;
  // Rigidity in [0, 1] (Nucleus's rigidity and deform resistance): every particle is pulled
  // towards the object's rest shape moved rigidly to fit where the object is (shape matching,
  // Müller et al. 2005), closing this share of the gap in each substep. 1: a rigid body, exactly
  // rigid after every projection (a box, an OBJ mesh, a sphere that collides with everything
  // through its simplices, with the object's lumped masses for its inertia); 0: off. The object
  // may have no pins (a pinned rigid body is a collider). Collider contacts, projected after it
  // in each round, may leave a rigid body off its rigid shape by as little as the sweeps allow.
  Real rigidity = 0;
  // Particle clouds only: the cloud is a liquid (off by default).
  Liquid liquid;
  // Cloth only: tearing (off by default).
  Tear tear;
};

}  // namespace nucleon
