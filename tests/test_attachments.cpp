// Attachments against their analytic expectations: a weld holds two cloths at zero gap, a slide
// keeps the normal distance while the particle moves along the plane, a hard handle is followed
// exactly, a point on a surface stays at its distance, a glue breaks at the force set, and bad
// attachments are refused.
#include <gtest/gtest.h>

#include <cmath>

#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"

using namespace nucleon;

namespace {

// A vertical 10 × 10 panel, 0.5 m square, in the xy plane, its left edge at x = left.
ObjectDef panel(Real left, const std::string& name) {
  GridSpec spec;
  spec.resolution = {10, 10};
  spec.size = {Real(0.5), Real(0.5)};
  spec.center = Vec3(left + Real(0.25), 1, 0);
  spec.vertical = true;
  ObjectDef def = gridCloth(spec);
  def.name = name;
  def.material.mass = Real(0.1);
  return def;
}

ObjectDef singleParticle(const Vec3& at, Real mass) {
  ObjectDef def;
  def.name = "bead";
  def.vertices = {at};
  def.material.mass = mass;
  return def;
}

}  // namespace

// Two panels side by side, the second's left border on the first's right border, welded along
// it; only the first's top row is pinned. After two seconds the second still hangs from the seam:
// every welded pair is at zero gap (within 0.1 mm, hard attachments converged by the sweeps) and
// the second panel has not fallen (its lowest point within 5 cm of the first's).
TEST(Attachments, AWeldHoldsTwoClothsAtZeroGap) {
  World world;
  world.setSolver(test::solverSettings(SolverKind::Multigrid, 20, 2));
  ObjectDef left = panel(0, "left");
  for (Index i = 0; i < 10; ++i) left.pins.push_back(i);  // the top row
  const ObjectId a = world.addCloth(left);
  const ObjectId b = world.addCloth(panel(Real(0.5), "right"));
  EXPECT_EQ(world.weld(b, a, Real(1e-4)), 10u);  // the right panel's left column
  // The panels' vertices on the seam coincide: as colliding objects they would push each other
  // apart by their thickness there.
  world.excludeCollisions(a, b);
  for (int frame = 0; frame < 120; ++frame) world.step(1.0 / 60);
  const auto xa = world.positions(a), xb = world.positions(b);
  for (Index row = 0; row < 10; ++row)
    EXPECT_LT((xb[row * 10] - xa[row * 10 + 9]).norm(), 1e-4) << "row " << row;
  double lowA = 1e9, lowB = 1e9;
  for (const Vec3& x : xa) lowA = std::min(lowA, double(x.y()));
  for (const Vec3& x : xb) lowB = std::min(lowB, double(x.y()));
  EXPECT_NEAR(lowB, lowA, 0.05);
  EXPECT_EQ(world.brokenAttachments(), 0u);
}

// A bead slides on a fixed plane tilted 30° under gravity: the slide keeps its distance along the
// normal at 5 cm (1e-5 m) while gravity's tangential part, g sin 30°, carries it along the plane:
// after one second it has moved ½ g sin 30° t² = 2.45 m down the slope (within 1%: the
// constraint takes no energy from motion along the plane).
TEST(Attachments, ASlideKeepsTheNormalDistanceAndLetsTheParticleSlide) {
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 10, 4));
  const double angle = std::numbers::pi / 6;
  const Vec3 down(Real(std::cos(angle)), Real(-std::sin(angle)), 0);  // along the slope
  const Vec3 normal(Real(std::sin(angle)), Real(std::cos(angle)), 0);
  ObjectDef plane;
  plane.name = "plane";
  plane.vertices = {Vec3::Zero(), Vec3(0, 0, -1), 10 * down};
  plane.triangles = {{0, 2, 1}};  // its normal is `normal`
  const ObjectId slope = world.addCollider(plane);
  const Vec3 start = Real(0.05) * normal + Real(0.2) * down + Vec3(0, 0, Real(-0.2));
  const ObjectId bead = world.addParticles(singleParticle(start, Real(0.01)));
  Attachment slide;
  slide.kind = AttachmentKind::SlideOnSurface;
  slide.object = bead;
  slide.target = slope;
  slide.triangle = {0, 2, 1};
  slide.distance = Real(0.05);
  world.addAttachment(slide);
  for (int frame = 0; frame < 60; ++frame) {
    world.step(1.0 / 60);
    EXPECT_NEAR(normal.dot(world.positions(bead)[0]), 0.05, 1e-5) << "frame " << frame;
  }
  const double travelled = down.dot(world.positions(bead)[0] - start);
  EXPECT_NEAR(travelled, 0.5 * 9.81 * std::sin(angle), 0.01 * 2.45);
}

// A cloth corner held by a hard handle that circles 0.3 m about the vertical axis: at every frame
// end the corner is where the handle puts it (1e-5 m), the cloth hanging from it.
TEST(Attachments, AHardHandleIsFollowedExactly) {
  World world;
  world.setSolver(test::solverSettings(SolverKind::Multigrid, 10, 2));
  ObjectDef cloth = panel(0, "flag");
  const ObjectId id = world.addCloth(cloth);
  Attachment handle;
  handle.kind = AttachmentKind::PointToTransform;
  handle.object = id;
  handle.vertex = 9;  // top right corner, at (0.5, 1.25, 0)
  handle.motion.pivot = Vec3d(0, 1.25, 0);
  for (int k = 0; k <= 8; ++k) {
    Keyframe key;
    key.time = 0.25 * k;
    key.angle = k * std::numbers::pi / 4;
    handle.motion.keyframes.push_back(key);
  }
  world.addAttachment(handle);
  for (int frame = 1; frame <= 120; ++frame) {
    world.step(1.0 / 60);
    const double turn = (frame / 60.0) * std::numbers::pi;  // π rad/s
    const Vec3d expected(0.5 * std::cos(turn), 1.25, -0.5 * std::sin(turn));
    EXPECT_LT((world.positions(id)[9].cast<double>() - expected).norm(), 1e-5) << frame;
  }
}

// A bead held 0.1 m from the middle of a triangle of a cloth that falls freely: the bead stays at
// 0.1 m from the point (β = 0.2, 0.3, 0.5 of the triangle's corners) in every frame.
TEST(Attachments, APointOnASurfaceStaysAtItsDistance) {
  World world;
  world.setSolver(test::solverSettings(SolverKind::Multigrid, 10, 2));
  ObjectDef sheet = panel(0, "sheet");
  const ObjectId cloth = world.addCloth(sheet);
  const Vec3 point = Real(0.2) * sheet.vertices[44] + Real(0.3) * sheet.vertices[45] +
                     Real(0.5) * sheet.vertices[55];
  const ObjectId bead =
      world.addParticles(singleParticle(point + Vec3(0, 0, Real(0.1)), Real(0.01)));
  Attachment glue;
  glue.kind = AttachmentKind::PointToSurface;
  glue.object = bead;
  glue.target = cloth;
  glue.triangle = {44, 45, 55};
  glue.weights = Vec3(Real(0.2), Real(0.3), Real(0.5));
  glue.distance = Real(0.1);
  world.addAttachment(glue);
  world.setGravity(Vec3(Real(1), Real(-9.81), Real(2)));
  for (int frame = 0; frame < 60; ++frame) {
    world.step(1.0 / 60);
    const auto x = world.positions(cloth);
    const Vec3 q = Real(0.2) * x[44] + Real(0.3) * x[45] + Real(0.5) * x[55];
    EXPECT_NEAR((world.positions(bead)[0] - q).norm(), 0.1, 1e-4) << "frame " << frame;
  }
}

// A 1 kg bead hangs by a glue of strength S from a pinned particle: the glue carries the bead's
// weight, 9.81 N. At S = 1.05 × 9.81 N it holds for two seconds; at 0.95 × 9.81 N it breaks in
// the first step, counted, and the bead falls freely from then on.
TEST(Attachments, AGlueBreaksAtTheForceSet) {
  for (double share : {1.05, 0.95}) {
    SCOPED_TRACE(share);
    World world;
    world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 10, 2));
    ObjectDef anchor = singleParticle(Vec3(0, 2, 0), 1);
    anchor.pins = {0};
    const ObjectId top = world.addParticles(anchor);
    const ObjectId bead = world.addParticles(singleParticle(Vec3(0, Real(1.9), 0), 1));
    Attachment glue;
    glue.object = bead;
    glue.target = top;
    glue.distance = Real(0.1);
    glue.strength = Real(share * 9.81);
    const std::size_t index = world.addAttachment(glue);
    world.step(1.0 / 60);
    EXPECT_EQ(world.attachmentBroken(index), share < 1);
    for (int frame = 1; frame < 120; ++frame) world.step(1.0 / 60);
    EXPECT_EQ(world.brokenAttachments(), share < 1 ? 1u : 0u);
    if (share < 1)
      EXPECT_LT(world.positions(bead)[0].y(), 1.9 - 0.5 * 9.81 * 1.9 * 1.9 + 0.2);  // fell
    else
      EXPECT_NEAR(world.positions(bead)[0].y(), 1.9, 1e-3);  // held at its distance
  }
}

TEST(Attachments, BadAttachmentsAreRefused) {
  World world;
  const ObjectId a = world.addCloth(panel(0, "a"));
  const ObjectId b = world.addCloth(panel(1, "b"));
  Attachment bad;
  bad.object = a;
  bad.target = b;
  bad.vertex = 100;  // out of range
  EXPECT_THROW(world.addAttachment(bad), std::invalid_argument);
  bad.vertex = 0;
  bad.targetVertex = 0;
  bad.strength = -1;
  EXPECT_THROW(world.addAttachment(bad), std::invalid_argument);
  bad.strength = 0;
  bad.kind = AttachmentKind::PointToSurface;
  bad.triangle = {0, 1, 10};
  bad.weights = Vec3(Real(0.5), Real(0.5), Real(0.5));  // sums to 1.5
  EXPECT_THROW(world.addAttachment(bad), std::invalid_argument);
  bad.kind = AttachmentKind::PointToPoint;
  bad.target = a;  // itself
  EXPECT_THROW(world.addAttachment(bad), std::invalid_argument);
  bad.target = ObjectId{};  // null
  EXPECT_THROW(world.addAttachment(bad), std::invalid_argument);
  EXPECT_EQ(world.attachmentCount(), 0u);
  auto errorOf = [](const std::string& attachments) {
    return test::sceneError(R"({"name": "s", "objects": [{"type": "cloth", "name": "c", "shape":
        {"grid": {"resolution": [4, 4]}}}], "attachments": )" +
                            attachments + "}");
  };
  EXPECT_NE(errorOf(R"([{"kind": "glue", "object": "c"}])").find("attachments[0].kind"),
            std::string::npos);
  EXPECT_NE(
      errorOf(R"([{"kind": "point", "object": "d", "vertex": 0}])").find("attachments[0].object"),
      std::string::npos);
  EXPECT_NE(errorOf(R"([{"kind": "point", "object": "c", "vertex": 16, "target": "c",
                         "target_vertex": 0}])")
                .find("attachments[0].vertex"),
            std::string::npos);
  EXPECT_NE(errorOf(R"([{"kind": "transform", "object": "c", "vertex": 0}])").find("motion"),
            std::string::npos);
  EXPECT_EQ(errorOf(R"([{"kind": "transform", "object": "c", "vertices": "all",
                         "motion": {"keyframes": [{"time": 0}]}, "compliance": 0.01}])"),
            "");
  // Pairs of objects that never collide, by name.
  const Scene excluded = parseScene(
      R"({"name": "s", "objects": [{"type": "cloth", "name": "c", "shape": {"grid": {}}},
          {"type": "rope", "name": "r", "shape": {"polyline": {}}}],
          "exclude_collisions": [["c", "r"], ["c", "c"]]})",
      "test", "");
  ASSERT_EQ(excluded.excludedCollisions.size(), 2u);
  const Scene sets = parseScene(
      R"({"name": "s", "objects": [{"type": "cloth", "name": "c", "shape": {"grid": {}}}],
          "exclude_collisions": [{"object": "c", "vertices": [0, 1], "target": "c",
                                  "target_vertices": [5]}]})",
      "test", "");
  ASSERT_EQ(sets.excludedVertexSets.size(), 1u);
  EXPECT_EQ(sets.excludedVertexSets[0].vertices.size(), 2u);
  EXPECT_EQ(excluded.excludedCollisions[0][1], 1u);
  try {
    parseScene(R"({"name": "s", "objects": [{"type": "cloth", "name": "c", "shape": {"grid": {}}}],
                   "exclude_collisions": [["c", "x"]]})",
               "test", "");
    FAIL() << "an unknown object was excluded";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("exclude_collisions[0]"), std::string::npos);
  }
}

// Collisions excluded between vertex sets: a 0.2 m patch of cloth dropped onto a pinned sheet
// lands on it; with its vertices excluded against the sheet's vertices under it, it falls
// through the sheet there; with them excluded against a region of the sheet away from it, it
// still lands.
TEST(Attachments, ExcludedVertexSetsPassThroughEachOther) {
  auto dropPatch = [](int exclusion) {
    World world;
    world.setSolver(test::solverSettings(SolverKind::Multigrid, 10, 2));
    GridSpec big;
    big.resolution = {21, 21};
    big.size = {1, 1};
    big.center = Vec3(0, Real(0.5), 0);
    ObjectDef sheet = gridCloth(big);
    std::vector<Index> under, away;
    for (Index j = 0; j < 21; ++j)
      for (Index i = 0; i < 21; ++i) {
        if (i == 0 || j == 0 || i == 20 || j == 20) sheet.pins.push_back(j * 21 + i);
        const Vec3& v = sheet.vertices[j * 21 + i];
        if (std::abs(v.x()) < 0.2 && std::abs(v.z()) < 0.2) under.push_back(j * 21 + i);
        if (v.x() > 0.3 && v.x() < 0.45) away.push_back(j * 21 + i);
      }
    const ObjectId bottom = world.addCloth(sheet);
    GridSpec small;
    small.resolution = {5, 5};
    small.size = {Real(0.2), Real(0.2)};
    small.center = Vec3(0, Real(0.6), 0);
    ObjectDef patch = gridCloth(small);
    const ObjectId top = world.addCloth(patch);
    std::vector<Index> all(25);
    for (Index i = 0; i < 25; ++i) all[i] = i;
    if (exclusion == 1) world.excludeCollisions(top, all, bottom, under);
    if (exclusion == 2) world.excludeCollisions(top, all, bottom, away);
    for (int frame = 0; frame < 60; ++frame) world.step(1.0 / 60);
    double lowestSheet = 1e9, highestPatch = -1e9;
    for (const Vec3& x : world.positions(bottom))
      lowestSheet = std::min(lowestSheet, double(x.y()));
    for (const Vec3& x : world.positions(top)) highestPatch = std::max(highestPatch, double(x.y()));
    return highestPatch - lowestSheet;  // the patch's height above the sheet's lowest point
  };
  EXPECT_GT(dropPatch(0), 0);     // lands on the sheet
  EXPECT_LT(dropPatch(1), -0.5);  // falls through (a second of free fall: several metres)
  EXPECT_GT(dropPatch(2), 0);     // excluded elsewhere: lands
  World world;
  const ObjectId a = world.addCloth(panel(0, "a"));
  const std::vector<Index> bad = {100};
  EXPECT_THROW(world.excludeCollisions(a, bad, a, bad), std::invalid_argument);
}

// Input attract: every particle of a cloud pulled to its animated rest position with a
// compliance α, under gravity. At rest each hangs below its target by its weight times the
// compliance, m g α (a spring of stiffness 1/α): 0.1 kg × 9.81 m/s² × 0.01 m/N = 9.81 mm. The
// targets move sideways at 0.5 m/s, and the cloud follows them at that sag (the mean over the
// last half second, within 2%: the undamped springs ring around it).
TEST(Attachments, AnAttractHoldsACloudBelowItsMovingTargetByItsWeightTimesTheCompliance) {
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 10, 4));
  ObjectDef cloud;
  cloud.name = "cloud";
  for (int i = 0; i < 10; ++i) cloud.vertices.push_back(Vec3(Real(0.1) * i, 1, 0));
  cloud.material.mass = 1;  // 0.1 kg each
  const ObjectId id = world.addParticles(cloud);
  Attachment attract;
  attract.kind = AttachmentKind::PointToTransform;
  attract.object = id;
  attract.compliance = Real(0.01);
  Keyframe start, end;
  end.time = 10;
  end.translation = Vec3d(5, 0, 0);
  attract.motion.keyframes = {start, end};
  for (Index v = 0; v < 10; ++v) {
    attract.vertex = v;
    world.addAttachment(attract);
  }
  double sag = 0, lag = 0;
  int samples = 0;
  for (int frame = 1; frame <= 240; ++frame) {
    world.step(1.0 / 60);
    if (frame <= 210) continue;
    const double t = frame / 60.0;
    for (Index v = 0; v < 10; ++v) {
      const Vec3 x = world.positions(id)[v];
      sag += 1.0 - double(x.y());
      lag += (0.1 * v + 0.5 * t) - double(x.x());
      ++samples;
    }
  }
  EXPECT_NEAR(sag / samples, 0.1 * 9.81 * 0.01, 0.02 * 0.00981);
  EXPECT_NEAR(lag / samples, 0, 1e-3);  // moving steadily, no force along the motion
}
