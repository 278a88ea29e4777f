// Tearing of cloth (Material::tear; ARCHITECTURE.md §2, "Tearing"): a split keeps mass and
// momentum, a pull above the threshold tears and one below does not, the torn cloth does not
// intersect itself, its lips collide once open, the result does not depend on the thread count,
// the torn mesh exports as a manifold OBJ, and bad settings are errors naming their JSON path.
#include <cstdio>
#include <filesystem>
#include <map>
#include <numeric>
#include <set>

#include <gtest/gtest.h>

#include "engine/src/world_state.h"
#include "nucleon/mesh_io.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"
#include "systems/topology/tear_cloth.h"

using namespace nucleon;

namespace {

// A vertical n×n cloth 0.5 m square (n odd), hung by its top row, whose left and right halves of
// that row move `pull` m apart each over the first half second; the middle vertex of the row is
// free, so the first edges to stretch are its two.
ObjectDef pulledCloth(int n, Real strain, Real time, double pull) {
  GridSpec spec;
  spec.resolution = {n, n};
  spec.size = {Real(0.5), Real(0.5)};
  spec.center = Vec3(0, 1, 0);
  spec.vertical = true;
  ObjectDef cloth = gridCloth(spec);
  cloth.name = "sheet";
  cloth.material.mass = Real(0.1);
  cloth.material.thickness = Real(0.002);
  cloth.material.selfCollision = true;
  cloth.material.tethers = false;
  cloth.material.tear.strain = strain;
  cloth.material.tear.time = time;
  for (int side = -1; side <= 1; side += 2) {
    PinGroup group;
    for (int i = 0; i < n / 2; ++i)
      group.vertices.push_back(static_cast<Index>(side < 0 ? i : n - 1 - i));
    group.motion.pivot = Vec3d(0, 1.25, 0);
    group.motion.keyframes = {Keyframe{}, Keyframe{}};
    group.motion.keyframes[1].time = 0.5;
    group.motion.keyframes[1].translation = Vec3d(side * pull, 0, 0);
    cloth.pinGroups.push_back(group);
  }
  return cloth;
}

World pulledWorld(int n, Real strain, Real time, double pull, int threads = 2) {
  World world;
  world.setSolver(test::solverSettings(SolverKind::ColoredGaussSeidel, 10, 2));
  world.setThreads(threads);
  world.addCloth(pulledCloth(n, strain, time, pull));
  return world;
}

// Total mass and linear momentum of the free particles.
struct Totals {
  double mass = 0;
  Vec3d momentum = Vec3d::Zero(), moment = Vec3d::Zero();  // Σ m v, Σ m x
};
Totals totals(const ParticlePool& particles) {
  Totals t;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    if (particles.w[i] <= 0) continue;
    const double m = 1.0 / double(particles.w[i]);
    t.mass += m;
    t.momentum += m * particles.v[i].cast<double>();
    t.moment += m * particles.x[i].cast<double>();
  }
  return t;
}

// A horizontal 7×7 cloth 0.6 m square at rest, without gravity, with every particle given its
// own velocity; then its right half is moved 0.3 m to the right, so that the edges across the
// middle stand at several times their rest length.
World stretchedFreeCloth() {
  GridSpec spec;
  spec.resolution = {7, 7};
  spec.size = {Real(0.6), Real(0.6)};
  ObjectDef cloth = gridCloth(spec);
  cloth.material.tear.strain = Real(0.5);
  cloth.material.selfCollision = true;
  cloth.material.thickness = Real(0.01);
  World world;
  world.setGravity(Vec3::Zero());
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 10, 1));
  world.addCloth(cloth);
  world.step(1.0 / 60);  // builds the derived tables
  ParticlePool& particles = world.impl().state.particles;
  for (Index i = 0; i < 49; ++i) {
    particles.v[i] = Vec3(Real(0.01) * Real(i % 5), Real(-0.02) * Real(i % 3), Real(0.005) * i);
    if (particles.restPosition[i].x() > Real(0.05)) particles.x[i].x() += Real(0.3);
    particles.p[i] = particles.x[i];
  }
  return world;
}

// Splits the world's tearable cloths now, as the step does after its substeps.
bool tearNow(WorldState& s, TearReport& report) {
  const bool torn = tearCloths(s.objects, s.particles, s.constraints, 1.0 / 60, report);
  if (torn) {
    s.topologyDirty = true;
    s.candidates.pathStart.clear();
  }
  return torn;
}

}  // namespace

TEST(Tearing, SplitKeepsMassMomentumAndCentreOfMass) {
  World world = stretchedFreeCloth();
  WorldState& s = world.impl().state;
  const Totals before = totals(s.particles);
  TearReport report;
  ASSERT_TRUE(tearNow(s, report));
  // The column of edges across the middle is cut: a vertex split per row, at least.
  EXPECT_GE(report.newVertices, 7u);
  EXPECT_GE(report.tornEdges, 6u);
  EXPECT_EQ(s.objects[0].particleCount, 49 + report.newVertices);
  const Totals after = totals(s.particles);
  // Float inverse masses: the copies' masses are rounded once each.
  EXPECT_NEAR(after.mass, before.mass, 1e-6 * before.mass);
  EXPECT_LT((after.momentum - before.momentum).norm(), 1e-6 * before.mass);
  EXPECT_LT((after.moment - before.moment).norm(), 1e-6 * before.mass);
  // Every copy has its original's velocity and rest position.
  const ObjectRecord& o = s.objects[0];
  for (Index v = 49; v < o.particleCount; ++v) {
    const Index root = o.tear.origin[v];
    EXPECT_EQ(s.particles.v[v], s.particles.v[root]);
    EXPECT_EQ(s.particles.restPosition[v], s.particles.restPosition[root]);
  }
  // The torn cloth goes on: its constraints were rebuilt over the new vertices.
  EXPECT_EQ(world.constraintCount(ConstraintFamily::Stretch), o.complex.edges.size());
  world.step(1.0 / 60);
  const Totals stepped = totals(s.particles);
  EXPECT_NEAR(stepped.mass, after.mass, 1e-9 * after.mass);
  EXPECT_LT((stepped.momentum - after.momentum).norm(), 1e-4 * after.mass);
  EXPECT_EQ(world.measure().nanCount, 0u);
}

// Tethers are geodesic from the pins: a piece torn off loses them and falls, the rest keeps
// those whose path stays on it.
TEST(Tearing, TethersFollowTheTornMesh) {
  GridSpec spec;
  spec.resolution = {7, 7};
  spec.size = {Real(0.6), Real(0.6)};
  spec.vertical = true;
  ObjectDef cloth = gridCloth(spec);
  cloth.pins = {0, 1, 2, 3, 4, 5, 6};  // the top row
  cloth.material.tear.strain = Real(0.5);
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 10, 1));
  world.addCloth(cloth);
  world.step(1.0 / 60);
  const std::size_t tethersBefore = world.constraintCount(ConstraintFamily::Tether);
  ASSERT_EQ(tethersBefore, 42u);  // every free vertex to the one cluster
  // The lower half pulled 0.3 m down: the rows between stand at several times their length.
  WorldState& s = world.impl().state;
  const Real middle = Real(1);
  for (Index i = 0; i < 49; ++i) {
    if (s.particles.restPosition[i].y() < middle - Real(0.05)) s.particles.x[i].y() -= Real(0.3);
    s.particles.v[i].setZero();
    s.particles.p[i] = s.particles.x[i];
  }
  TearReport report;
  ASSERT_TRUE(tearNow(s, report));
  const ObjectRecord& o = s.objects[0];
  // The pieces of the torn cloth, by the triangles' shared vertices.
  std::vector<Index> piece(o.particleCount);
  std::iota(piece.begin(), piece.end(), Index(0));
  const auto find = [&](Index v) {
    while (piece[v] != v) v = piece[v] = piece[piece[v]];
    return v;
  };
  for (const auto& t : o.complex.triangles.vertices)
    for (int k = 1; k < 3; ++k) piece[find(t[k])] = find(t[0]);
  std::set<Index> pieces;
  for (Index v = 0; v < o.particleCount; ++v) pieces.insert(find(v));
  ASSERT_EQ(pieces.size(), 2u);
  const TetherConstraints& tethers = s.constraints.tether;
  for (std::size_t c = 0; c < tethers.size(); ++c)
    EXPECT_EQ(find(tethers.particles[c][0]), find(tethers.particles[c][1]));
  EXPECT_LT(tethers.size(), tethersBefore);
  EXPECT_GT(tethers.size(), 0u);
  // The piece without pins falls freely: after 10 steps at 1/60 s, g t²/2 = 0.136 m lower.
  const Index loose = find(48);  // the bottom corner
  ASSERT_NE(loose, find(0));
  std::vector<Real> startY(o.particleCount);
  for (Index v = 0; v < o.particleCount; ++v) startY[v] = s.particles.x[v].y();
  test::simulate(world, 10);
  for (Index v = 0; v < o.particleCount; ++v)
    if (find(v) == loose) {
      EXPECT_LT(s.particles.x[v].y(), startY[v] - Real(0.12)) << v;
    }
}

TEST(Tearing, TearsAboveTheThresholdAndNotBelow) {
  constexpr int kSteps = 40;
  // The strain the pull reaches when nothing tears.
  World intact = pulledWorld(9, Real(1000), 0, 0.15);
  double reached = 0;
  for (int k = 0; k < kSteps; ++k) {
    intact.step(1.0 / 60);
    reached = std::max(reached, intact.measure().maxStretch);
  }
  ASSERT_GT(reached, 0.2);
  EXPECT_EQ(intact.tearReport().newVertices, 0u);

  World below = pulledWorld(9, Real(1.2 * reached), 0, 0.15);
  test::simulate(below, kSteps);
  EXPECT_EQ(below.tearReport().newVertices, 0u);
  EXPECT_EQ(below.positions(below.objectAt(0)).size(), 81u);

  World above = pulledWorld(9, Real(0.5 * reached), 0, 0.15);
  test::simulate(above, kSteps);
  EXPECT_GT(above.tearReport().newVertices, 0u);
  EXPECT_GT(above.tearReport().tornEdges, 0u);
  EXPECT_EQ(above.positions(above.objectAt(0)).size(), 81 + above.tearReport().newVertices);

  // Above the threshold for less than the time asked: no tear either.
  World brief = pulledWorld(9, Real(0.5 * reached), 10, 0.15);
  test::simulate(brief, kSteps);
  EXPECT_EQ(brief.tearReport().newVertices, 0u);
}

TEST(Tearing, TornClothNeverIntersectsItself) {
  World world = pulledWorld(9, Real(0.3), Real(0.02), 0.3);
  for (int k = 0; k < 60; ++k) {
    world.step(1.0 / 60);
    ASSERT_EQ(world.measure().intersections, 0u) << "step " << k + 1;
  }
  EXPECT_GT(world.tearReport().newVertices, 0u);
  EXPECT_EQ(world.recoveries().total(), 0u);
}

TEST(Tearing, SameStateAtOneAndTwoThreads) {
#if defined(__SANITIZE_ADDRESS__)
  // Determinism is a property of the arithmetic, which the Release and double builds check; the
  // sanitizer build runs the same tears in the other tests (it does not detect data races).
  GTEST_SKIP() << "thread-count determinism is checked in the Release and double builds";
#endif
  // The parallel backends, multigrid's levels rebuilt after every tear included.
  for (const SolverKind kind :
       {SolverKind::ColoredGaussSeidel, SolverKind::Jacobi, SolverKind::Multigrid}) {
    World one = pulledWorld(9, Real(0.3), Real(0.02), 0.3, 1);
    World two = pulledWorld(9, Real(0.3), Real(0.02), 0.3, 2);
    one.setSolver(test::solverSettings(kind, 10, 2));
    two.setSolver(test::solverSettings(kind, 10, 2));
    test::simulate(one, 45);
    test::simulate(two, 45);
    EXPECT_GT(one.tearReport().newVertices, 0u) << toString(kind);
    EXPECT_EQ(one.tearReport().newVertices, two.tearReport().newVertices) << toString(kind);
    EXPECT_EQ(one.tearReport().tornEdges, two.tearReport().tornEdges) << toString(kind);
    EXPECT_EQ(one.stateHash(), two.stateHash()) << toString(kind);
    EXPECT_EQ(one.recoveries().total(), 0u) << toString(kind);
  }
}

TEST(Tearing, TornMeshExportsAManifoldObj) {
  World world = pulledWorld(9, Real(0.3), Real(0.02), 0.3);
  test::simulate(world, 45);
  ASSERT_GT(world.tearReport().newVertices, 0u);
  const ObjectId id = world.objectAt(0);
  const std::string path =
      (std::filesystem::temp_directory_path() / "nucleon_torn_sheet.obj").string();
  writeObj(path, world.positions(id), world.surfaceTriangles(id), {});
  const ObjectDef mesh = loadObj(path);
  std::remove(path.c_str());
  ASSERT_EQ(mesh.vertices.size(), world.positions(id).size());
  ASSERT_EQ(mesh.triangles.size(), 2u * 8 * 8);
  // Every edge in at most two triangles, which run it in opposite directions; every vertex used.
  std::map<std::pair<Index, Index>, int> directed;
  std::set<Index> used;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      ASSERT_LT(t[k], mesh.vertices.size());
      used.insert(t[k]);
      ++directed[{t[k], t[(k + 1) % 3]}];
    }
  EXPECT_EQ(used.size(), mesh.vertices.size());
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1) << edge.first << "-" << edge.second << " twice in one direction";
    EXPECT_LE(count + directed.count({edge.second, edge.first}), 2u);
  }
}

// The lips of a cut start coincident in the rest shape, as every pair of a mesh's neighbours
// does; once they have opened beyond the contact distance they collide like any two layers.
TEST(Tearing, OpenedLipsCollideAcrossTheCut) {
  for (const bool opened : {false, true}) {
    World world = stretchedFreeCloth();
    WorldState& s = world.impl().state;
    TearReport report;
    ASSERT_TRUE(tearNow(s, report));
    ParticlePool& particles = s.particles;
    const ObjectRecord& o = s.objects[0];
    if (opened) {
      // Apart by far more than the contact distance (2 × 0.01 m): every lip opens.
      std::vector<Vec3> kept(particles.x.begin(), particles.x.end());
      for (Index v = 49; v < o.particleCount; ++v) particles.x[v].x() += Real(0.3);
      openTornLips(s.objects, particles, s.primitives);
      std::copy(kept.begin(), kept.end(), particles.x.begin());
    }
    EXPECT_EQ(std::count(o.tear.opened.begin(), o.tear.opened.end(), 1) > 0, opened);
    // The two halves closed again, lip against lip (as at the tear), and still.
    for (Index v = 0; v < o.particleCount; ++v) {
      if (particles.x[v].x() > Real(0.05)) particles.x[v].x() -= Real(0.3);
      particles.v[v].setZero();
      particles.p[v] = particles.x[v];
    }
    const std::uint64_t contactsBefore = world.collisionReport().contacts;
    world.step(1.0 / 60);
    // The only primitives within contact distance of each other that share no vertex are the
    // lips' (a flat sheet's other neighbours are exempt by the rest shape).
    const std::uint64_t contacts = world.collisionReport().contacts - contactsBefore;
    if (opened)
      EXPECT_GT(contacts, 0u);
    else
      EXPECT_EQ(contacts, 0u);
  }
}

TEST(Tearing, SparesRunOutAndFurtherTearsAreRefused) {
  World world = stretchedFreeCloth();
  WorldState& s = world.impl().state;
  const Index spares = s.objects[0].tear.spareParticles;
  EXPECT_EQ(spares, 64u);  // a quarter of 49 vertices, at least 64
  EXPECT_EQ(world.particleCount(), 49u + spares);
  s.objects[0].tear.spareParticles = 3;
  TearReport report;
  ASSERT_TRUE(tearNow(s, report));
  EXPECT_EQ(report.newVertices, 3u);
  EXPECT_GT(report.refusedTears, 0u);
  EXPECT_EQ(s.objects[0].particleCount, 52u);
}

TEST(Tearing, BadSettingsAreErrorsNamingThePath) {
  const std::string scene = R"({"objects": [{"type": "cloth",
      "shape": {"grid": {"resolution": [4, 4], "size": [1, 1]}},
      "material": {"tear": {"strain": 0.5, "time": 0.01}}}]})";
  EXPECT_EQ(test::sceneError(scene), "");
  EXPECT_NE(test::sceneError(test::replaced(scene, "\"strain\": 0.5", "\"strain\": -1"))
                .find("objects[0].material.tear.strain"),
            std::string::npos);
  EXPECT_NE(test::sceneError(test::replaced(scene, "\"strain\": 0.5", "\"strain\": 0"))
                .find("objects[0].material.tear.strain"),
            std::string::npos);
  EXPECT_NE(test::sceneError(test::replaced(scene, "\"time\": 0.01", "\"time\": -2"))
                .find("objects[0].material.tear.time"),
            std::string::npos);
  EXPECT_NE(test::sceneError(test::replaced(scene, "\"time\": 0.01", "\"time\": 0.01, \"s\": 1"))
                .find("objects[0].material.tear: unknown key 's'"),
            std::string::npos);
  EXPECT_NE(test::sceneError(test::replaced(scene, "\"time\": 0.01",
                                            "\"time\": 0.01, \"max_new_vertices\": 1.5"))
                .find("objects[0].material.tear.max_new_vertices"),
            std::string::npos);
  EXPECT_NE(test::sceneError(test::replaced(scene, "\"strain\": 0.5, ", ""))
                .find("objects[0].material.tear: missing 'strain'"),
            std::string::npos);
  const std::string rope = R"({"objects": [{"type": "rope",
      "shape": {"polyline": {"from": [0, 1, 0], "to": [1, 1, 0], "segments": 4}},
      "material": {"tear": {"strain": 0.5}}}]})";
  EXPECT_NE(test::sceneError(rope).find("objects[0].material.tear: only a cloth can tear"),
            std::string::npos)
      << test::sceneError(rope);

  // The same ranges through the C++ API.
  ObjectDef cloth = gridCloth(GridSpec{{4, 4}, {1, 1}, Vec3(0, 1, 0), false});
  World world;
  cloth.material.tear.strain = std::numeric_limits<Real>::quiet_NaN();
  EXPECT_THROW(world.addCloth(cloth), std::invalid_argument);
  cloth.material.tear.strain = Real(0.5);
  cloth.material.tear.time = -1;
  EXPECT_THROW(world.addCloth(cloth), std::invalid_argument);
  cloth.material.tear.time = 0;
  cloth.material.rigidity = Real(0.5);
  EXPECT_THROW(world.addCloth(cloth), std::invalid_argument);
  cloth.material.rigidity = 0;
  EXPECT_NO_THROW(world.addCloth(cloth));
  ObjectDef rod = polylineRope(Vec3(0, 1, 0), Vec3(1, 1, 0), 4);
  rod.material.tear.strain = Real(0.5);
  EXPECT_THROW(world.addRope(rod), std::invalid_argument);
}
