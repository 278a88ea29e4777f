// Constraint families: the kinds of constraint that a schedule names and the statistics count.
//
// Every built-in family is declared once, in NUCLEON_CONSTRAINT_FAMILIES below. The enum, the
// names, the default sweep order (the table's order), the solver's pool list, the counts and the
// dispatch from a family to the kernels of its pools are all derived from it. Families that an
// embedding program registers at run time (nucleon/user_constraint.h) take the ids after the
// built-in ones.
//
// Adding a built-in family: a kernel in systems/solver/constraint_kernels.h (C and ∇C in its doc
// comment) and one row here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

// One row per family, in the default sweep order: X(Enumerator, "schedule name", pools), where
// `pools` lists the family's constraint pools as
//   NUCLEON_POOL(member, arity, Kernel, paths)
// - member: the pool's name in the solver's ConstraintPools (components/constraint_pools.h);
// - arity: particles per constraint;
// - Kernel: the kernel that evaluates C and ∇C (systems/solver/constraint_kernels.h);
// - paths: the sweep paths the pool takes besides the generic sweep of each backend
//   (SweepPath in systems/solver/sweep_paths.h): kDistanceBatch (AVX2 batches of eight distance
//   constraints in colored Gauss–Seidel and Jacobi), kAngularBatch (the same for dihedral
//   hinges and angles), kVertexJacobi (the vertex-centric Jacobi
//   sweep of hard distance constraints), kTetherLayers (the tethers' own sweep by vertex), or
//   kGenericSweep alone.
// A family may own several pools: bend is the dihedral angle of cloth hinges (or its isometric
// form, Material::bendModel) and the angle between rope segments. A family with no pools here is a
// constraint on many particles at once with a pool and a system of its own, projected when the plan
// sweeps it: pressure (one volume constraint per closed surface, systems/solver/pressure.h),
// attachment (nConstraints between objects, to surfaces and to handles,
// systems/solver/attachments.h) and rigidity (one shape matching cluster per object,
// systems/solver/shape_matching.h) and density (one SPH density constraint per liquid particle,
// systems/liquid/density_constraints.h). Only the library expands `pools`; the public expansions
// ignore them.
#define NUCLEON_CONSTRAINT_FAMILIES(X)                                                            \
  X(Stretch, "stretch", NUCLEON_POOL(stretch, 2, DistanceKernel, kDistanceBatch | kVertexJacobi)) \
  X(Tether, "tether", NUCLEON_POOL(tether, 2, TetherKernel, kTetherLayers))                       \
  X(Shear, "shear", NUCLEON_POOL(shear, 3, AngleKernel, kAngularBatch))                           \
  X(Bend, "bend",                                                                                 \
    NUCLEON_POOL(bend, 4, DihedralKernel, kAngularBatch)                                          \
        NUCLEON_POOL(isometricBend, 4, IsometricBendKernel, kAngularBatch)                        \
            NUCLEON_POOL(curveBend, 3, AngleKernel, kAngularBatch))                               \
  X(Twist, "twist", NUCLEON_POOL(twist, 4, DihedralKernel, kAngularBatch))                        \
  X(Volume, "volume", NUCLEON_POOL(volume, 4, VolumeKernel, kGenericSweep))                       \
  X(Pressure, "pressure", )                                                                       \
  X(Attachment, "attachment", )                                                                   \
  X(Rigidity, "rigidity", )                                                                       \
  X(Density, "density", )

namespace nucleon {

// A family's id: the built-in families by name; a family registered with
// World::registerConstraintFamily has the id that call returned (kBuiltinFamilyCount and up).
enum class ConstraintFamily : std::uint16_t {
#define NUCLEON_FAMILY_ENUMERATOR(enumerator, name, pools) enumerator,
  NUCLEON_CONSTRAINT_FAMILIES(NUCLEON_FAMILY_ENUMERATOR)
#undef NUCLEON_FAMILY_ENUMERATOR
};

#define NUCLEON_FAMILY_ONE(enumerator, name, pools) +1
constexpr std::size_t kBuiltinFamilyCount = 0 NUCLEON_CONSTRAINT_FAMILIES(NUCLEON_FAMILY_ONE);
#undef NUCLEON_FAMILY_ONE

constexpr std::size_t familyIndex(ConstraintFamily family) {
  return static_cast<std::size_t>(family);
}
constexpr bool isBuiltin(ConstraintFamily family) {
  return familyIndex(family) < kBuiltinFamilyCount;
}

// The schedule name of a built-in family ("stretch", …); "user" for any other id (a world names
// its registered families: World::familyName).
const char* toString(ConstraintFamily family);
// Parses a built-in family's schedule name; false on anything else.
bool parseConstraintFamily(const std::string& name, ConstraintFamily& out);

}  // namespace nucleon
