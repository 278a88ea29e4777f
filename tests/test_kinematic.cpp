// Animated colliders and animated pins: keyframed rigid motion, the procedural bend and targets
// set through the API put the collider's particles (or a pin group's) exactly where the animation
// says at every substep's end, with the velocity of the substep's straight-line motion; the free
// part of a cloth with animated pins follows them; bad input is rejected with a clear message.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/src/world_state.h"
#include "nucleon/mesh_io.h"
#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"
#include "systems/dynamics/kinematic_motion.h"

namespace nucleon {
namespace {

constexpr double kPi = std::numbers::pi;

// Positions are stored in Real: posing in double and rounding once gives half an ulp; comparing
// with an independent double computation (axis-angle matrix instead of quaternion) adds a few
// double ulps. Four Real ulps of the coordinate's magnitude covers both, with margin.
double tolerance(double magnitude) {
  return 4 * std::max<double>(std::numeric_limits<Real>::epsilon(), 1e-14) *
         std::max(1.0, magnitude);
}

void expectNear(const Vec3& actual, const Vec3d& expected, const std::string& what) {
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(actual[k], expected[k], tolerance(expected.cwiseAbs().maxCoeff()))
        << what << " coordinate " << k;
}

// A 4×4 grid panel, vertical in the xy plane, centred 1 m right of the pivot: an open mesh.
ObjectDef panel() {
  return test::verticalPanel(Vec3(1, 1, 0));
}

Keyframe key(double time, Vec3d translation, Vec3d axis, double degrees) {
  Keyframe k;
  k.time = time;
  k.translation = translation;
  k.axis = axis;
  k.angle = degrees * kPi / 180;
  return k;
}

// Rest vertex r turned by `degrees` about `axis` through `pivot`, then moved.
Vec3d rigid(const Vec3& r, const Vec3d& pivot, const Vec3d& axis, double degrees,
            const Vec3d& translation) {
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(degrees * kPi / 180, axis.normalized()).toRotationMatrix();
  return rotation * (r.cast<double>() - pivot) + pivot + translation;
}

// dt = 1/32 s in 4 substeps: every step and substep end is exact in binary, so the world's clock
// lands exactly on the keyframe times.
World animatedWorld(const ObjectDef& collider, int substeps = 4) {
  World world;
  world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 2, substeps));
  world.addCollider(collider);
  return world;
}
constexpr double kDt = 1.0 / 32;

ObjectDef turningPanel() {
  ObjectDef def = panel();
  def.motion.pivot = Vec3d(0, 1, 0);
  def.motion.keyframes = {key(0, Vec3d::Zero(), Vec3d(0, 1, 0), 0),
                          key(0.5, Vec3d(0.5, 0, 0), Vec3d(0, 2, 0), 90),
                          key(1.0, Vec3d(0.5, 1, 0), Vec3d(0, 1, 0), 170)};
  return def;
}

TEST(KeyframedCollider, ReachesEveryKeyframePoseExactlyAtItsTime) {
  const ObjectDef def = turningPanel();
  World world = animatedWorld(def);
  const ObjectId id = world.objectAt(0);
  for (int k = 0; k < 16; ++k) world.step(kDt);
  ASSERT_EQ(world.time(), 0.5);
  auto x = world.positions(id);
  for (std::size_t i = 0; i < x.size(); ++i)
    expectNear(x[i], rigid(def.vertices[i], def.motion.pivot, {0, 1, 0}, 90, {0.5, 0, 0}),
               "keyframe 1, vertex " + std::to_string(i));
  for (int k = 0; k < 16; ++k) world.step(kDt);
  ASSERT_EQ(world.time(), 1.0);
  x = world.positions(id);
  for (std::size_t i = 0; i < x.size(); ++i)
    expectNear(x[i], rigid(def.vertices[i], def.motion.pivot, {0, 1, 0}, 170, {0.5, 1, 0}),
               "keyframe 2, vertex " + std::to_string(i));
}

TEST(KeyframedCollider, InterpolatesLinearlyAndBySlerpBetweenKeyframes) {
  const ObjectDef def = turningPanel();
  World world = animatedWorld(def);
  for (int k = 0; k < 8; ++k) world.step(kDt);  // t = 0.25: halfway from keyframe 0 to 1
  auto x = world.positions(world.objectAt(0));
  for (std::size_t i = 0; i < x.size(); ++i)
    expectNear(x[i], rigid(def.vertices[i], def.motion.pivot, {0, 1, 0}, 45, {0.25, 0, 0}),
               "halfway, vertex " + std::to_string(i));
  for (int k = 0; k < 12; ++k) world.step(kDt);  // t = 0.625: a quarter from keyframe 1 to 2
  x = world.positions(world.objectAt(0));
  for (std::size_t i = 0; i < x.size(); ++i)
    expectNear(x[i], rigid(def.vertices[i], def.motion.pivot, {0, 1, 0}, 110, {0.5, 0.25, 0}),
               "quarter, vertex " + std::to_string(i));
}

TEST(KeyframedCollider, HoldsTheLastKeyframeAfterTheEnd) {
  const ObjectDef def = turningPanel();
  World world = animatedWorld(def);
  for (int k = 0; k < 48; ++k) world.step(kDt);  // 1.5 s
  const auto x = world.positions(world.objectAt(0));
  const auto v = world.velocities();
  for (std::size_t i = 0; i < x.size(); ++i) {
    expectNear(x[i], rigid(def.vertices[i], def.motion.pivot, {0, 1, 0}, 170, {0.5, 1, 0}),
               "held, vertex " + std::to_string(i));
    EXPECT_EQ(v[i], Vec3::Zero()) << "a held collider is at rest";
  }
}

TEST(KeyframedCollider, LoopsWithTheKeyframesPeriod) {
  ObjectDef def = turningPanel();
  def.motion.loop = true;
  World world = animatedWorld(def);
  for (int k = 0; k < 40; ++k) world.step(kDt);  // 1.25 s = one period + 0.25 s
  const auto x = world.positions(world.objectAt(0));
  for (std::size_t i = 0; i < x.size(); ++i)
    expectNear(x[i], rigid(def.vertices[i], def.motion.pivot, {0, 1, 0}, 45, {0.25, 0, 0}),
               "looped, vertex " + std::to_string(i));
}

TEST(KeyframedCollider, StartsAtItsPoseWhenAdded) {
  ObjectDef def = panel();
  def.motion.keyframes = {key(0, Vec3d(0, 2, 0), Vec3d(1, 0, 0), 30),
                          key(1, Vec3d(0, 3, 0), Vec3d(1, 0, 0), 30)};
  World world = animatedWorld(def);
  const auto x = world.positions(world.objectAt(0));
  for (std::size_t i = 0; i < x.size(); ++i)
    expectNear(x[i], rigid(def.vertices[i], Vec3d::Zero(), {1, 0, 0}, 30, {0, 2, 0}),
               "initial, vertex " + std::to_string(i));
}

// The velocity the collision code sees is the substep's straight-line displacement over h: the
// last substep goes from the pose at t − h to the pose at t.
TEST(KeyframedCollider, VelocityIsTheSubstepDisplacementOverH) {
  const ObjectDef def = turningPanel();
  const int substeps = 4;
  World world = animatedWorld(def, substeps);
  for (int k = 0; k < 5; ++k) world.step(kDt);
  const double h = kDt / substeps;
  const KinematicTrack& track = world.impl().state.kinematics.tracks.at(0);
  std::vector<Vec3> before(def.vertices.size());
  posePositions(track, def.vertices, world.time() - h, before);
  const auto x = world.positions(world.objectAt(0));
  const auto v = world.velocities();
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Vec3d expected = (x[i].cast<double>() - before[i].cast<double>()) / h;
    // Both ends are rounded to Real: the displacement is known to an ulp of the coordinates.
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(v[i][k], expected[k], 2 * tolerance(3) / h) << "vertex " << i;
    EXPECT_GT(v[i].norm(), 0.1) << "the panel turns";
  }
}

// With a single substep the velocity is exactly what predict needs: x + h v reproduces the pose
// to rounding, and update leaves x exactly on the pose.
TEST(KeyframedCollider, PredictLandsOnTheTarget) {
  const ObjectDef def = turningPanel();
  World world = animatedWorld(def, 1);
  world.step(kDt);
  std::vector<Vec3> start(world.positions().begin(), world.positions().end());
  world.step(kDt);
  const KinematicTrack& track = world.impl().state.kinematics.tracks.at(0);
  std::vector<Vec3> pose(def.vertices.size());
  posePositions(track, def.vertices, world.time(), pose);
  const Real h = static_cast<Real>(kDt);
  for (std::size_t i = 0; i < pose.size(); ++i) {
    EXPECT_EQ(world.positions()[i], pose[i]) << "vertex " << i;
    const Vec3 predicted = start[i] + h * world.velocities()[i];
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(predicted[k], pose[i][k], tolerance(3)) << "vertex " << i;
  }
}

// A strip along x, bent about z: the centre line becomes a circular arc of the bend's curvature
// and keeps its length; points off the line in z keep their offset.
TEST(BentCollider, BendsItsRestShapeIntoAnArc) {
  GridSpec spec;
  spec.resolution = {11, 3};
  spec.size = {1, Real(0.2)};
  spec.center = Vec3(Real(0.5), 0, 0);  // x in [0, 1], z in [-0.1, 0.1]
  ObjectDef def = gridCloth(spec);
  def.motion.bend.axis = Vec3d(0, 0, 1);
  def.motion.bend.along = Vec3d(1, 0, 0);
  def.motion.bend.curvature = kPi / 2;  // a quarter turn over the 1 m strip at the peak
  def.motion.bend.frequency = 0.5;      // the peak at t = 0.5 s
  World world = animatedWorld(def);
  for (int k = 0; k < 16; ++k) world.step(kDt);
  const auto x = world.positions(world.objectAt(0));
  const double radius = 2 / kPi;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double s = def.vertices[i].x(), z = def.vertices[i].z();
    const double theta = s / radius;
    // The arc from the origin with tangent x, turning towards z × x = y.
    expectNear(x[i], Vec3d(radius * std::sin(theta), radius * (1 - std::cos(theta)), z),
               "bent, vertex " + std::to_string(i));
  }
  // At a full period the strip is straight again.
  for (int k = 0; k < 48; ++k) world.step(kDt);
  for (std::size_t i = 0; i < x.size(); ++i)
    expectNear(world.positions(world.objectAt(0))[i], def.vertices[i].cast<double>(),
               "straight, vertex " + std::to_string(i));
}

// A rotating, bending body: the bend is applied to the rest shape, then the keyframed turn.
TEST(BentCollider, TurnsAfterBending) {
  ObjectDef def = panel();
  def.motion.pivot = Vec3d(0, 1, 0);
  def.motion.keyframes = {key(0, Vec3d::Zero(), Vec3d(0, 1, 0), 0),
                          key(1, Vec3d::Zero(), Vec3d(0, 1, 0), 120)};
  def.motion.bend.axis = Vec3d(0, 0, 1);
  def.motion.bend.along = Vec3d(1, 0, 0);
  def.motion.bend.curvature = 1;
  def.motion.bend.frequency = 0.25;
  World world = animatedWorld(def);
  for (int k = 0; k < 16; ++k) world.step(kDt);  // t = 0.5: κ = sin(π/4), 60°
  const double kappa = std::sin(kPi / 4);
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(kPi / 3, Vec3d(0, 1, 0)).toRotationMatrix();
  const auto x = world.positions(world.objectAt(0));
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Vec3d r = def.vertices[i].cast<double>() - def.motion.pivot;
    const double radius = 1 / kappa, theta = kappa * r.x();
    const Vec3d bent((radius - r.y()) * std::sin(theta),
                     radius - (radius - r.y()) * std::cos(theta), r.z());
    expectNear(x[i], turn * bent + def.motion.pivot, "vertex " + std::to_string(i));
  }
}

TEST(ColliderTargets, MoveTheMeshLinearlyOverTheSubstepsToTheTargets) {
  const ObjectDef def = panel();
  const int substeps = 4;
  World world = animatedWorld(def, substeps);
  const ObjectId id = world.objectAt(0);
  std::vector<Vec3> goal;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.3, Vec3d(0, 0, 1)).toRotationMatrix();
  for (const Vec3& r : def.vertices)
    goal.push_back((turn * r.cast<double>() + Vec3d(0.2, -0.1, 0.05)).cast<Real>());
  world.setColliderTargets(id, goal);
  world.step(kDt);
  const auto x = world.positions(id);
  const auto v = world.velocities();
  for (std::size_t i = 0; i < x.size(); ++i) {
    EXPECT_EQ(x[i], goal[i]) << "vertex " << i;
    // Linear over the substeps: the last one covers a quarter of the way in h = dt / 4, at the
    // mean velocity of the step.
    const Vec3d mean = (goal[i].cast<double>() - def.vertices[i].cast<double>()) / kDt;
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(v[i][k], mean[k], 4 * tolerance(2) * substeps / kDt) << "vertex " << i;
  }
  // No new targets: it stays where it is.
  world.step(kDt);
  for (std::size_t i = 0; i < x.size(); ++i) {
    EXPECT_EQ(world.positions(id)[i], goal[i]);
    EXPECT_EQ(world.velocities()[i], Vec3::Zero());
  }
}

// Animation never touches free particles: the same cloud falls the same with the collider still
// or animated, as long as it hits nothing.
TEST(KeyframedCollider, LeavesFreeParticlesUntouched) {
  ObjectDef cloud;
  for (int i = 0; i < 50; ++i) cloud.vertices.push_back(Vec3(Real(10 + 0.1 * i), 5, 0));
  cloud.velocity = Vec3(0, 1, Real(0.5));
  std::vector<Vec3> positions[2], velocities[2];
  for (int animated = 0; animated < 2; ++animated) {
    ObjectDef collider = animated ? turningPanel() : panel();
    World world;
    // The same substeps either way: none added for the turning panel's speed.
    SolverSettings settings = test::solverSettings(SolverKind::GaussSeidel, 2, 4);
    settings.maxKinematicTravel = 0;
    world.setSolver(settings);
    world.addCollider(collider);
    const ObjectId id = world.addParticles(cloud);
    test::simulate(world, 30, kDt);
    positions[animated].assign(world.positions(id).begin(), world.positions(id).end());
    velocities[animated].assign(world.velocities().end() - 50, world.velocities().end());
    EXPECT_EQ(world.recoveries().total(), 0u);
  }
  EXPECT_EQ(positions[0], positions[1]);
  EXPECT_EQ(velocities[0], velocities[1]);
}

std::string addError(const ObjectDef& def, bool collider = true) {
  World world;
  try {
    if (collider)
      world.addCollider(def);
    else
      world.addCloth(def);
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(world.objectCount(), 0u) << "a rejected object leaves the world unchanged";
    return e.what();
  }
  return "";
}

TEST(KinematicValidation, RejectsBadMotionsWithAClearMessage) {
  ObjectDef def = turningPanel();
  def.motion.keyframes[2].time = 0.5;
  EXPECT_NE(addError(def).find(
                "collider 'panel': keyframe 2 time 0.5 must be later than keyframe 1's time 0.5"),
            std::string::npos)
      << addError(def);

  def = turningPanel();
  def.motion.keyframes[1].axis = Vec3d::Zero();
  EXPECT_NE(addError(def).find("keyframe 1 axis must be finite and not zero"), std::string::npos);

  def = turningPanel();
  def.motion.keyframes[0].translation.y() = std::nan("");
  EXPECT_NE(addError(def).find("keyframe 0 translation must be finite"), std::string::npos);

  def = turningPanel();
  def.motion.keyframes[2].angle = kPi / 2 + kPi;  // half a turn from keyframe 1
  EXPECT_NE(addError(def).find("half a turn"), std::string::npos);

  def = turningPanel();
  def.velocity = Vec3(1, 0, 0);
  EXPECT_NE(addError(def).find("takes no velocity"), std::string::npos);

  def = turningPanel();
  EXPECT_NE(addError(def, false).find("only colliders can have a motion"), std::string::npos);

  def = panel();
  def.motion.bend.curvature = 1;
  def.motion.bend.frequency = 1;
  def.motion.bend.along = Vec3d(1, 0, 1);
  EXPECT_NE(addError(def).find("bend axis and along must be perpendicular"), std::string::npos);
  def.motion.bend.along = Vec3d(1, 0, 0);
  def.motion.bend.frequency = 0;
  EXPECT_NE(addError(def).find("bend frequency must be positive"), std::string::npos);
}

TEST(KinematicValidation, RejectsBadTargetsWithAClearMessage) {
  World world = animatedWorld(panel());
  const ObjectId id = world.objectAt(0);
  std::vector<Vec3> targets(world.positions(id).begin(), world.positions(id).end());
  auto message = [&](std::span<const Vec3> t, ObjectId target) -> std::string {
    try {
      world.setColliderTargets(target, t);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message(std::span<const Vec3>(targets).first(3), id),
            "setColliderTargets: collider 'panel' has 16 vertices, got 3 positions");
  targets[5].x() = std::numeric_limits<Real>::infinity();
  EXPECT_EQ(message(targets, id), "setColliderTargets: collider 'panel': position 5 is not finite");

  World other = animatedWorld(turningPanel());
  EXPECT_NE(std::string(message(targets, ObjectId{})).find("invalid object id"), std::string::npos);
  targets[5].x() = 0;
  try {
    other.setColliderTargets(other.objectAt(0), targets);
    ADD_FAILURE() << "targets for a collider with a motion";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("animated by its motion"), std::string::npos);
  }
  const ObjectId cloth = other.addCloth(panel());
  try {
    other.setColliderTargets(cloth, targets);
    ADD_FAILURE() << "targets for a cloth";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("is not a collider"), std::string::npos);
  }
}

const char* kMotionScene = R"({
  "frames": 4,
  "objects": [{"type": "collider", "name": "paddle",
               "shape": {"grid": {"resolution": [4, 4], "size": [1, 1], "center": [1, 1, 0]}},
               "motion": {"pivot": [0, 1, 0], "loop": true,
                          "keyframes": [{"time": 0},
                                        {"time": 0.5, "translation": [0, 1, 0], "axis": [0, 1, 0],
                                         "degrees": 90},
                                        {"time": 1, "degrees": 0}],
                          "bend": {"axis": [0, 0, 1], "along": [1, 0, 0],
                                   "degrees_per_meter": 45, "frequency": 2}}}]
})";

TEST(KinematicScene, ParsesAMotion) {
  const Scene scene = parseScene(kMotionScene, "test.json", ".");
  const ColliderMotion& m = scene.objects.at(0).def.motion;
  ASSERT_EQ(m.keyframes.size(), 3u);
  EXPECT_EQ(m.pivot, Vec3d(0, 1, 0));
  EXPECT_TRUE(m.loop);
  EXPECT_DOUBLE_EQ(m.keyframes[1].angle, kPi / 2);
  EXPECT_EQ(m.keyframes[1].translation, Vec3d(0, 1, 0));
  EXPECT_EQ(m.keyframes[2].axis, Vec3d(0, 1, 0));  // the default axis
  EXPECT_DOUBLE_EQ(m.bend.curvature, kPi / 4);
  EXPECT_EQ(m.bend.frequency, 2);
  World world = buildWorld(scene);
  test::simulate(world, 4);
  EXPECT_EQ(world.measure().nanCount, 0u);
}

using test::sceneError;

// kMotionScene with one substring replaced.
std::string motionScene(const std::string& from, const std::string& to) {
  return test::replaced(kMotionScene, from, to);
}

TEST(KinematicScene, NamesTheJsonPathOfAnError) {
  EXPECT_EQ(sceneError(motionScene("{\"time\": 1, \"degrees\": 0}", "{\"time\": 0.5}")),
            "test.json: objects[0].motion.keyframes[2].time: must be later than the previous "
            "keyframe's time 0.5, got 0.5");
  EXPECT_EQ(sceneError(motionScene("\"axis\": [0, 1, 0]", "\"axis\": [0, 0, 0]")),
            "test.json: objects[0].motion.keyframes[1].axis: must not be zero");
  EXPECT_EQ(sceneError(motionScene("\"degrees\": 90", "\"degres\": 90")),
            "test.json: objects[0].motion.keyframes[1]: unknown key 'degres'");
  EXPECT_EQ(sceneError(motionScene("\"along\": [1, 0, 0]", "\"along\": [1, 0, 1]")),
            "test.json: objects[0].motion.bend.along: must be perpendicular to 'axis'");
  EXPECT_EQ(sceneError(motionScene("\"frequency\": 2", "\"frequency\": -2")),
            "test.json: objects[0].motion.bend.frequency: must be in [1e-09, 1e+06], got -2");
  EXPECT_EQ(sceneError(motionScene("{\"time\": 0}", "{}")),
            "test.json: objects[0].motion.keyframes[0]: missing 'time'");
  EXPECT_EQ(sceneError(motionScene("\"collider\"", "\"cloth\"")),
            "test.json: objects[0].motion: only colliders can have a motion");
  EXPECT_EQ(sceneError(motionScene("\"loop\": true", "\"loop\": true, \"speed\": 1")),
            "test.json: objects[0].motion: unknown key 'speed'");
}

// A collider from an OBJ file: the flag is an open sheet, which a collider may be (it collides on
// both sides), and it can be animated like any other.
TEST(KinematicScene, AnimatesAnOpenColliderFromAnObjFile) {
  const std::string json = R"({
    "objects": [{"type": "collider", "shape": {"obj": "flag.obj"},
                 "motion": {"keyframes": [{"time": 0}, {"time": 1, "translation": [0, -1, 0]}]}}]
  })";
  const Scene scene = parseScene(json, "test.json", std::string(NUCLEON_ASSETS_DIR) + "/scenes");
  World world = buildWorld(scene);
  const ObjectId id = world.objectAt(0);
  EXPECT_EQ(world.kind(id), ObjectKind::Collider);
  EXPECT_FALSE(world.impl().state.objects.at(0).closed);
  EXPECT_EQ(world.surfaceTriangles(id).size(), scene.objects[0].def.triangles.size());
  for (int k = 0; k < 16; ++k) world.step(kDt);
  const auto x = world.positions(id);
  for (std::size_t i = 0; i < x.size(); ++i)
    expectNear(x[i], scene.objects[0].def.vertices[i].cast<double>() + Vec3d(0, -0.5, 0),
               "vertex " + std::to_string(i));
  // And a static one, as it is in the file.
  World still = buildWorld(parseScene(R"({"objects": [{"type": "collider",
                                                       "shape": {"obj": "flag.obj"}}]})",
                                      "test.json", "."));
  test::simulate(still, 3);
  const auto y = still.positions(still.objectAt(0));
  for (std::size_t i = 0; i < y.size(); ++i) EXPECT_EQ(y[i], scene.objects[0].def.vertices[i]);
}

// Animated pins (PinGroup): a ring of a cloth tube driven by a motion, the rest of the tube free.
// 16 around × 8 rings, radius 0.25 m, 1 m long about y, centred at y = 1.
TubeSpec smallTube() {
  TubeSpec spec;
  spec.resolution = {16, 8};
  spec.radiusBottom = spec.radiusTop = Real(0.25);
  spec.length = 1;
  spec.center = Vec3(0, 1, 0);
  return spec;
}

std::vector<Index> ring(const TubeSpec& spec, int k) {
  std::vector<Index> out;
  for (int j = 0; j < spec.resolution[0]; ++j) out.push_back(k * spec.resolution[0] + j);
  return out;
}

// The top ring turns a full revolution about the tube's axis in 1 s, the bottom ring is held
// still: the tube twists.
ObjectDef twistingTube() {
  const TubeSpec spec = smallTube();
  ObjectDef def = tube(spec);
  def.name = "tube";
  def.pins = ring(spec, 0);
  PinGroup top;
  top.vertices = ring(spec, spec.resolution[1] - 1);
  top.motion.pivot = Vec3d(0, 1.5, 0);
  for (int k = 0; k <= 4; ++k)
    top.motion.keyframes.push_back(key(0.25 * k, Vec3d::Zero(), Vec3d(0, 1, 0), 90 * k));
  def.pinGroups = {top};
  return def;
}

// At the end of every substep (one substep per step here, so every substep is observed) each
// animated pin is exactly where its track puts it: the same bits as posing the rest shape.
TEST(AnimatedPins, LandExactlyOnTheirTrackAtEverySubstepEnd) {
  const ObjectDef def = twistingTube();
  for (int substeps : {1, 4}) {
    World world;
    world.setSolver(test::solverSettings(SolverKind::ColoredGaussSeidel, 4, substeps));
    world.setThreads(2);
    const ObjectId id = world.addCloth(def);
    const KinematicTrack& track = world.impl().state.kinematics.tracks.at(0);
    ASSERT_EQ(track.particleCount, def.pinGroups[0].vertices.size());
    std::vector<Vec3> rest, pose(track.particleCount);
    for (Index v : def.pinGroups[0].vertices) rest.push_back(def.vertices[v]);
    for (int step = 0; step < 40; ++step) {
      world.step(kDt);
      posePositions(track, rest, world.time(), pose);
      const auto x = world.positions(id);
      for (std::size_t i = 0; i < rest.size(); ++i) {
        const Index v = def.pinGroups[0].vertices[i];
        ASSERT_EQ(x[v], pose[i]) << "substeps " << substeps << ", step " << step << ", pin " << v;
        // And where an independent rigid turn puts it: 360° per second about the y axis.
        const double degrees = 360 * std::min(world.time(), 1.0);  // held after the last key
        expectNear(x[v],
                   rigid(def.vertices[v], Vec3d(0, 1.5, 0), {0, 1, 0}, degrees, Vec3d::Zero()),
                   "pin " + std::to_string(v));
      }
    }
    EXPECT_EQ(world.recoveries().total(), 0u);
  }
}

// The top row of a hanging cloth is carried 1 m sideways in 1 s and then held: the free cloth
// follows it through its constraints and comes to hang below the pins' new place.
TEST(AnimatedPins, TheFreeClothFollows) {
  GridSpec spec;
  spec.resolution = {12, 12};
  spec.size = {1, 1};
  spec.center = Vec3(0, 1, 0);
  spec.vertical = true;  // row 0 at the top (y = 1.5)
  ObjectDef def = gridCloth(spec);
  PinGroup top;
  for (Index i = 0; i < 12; ++i) top.vertices.push_back(i);
  top.motion.keyframes = {key(0, Vec3d::Zero(), Vec3d(0, 1, 0), 0),
                          key(1, Vec3d(1, 0, 0), Vec3d(0, 1, 0), 0)};
  def.pinGroups = {top};
  def.material.damping = Real(0.01);
  World world;
  world.setSolver(test::solverSettings(SolverKind::ColoredGaussSeidel, 10, 2));
  const ObjectId id = world.addCloth(def);
  test::simulate(world, 240);  // 4 s: moved by 1 s, then 3 s to settle
  const auto x = world.positions(id);
  double meanShift = 0;
  for (Index i = 12; i < x.size(); ++i) meanShift += x[i].x() - def.vertices[i].x();
  meanShift /= static_cast<double>(x.size() - 12);
  EXPECT_NEAR(meanShift, 1.0, 0.05) << "the free cloth hangs below the moved pins";
  for (Index i = 0; i < 12; ++i) EXPECT_EQ(x[i], def.vertices[i] + Vec3(1, 0, 0));
  EXPECT_LT(world.measure().maxStrain, 0.05);
  EXPECT_EQ(world.recoveries().total(), 0u);
}

// Every pin of the turning ring stays on its circle: the radius about the axis is the rest
// radius, and it sits at its height, at every step, while the tube below twists.
TEST(AnimatedPins, ARotatingRingKeepsItsRadius) {
  const ObjectDef def = twistingTube();
  World world;
  world.setSolver(test::solverSettings(SolverKind::ColoredGaussSeidel, 10, 2));
  const ObjectId id = world.addCloth(def);
  const Vec3d pivot = def.pinGroups[0].motion.pivot;
  // The mean turn about y of ring k's vertices from their rest angles, right-handed.
  auto turnOfRing = [&](int k) {
    double sum = 0;
    for (Index v : ring(smallTube(), k)) {
      const Vec3 now = world.positions(id)[v], rest = def.vertices[v];
      sum +=
          std::remainder(std::atan2(-now.z(), now.x()) - std::atan2(-rest.z(), rest.x()), 2 * kPi);
    }
    return sum / 16;
  };
  for (int step = 1; step <= 60; ++step) {
    world.step(1.0 / 60);
    const auto x = world.positions(id);
    for (Index v : def.pinGroups[0].vertices) {
      const Vec3d r = x[v].cast<double>() - pivot;
      EXPECT_NEAR(std::hypot(r.x(), r.z()), 0.25, tolerance(1)) << "step " << step << ", pin " << v;
      EXPECT_NEAR(r.y(), 0, tolerance(1)) << "step " << step << ", pin " << v;
    }
    if (step == 15) {  // the top ring has turned a quarter of a revolution
      EXPECT_NEAR(turnOfRing(7), kPi / 2, 1e-5);
      EXPECT_GT(turnOfRing(4), 0.05) << "the twist reaches into the free tube";
      EXPECT_LT(turnOfRing(4), kPi / 2);
    }
  }
  EXPECT_EQ(world.recoveries().total(), 0u);
  EXPECT_EQ(world.measure().nanCount, 0u);
}

TEST(AnimatedPins, RejectsBadGroupsWithAClearMessage) {
  ObjectDef def = twistingTube();
  def.pinGroups[0].vertices.clear();
  EXPECT_NE(addError(def, false).find("cloth 'tube': pin group 0 has no vertices"),
            std::string::npos)
      << addError(def, false);

  def = twistingTube();
  def.pinGroups[0].vertices.push_back(999);
  EXPECT_NE(addError(def, false)
                .find("pin group 0: vertex 999 is out of range (the object has 128 vertices)"),
            std::string::npos)
      << addError(def, false);

  def = twistingTube();
  def.pinGroups[0].motion = ColliderMotion{};
  EXPECT_NE(addError(def, false).find("pin group 0 has no motion: give keyframes or a bend"),
            std::string::npos)
      << addError(def, false);

  def = twistingTube();
  def.pinGroups[0].vertices.push_back(3);  // a still pin of ring 0
  EXPECT_NE(addError(def, false).find("pin group 0: vertex 3 is also a still pin"),
            std::string::npos)
      << addError(def, false);

  def = twistingTube();
  def.pinGroups.push_back(def.pinGroups[0]);
  EXPECT_NE(addError(def, false).find("pin group 1: vertex 112 is also in pin group 0"),
            std::string::npos)
      << addError(def, false);

  def = twistingTube();
  def.pinGroups[0].motion.keyframes[2].time = 0.25;
  EXPECT_NE(
      addError(def, false)
          .find("pin group 0: keyframe 2 time 0.25 must be later than keyframe 1's time 0.25"),
      std::string::npos)
      << addError(def, false);

  def = panel();
  def.pinGroups = twistingTube().pinGroups;
  def.pinGroups[0].vertices = {0};
  EXPECT_NE(addError(def).find("a collider takes no pin groups"), std::string::npos);
}

const char* kPinScene = R"({
  "frames": 4,
  "objects": [{"type": "cloth", "name": "sleeve",
               "shape": {"tube": {"resolution": [12, 6], "radius": 0.2, "length": 0.8}},
               "pins": [0, 1],
               "pin_groups": [{"ring": -1,
                               "motion": {"pivot": [0, 1.4, 0], "loop": true,
                                          "keyframes": [{"time": 0},
                                                        {"time": 0.5, "degrees": 120},
                                                        {"time": 1, "degrees": 240},
                                                        {"time": 1.5, "degrees": 360}]}},
                              {"vertices": [30, 31],
                               "motion": {"keyframes": [{"time": 0},
                                                        {"time": 1, "translation": [0, 0.1, 0]}]}}]}]
})";

TEST(AnimatedPinScene, ParsesRingsAndVertexLists) {
  const Scene scene = parseScene(kPinScene, "test.json", ".");
  const ObjectDef& def = scene.objects.at(0).def;
  ASSERT_EQ(def.vertices.size(), 72u);
  ASSERT_EQ(def.pinGroups.size(), 2u);
  EXPECT_EQ(def.pinGroups[0].vertices, (std::vector<Index>{60, 61, 62, 63, 64, 65, 66, 67, 68, 69,
                                                           70, 71}));  // ring 5, the last
  EXPECT_EQ(def.pinGroups[1].vertices, (std::vector<Index>{30, 31}));
  EXPECT_TRUE(def.pinGroups[0].motion.loop);
  EXPECT_DOUBLE_EQ(def.pinGroups[0].motion.keyframes[3].angle, 2 * kPi);
  World world = buildWorld(scene);
  EXPECT_EQ(world.impl().state.kinematics.tracks.size(), 2u);
  const auto w = world.inverseMasses();
  EXPECT_EQ(std::count(w.begin(), w.end(), Real(0)), 2 + 12 + 2);
  test::simulate(world, 30);
  EXPECT_EQ(world.measure().nanCount, 0u);
  EXPECT_EQ(world.recoveries().total(), 0u);
}

// A pin group may share the motion of an animated collider given earlier, by its name: its pins
// then ride on the body exactly (the same track, the same bits).
TEST(AnimatedPinScene, SharesTheMotionOfANamedCollider) {
  const std::string json = R"({
    "objects": [{"type": "collider", "name": "body",
                 "shape": {"tube": {"resolution": [8, 3], "radius": 0.1, "length": 0.4,
                                    "caps": true}},
                 "motion": {"pivot": [0, 0.8, 0],
                            "keyframes": [{"time": 0}, {"time": 0.5, "degrees": 120},
                                          {"time": 1, "degrees": 240}],
                            "bend": {"axis": [0, 0, 1], "along": [0, 1, 0],
                                     "degrees_per_meter": 60, "frequency": 1}}},
                {"type": "cloth", "name": "skirt",
                 "shape": {"tube": {"resolution": [12, 4], "radius_top": 0.15,
                                    "radius_bottom": 0.25, "length": 0.3, "center": [0, 0.9, 0]}},
                 "pin_groups": [{"ring": -1, "motion": "body"}],
                 "material": {"thickness": 0.005}}]
  })";
  const Scene scene = parseScene(json, "test.json", ".");
  const ObjectDef& skirt = scene.objects.at(1).def;
  ASSERT_EQ(skirt.pinGroups.size(), 1u);
  EXPECT_EQ(skirt.pinGroups[0].motion.keyframes.size(), 3u);
  EXPECT_EQ(skirt.pinGroups[0].motion.pivot, Vec3d(0, 0.8, 0));
  EXPECT_EQ(skirt.pinGroups[0].motion.bend.frequency, 1);
  World world = buildWorld(scene);
  test::simulate(world, 20, kDt);
  const KinematicTrack& body = world.impl().state.kinematics.tracks.at(0);
  std::vector<Vec3> rest, posed(12);
  for (Index v : skirt.pinGroups[0].vertices) rest.push_back(skirt.vertices[v]);
  posePositions(body, rest, world.time(), posed);
  for (std::size_t i = 0; i < rest.size(); ++i)
    EXPECT_EQ(world.positions(world.objectAt(1))[skirt.pinGroups[0].vertices[i]], posed[i]);
  EXPECT_EQ(world.recoveries().total(), 0u);

  EXPECT_EQ(sceneError(std::string(json).replace(json.find("\"motion\": \"body\""), 16,
                                                 "\"motion\": \"bdoy\"")),
            "test.json: objects[1].pin_groups[0].motion: no animated collider named 'bdoy' before "
            "this object");
}

// kPinScene with one substring replaced.
std::string pinScene(const std::string& from, const std::string& to) {
  return test::replaced(kPinScene, from, to);
}

TEST(AnimatedPinScene, NamesTheJsonPathOfAnError) {
  EXPECT_EQ(sceneError(pinScene("\"vertices\": [30, 31]", "\"vertices\": [30, 72]")),
            "test.json: objects[0].pin_groups[1].vertices: vertex 72 is out of range (the shape "
            "has 72 vertices)");
  EXPECT_EQ(sceneError(pinScene("\"vertices\": [30, 31]", "\"vertices\": []")),
            "test.json: objects[0].pin_groups[1].vertices: expected a non-empty list of vertex "
            "indices");
  EXPECT_EQ(sceneError(pinScene("\"ring\": -1", "\"ring\": 6")),
            "test.json: objects[0].pin_groups[0].ring: must be in [-6, 5], got 6");
  EXPECT_EQ(sceneError(pinScene("\"ring\": -1", "\"ring\": -1, \"vertices\": [3]")),
            "test.json: objects[0].pin_groups[0]: give exactly one of 'vertices', 'ring'");
  EXPECT_EQ(sceneError(pinScene("\"vertices\": [30, 31]", "\"vertices\": [30, 1]")),
            "test.json: objects[0].pin_groups[1]: vertex 1 is already held by a pin");
  EXPECT_EQ(sceneError(pinScene("\"vertices\": [30, 31]", "\"vertices\": [30, 66]")),
            "test.json: objects[0].pin_groups[1]: vertex 66 is already held by pin group 0");
  EXPECT_EQ(sceneError(R"({"objects": [{"type": "cloth", "pin_groups": [{"vertices": [0],
                                          "motion": {"pivot": [0, 1, 0]}}],
                                        "shape": {"grid": {"resolution": [4, 4]}}}]})"),
            "test.json: objects[0].pin_groups[0].motion: give keyframes or a bend with non-zero "
            "degrees_per_meter");
  EXPECT_EQ(sceneError(R"({"objects": [{"type": "cloth", "pin_groups": [{"vertices": [0]}],
                                        "shape": {"grid": {"resolution": [4, 4]}}}]})"),
            "test.json: objects[0].pin_groups[0]: missing 'motion' (vertices held still are "
            "'pins')");
  EXPECT_EQ(sceneError(R"({"objects": [{"type": "cloth", "pin_groups": [{"ring": 0,
                                          "motion": {"keyframes": [{"time": 0}]}}],
                                        "shape": {"grid": {"resolution": [4, 4]}}}]})"),
            "test.json: objects[0].pin_groups[0].ring: only a tube shape has rings");
  EXPECT_EQ(sceneError(R"({"objects": [{"type": "cloth", "pin_groups": [],
                                        "shape": {"grid": {"resolution": [4, 4]}}}]})"),
            "test.json: objects[0].pin_groups: expected a non-empty list of {\"vertices\" or "
            "\"ring\", \"motion\"}");
  EXPECT_EQ(sceneError(R"({"objects": [{"type": "collider", "pin_groups": [{"vertices": [0],
                                          "motion": {"keyframes": [{"time": 0}]}}],
                                        "shape": {"grid": {"resolution": [4, 4]}}}]})"),
            "test.json: objects[0].pin_groups: a collider takes no pin groups (its motion moves "
            "all of it)");
}

}  // namespace
}  // namespace nucleon
