// Animated colliders: keyframed rigid motion, the procedural bend and targets set through the API
// put the collider's particles exactly where the animation says at every substep's end, with the
// velocity of the substep's straight-line motion; bad input is rejected with a clear message.
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
#include "systems/kinematic_motion.h"

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
  GridSpec spec;
  spec.resolution = {4, 4};
  spec.size = {1, 1};
  spec.center = Vec3(1, 1, 0);
  spec.vertical = true;
  ObjectDef def = gridCloth(spec);
  def.name = "panel";
  return def;
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
    world.setSolver(test::solverSettings(SolverKind::GaussSeidel, 2, 4));
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

std::string sceneError(const std::string& json) {
  try {
    buildWorld(parseScene(json, "test.json", "."));
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

// kMotionScene with one substring replaced.
std::string motionScene(const std::string& from, const std::string& to) {
  std::string text = kMotionScene;
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
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

}  // namespace
}  // namespace nucleon
