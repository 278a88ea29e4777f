// Constraint families registered through the public API (nucleon/user_constraint.h): a
// registered distance family reproduces the built-in stretch family bit for bit in every backend,
// registered families are deterministic across thread counts, scheduled by name and counted, and
// bad definitions are rejected with a clear error.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "engine/src/world_state.h"  // the built-in stretch pool's edges, in pool order
#include "nucleon/shapes.h"
#include "nucleon/user_constraint.h"
#include "nucleon/world.h"

using namespace nucleon;

namespace {

// C = ‖x0 − x1‖ − L, ∇_x0 C = (x0 − x1)/‖x0 − x1‖ = −∇_x1 C: the built-in DistanceKernel's
// function, written as an embedding program would, with the same operations in the same order.
Real userDistance(const Vec3* x, const Real* rest, Vec3* gradient, const void*) {
  const Vec3 d = x[0] - x[1];
  const Real length = d.norm();
  if (length < Real(1e-12)) {
    gradient[0] = gradient[1] = Vec3::Zero();
    return 0 - rest[0];
  }
  gradient[0] = d * (1 / length);
  gradient[1] = -gradient[0];
  return length - rest[0];
}

UserConstraintFamilyDef distanceFamily() {
  UserConstraintFamilyDef def;
  def.name = "user-distance";
  def.arity = 2;
  def.restSize = 1;
  def.evaluate = userDistance;
  def.unitGradients = true;
  def.jacobiAcceleration = true;  // as the built-in stretch family
  return def;
}

ObjectDef cloth(int n) {
  GridSpec grid;
  grid.resolution = {n, n};
  ObjectDef def = gridCloth(grid);
  def.pins = {0, Index(n - 1)};
  def.material.tethers = false;                 // stretch alone
  def.material.stretchCompliance = Real(1e-6);  // soft in tension, so λ and α̃ both matter
  def.material.compressionCompliance = Real(1e-4);
  return def;
}

struct ClothRun {
  std::uint64_t hash = 0;
  std::size_t count = 0;
};

// `registered`: the cloth's stretch is swept by a registered distance family on the same edges,
// in the same order, with the same rest lengths and compliances, and the built-in stretch family
// gets no sweeps.
ClothRun runCloth(SolverKind kind, SolverKind smoother, bool registered, int threads = 2) {
  World world;
  world.setThreads(threads);
  const ObjectId id = world.addCloth(cloth(12));
  SolverSettings solver;
  solver.kind = kind;
  solver.smoother = smoother;
  solver.substeps = 2;
  solver.optimizedPaths = false;  // the built-in's generic sweep: no AVX2 batch, no vertex path
  solver.schedule = {{ConstraintFamily::Stretch, 6}};
  ClothRun run;
  if (registered) {
    const ConstraintFamily family = world.registerConstraintFamily(distanceFamily());
    const StretchConstraints& stretch = world.impl().state.constraints.stretch;
    for (std::size_t c = 0; c < stretch.size(); ++c) {
      const Index ends[] = {stretch.particles[c][0], stretch.particles[c][1]};
      const Real rest[] = {stretch.rest[c]};
      ConstraintCompliance compliance;
      compliance.compliance = stretch.compliance[c];
      compliance.compressionCompliance = stretch.compressionCompliance[c];
      compliance.damping = stretch.damping[c];
      world.addConstraint(id, family, ends, rest, compliance);
    }
    solver.schedule = {{family, 6}, {ConstraintFamily::Stretch, 0}};
    run.count = world.constraintCount(family);
  }
  world.setSolver(solver);
  for (int step = 0; step < 40; ++step) world.step(1.0 / 60);
  EXPECT_EQ(world.measure().nanCount, 0u);
  run.hash = world.stateHash();
  return run;
}

struct Backend {
  SolverKind kind;
  SolverKind smoother;
  const char* name;
};
const Backend kBackends[] = {
    {SolverKind::GaussSeidel, SolverKind::ColoredGaussSeidel, "gauss-seidel"},
    {SolverKind::ColoredGaussSeidel, SolverKind::ColoredGaussSeidel, "colored-gs"},
    {SolverKind::Jacobi, SolverKind::ColoredGaussSeidel, "jacobi"},
    {SolverKind::Multigrid, SolverKind::ColoredGaussSeidel, "multigrid, colored-gs smoother"},
    {SolverKind::Multigrid, SolverKind::Jacobi, "multigrid, jacobi smoother"},
    {SolverKind::Multigrid, SolverKind::GaussSeidel, "multigrid, gauss-seidel smoother"},
};

}  // namespace

TEST(UserConstraints, RegisteredDistanceReproducesStretchBitForBitInEveryBackend) {
  for (const Backend& b : kBackends) {
    SCOPED_TRACE(b.name);
    const ClothRun builtin = runCloth(b.kind, b.smoother, false);
    const ClothRun registered = runCloth(b.kind, b.smoother, true);
    EXPECT_EQ(registered.count, 2u * 11 * 12 + 11 * 11);  // the 12×12 grid's edges, diagonals too
    EXPECT_EQ(builtin.hash, registered.hash);
  }
}

TEST(UserConstraints, SameStateForOneAndTwoThreads) {
  for (const Backend& b : kBackends) {
    SCOPED_TRACE(b.name);
    EXPECT_EQ(runCloth(b.kind, b.smoother, true, 1).hash,
              runCloth(b.kind, b.smoother, true, 2).hash);
  }
}

namespace {

// C = n · x − d: particle x on the plane n · x = d (rest data n_x, n_y, n_z, d; ‖n‖ = 1).
Real distanceFromPlane(const Vec3* x, const Real* plane, Vec3* gradient, const void*) {
  const Vec3 normal(plane[0], plane[1], plane[2]);
  gradient[0] = normal;
  return normal.dot(x[0]) - plane[3];
}

// The point-on-plane family (rest data: the plane's normal and offset), registered in `world`.
ConstraintFamily registerOnPlane(World& world) {
  UserConstraintFamilyDef def;
  def.name = "on-plane";
  def.arity = 1;
  def.restSize = 4;
  def.evaluate = distanceFromPlane;
  return world.registerConstraintFamily(def);
}

}  // namespace

// A falling cloth whose four corners are held on the plane y = 0.5 by a registered family: the
// corners stop there while the rest of the cloth sags below them. Hard constraints on one particle
// are met exactly by each projection, so after the last sweep the corners are on the plane to
// rounding: 1e-5 m is a hundred times the float spacing at 0.5 m, with room for the stretch
// sweeps that run before the plane's in each round.
TEST(UserConstraints, PointOnPlaneHoldsTheCornersInEveryBackend) {
  for (const Backend& b : kBackends) {
    SCOPED_TRACE(b.name);
    World world;
    const ConstraintFamily family = registerOnPlane(world);
    GridSpec grid;
    grid.resolution = {16, 16};
    ObjectDef d = gridCloth(grid);  // at y = 1
    const ObjectId id = world.addCloth(d);
    const Index corners[] = {0, 15, 240, 255};
    const Real plane[] = {0, 1, 0, Real(0.5)};
    for (Index c : corners) world.addConstraint(id, family, {{c}}, plane);
    SolverSettings solver;
    solver.kind = b.kind;
    solver.smoother = b.smoother;
    solver.iterations = 10;
    world.setSolver(solver);
    EXPECT_EQ(world.sweepsPerSubstep(family), 10);
    for (int step = 0; step < 60; ++step) world.step(1.0 / 60);
    const auto x = world.positions(id);
    for (Index c : corners) EXPECT_NEAR(x[c].y(), 0.5, 1e-5) << "corner " << c;
    // Free fall for one second would take the middle 4.9 m down; the held cloth sags below the
    // corners but stays near them.
    const Real middle = x[8 * 16 + 8].y();
    EXPECT_LT(middle, Real(0.5));
    EXPECT_GT(middle, Real(-1.0));
    EXPECT_EQ(world.measure().nanCount, 0u);
  }
}

// Multigrid's coarse levels do not see registered families: a world that has both says so,
// naming the family; a family without constraints, or another backend, gives no such line.
TEST(UserConstraints, MultigridWithARegisteredFamilyIsWarnedOf) {
  const auto familyLines = [](const World& world) {
    int lines = 0;
    for (const std::string& line : world.warnings())
      lines += line.rfind("on-plane: registered families are not seen by multigrid", 0) == 0;
    return lines;
  };
  World world;
  const ConstraintFamily family = registerOnPlane(world);
  GridSpec grid;
  grid.resolution = {8, 8};
  const ObjectId id = world.addCloth(gridCloth(grid));
  SolverSettings solver;
  solver.kind = SolverKind::Multigrid;
  world.setSolver(solver);
  EXPECT_EQ(familyLines(world), 0);  // registered, but no constraint of it yet
  const Real plane[] = {0, 1, 0, Real(0.5)};
  world.addConstraint(id, family, {{0}}, plane);
  EXPECT_EQ(familyLines(world), 1);
  solver.kind = SolverKind::ColoredGaussSeidel;
  world.setSolver(solver);
  EXPECT_EQ(familyLines(world), 0);
}

TEST(UserConstraints, ScheduledByNameAndCounted) {
  World world;
  const ConstraintFamily family = world.registerConstraintFamily(distanceFamily());
  EXPECT_EQ(world.familyCount(), kBuiltinFamilyCount + 1);
  EXPECT_EQ(world.familyName(family), "user-distance");
  ConstraintFamily found{};
  ASSERT_TRUE(world.findConstraintFamily("user-distance", found));
  EXPECT_EQ(found, family);
  ASSERT_TRUE(world.findConstraintFamily("bend", found));
  EXPECT_EQ(found, ConstraintFamily::Bend);
  EXPECT_FALSE(world.findConstraintFamily("no-such-family", found));

  const ObjectId id = world.addRope(polylineRope(Vec3(0, 1, 0), Vec3(1, 1, 0), 4));
  world.addConstraint(id, family, std::vector<Index>{0, 4}, std::vector<Real>{Real(1)});
  EXPECT_EQ(world.constraintCount(family), 1u);
  SolverSettings solver;
  solver.schedule = {{ConstraintFamily::Stretch, 4}, {family, 2}};
  world.setSolver(solver);
  EXPECT_EQ(world.sweepsPerSubstep(family), 2);
  EXPECT_EQ(world.sweepsPerSubstep(ConstraintFamily::Stretch), 4);
  EXPECT_EQ(world.sweepsPerSubstep(ConstraintFamily::Bend), 0);
}

TEST(UserConstraints, BadDefinitionsAndConstraintsAreRejected) {
  World world;
  UserConstraintFamilyDef def = distanceFamily();
  def.name = "";
  EXPECT_THROW(world.registerConstraintFamily(def), std::invalid_argument);
  def.name = "stretch";  // a built-in's name
  EXPECT_THROW(world.registerConstraintFamily(def), std::invalid_argument);
  def.name = "ok";
  def.arity = 0;
  EXPECT_THROW(world.registerConstraintFamily(def), std::invalid_argument);
  def.arity = kMaxUserConstraintArity + 1;
  EXPECT_THROW(world.registerConstraintFamily(def), std::invalid_argument);
  def.arity = 2;
  def.evaluate = nullptr;
  EXPECT_THROW(world.registerConstraintFamily(def), std::invalid_argument);
  EXPECT_EQ(world.familyCount(), kBuiltinFamilyCount);  // nothing registered

  const ConstraintFamily family = world.registerConstraintFamily(distanceFamily());
  EXPECT_THROW(world.registerConstraintFamily(distanceFamily()), std::invalid_argument);  // taken
  const ObjectId id = world.addRope(polylineRope(Vec3(0, 1, 0), Vec3(1, 1, 0), 4));
  const std::vector<Real> rest = {1};
  EXPECT_THROW(world.addConstraint(id, family, std::vector<Index>{0}, rest),
               std::invalid_argument);  // arity 2
  EXPECT_THROW(world.addConstraint(id, family, std::vector<Index>{0, 5}, rest),
               std::invalid_argument);  // the rope has vertices 0 … 4
  EXPECT_THROW(world.addConstraint(id, family, std::vector<Index>{0, 4}, std::vector<Real>{}),
               std::invalid_argument);  // one rest value
  EXPECT_THROW(
      world.addConstraint(id, family, std::vector<Index>{0, 4}, std::vector<Real>{std::nanf("")}),
      std::invalid_argument);
  ConstraintCompliance negative;
  negative.compliance = -1;
  EXPECT_THROW(world.addConstraint(id, family, std::vector<Index>{0, 4}, rest, negative),
               std::invalid_argument);
  EXPECT_THROW(world.addConstraint(id, ConstraintFamily::Stretch, std::vector<Index>{0, 4}, rest),
               std::invalid_argument);  // not a registered family
  EXPECT_EQ(world.constraintCount(family), 0u);
  SolverSettings solver;
  solver.schedule = {{static_cast<ConstraintFamily>(kBuiltinFamilyCount + 5), 1}};
  EXPECT_THROW(world.setSolver(solver), std::invalid_argument);  // no such family
}
