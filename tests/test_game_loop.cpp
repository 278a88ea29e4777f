// The game-loop controls of World (positions, velocities, impulses, drags, removed attachments):
// each does what its contract says, refuses bad input without changing the state, and a drag
// holds a particle with the compliance it was given.
#include <cmath>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "nucleon/shapes.h"
#include "nucleon/world.h"

namespace nucleon {
namespace {

struct Sheet {
  World world;
  ObjectId cloth, collider;
};

// A 16² sheet pinned at two corners, and a static collider far below it.
Sheet makeSheet() {
  Sheet s;
  GridSpec spec;
  spec.resolution = {16, 16};
  spec.size = {1, 1};
  ObjectDef def = gridCloth(spec);
  def.pins = {0, 15};
  s.cloth = s.world.addCloth(def);
  GridSpec floor;
  floor.resolution = {2, 2};
  floor.center = Vec3(0, -5, 0);
  s.collider = s.world.addCollider(gridCloth(floor));
  return s;
}

TEST(GameLoop, BadInputThrowsAndChangesNothing) {
  Sheet s = makeSheet();
  s.world.step(1.0 / 60);
  const std::uint64_t before = s.world.stateHash();
  const std::size_t n = s.world.positions(s.cloth).size();
  std::vector<Vec3> good(n, Vec3::Zero()), shorter(n - 1, Vec3::Zero()), nan(n, Vec3::Zero());
  nan[3].x() = std::nanf("");
  EXPECT_THROW(s.world.setPositions(s.cloth, shorter), std::invalid_argument);
  EXPECT_THROW(s.world.setPositions(s.cloth, nan), std::invalid_argument);
  EXPECT_THROW(s.world.setVelocities(s.cloth, nan), std::invalid_argument);
  EXPECT_THROW(s.world.setPositions(s.collider, std::vector<Vec3>(4, Vec3::Zero())),
               std::invalid_argument);
  EXPECT_THROW(s.world.applyImpulse(s.cloth, Index(n), Vec3(1, 0, 0)), std::invalid_argument);
  EXPECT_THROW(s.world.applyImpulse(s.cloth, Vec3(INFINITY, 0, 0)), std::invalid_argument);
  EXPECT_THROW(s.world.beginDrag(s.collider, 0, Vec3::Zero()), std::invalid_argument);
  EXPECT_THROW(s.world.beginDrag(s.cloth, Index(n), Vec3::Zero()), std::invalid_argument);
  EXPECT_THROW(s.world.moveDrag(7, Vec3::Zero()), std::invalid_argument);
  EXPECT_THROW(s.world.endDrag(7), std::invalid_argument);
  EXPECT_THROW(s.world.removeAttachment(7), std::invalid_argument);
  EXPECT_EQ(s.world.stateHash(), before);
  EXPECT_EQ(s.world.attachmentCount(), 0u);
}

TEST(GameLoop, ImpulsesChangeMomentumByExactlyJ) {
  Sheet s = makeSheet();
  const auto momentum = [&] {
    Vec3d sum = Vec3d::Zero();
    const auto v = s.world.velocities();
    const auto w = s.world.inverseMasses();
    for (std::size_t i = 0; i < s.world.positions(s.cloth).size(); ++i)
      if (w[i] > 0) sum += v[i].cast<double>() / double(w[i]);
    return sum;
  };
  const Vec3d start = momentum();
  s.world.applyImpulse(s.cloth, Vec3(0.5f, 0, -1));
  EXPECT_LT((momentum() - start - Vec3d(0.5, 0, -1)).norm(), 1e-5);
  // On one particle: Δv = w J; a pinned one (w = 0) does not move.
  const Vec3 v5 = s.world.velocities()[5];
  s.world.applyImpulse(s.cloth, 5, Vec3(0, 0.001f, 0));
  EXPECT_NEAR(s.world.velocities()[5].y() - v5.y(), s.world.inverseMasses()[5] * 0.001f, 1e-6);
  const Vec3 pinned = s.world.velocities()[0];
  s.world.applyImpulse(s.cloth, 0, Vec3(0, 5, 0));
  EXPECT_EQ(s.world.velocities()[0], pinned);
}

TEST(GameLoop, DragHoldsAParticleWhereTheHostMovesItAndLetsGo) {
  Sheet s = makeSheet();
  const Index corner = 255;  // free, far from the pins
  const Vec3 point = s.world.positions(s.cloth)[corner] + Vec3(0, 0.2f, 0);
  const std::size_t drag = s.world.beginDrag(s.cloth, corner, point, 0);  // hard
  for (int i = 0; i < 30; ++i) s.world.step(1.0 / 60);
  EXPECT_LT((s.world.positions(s.cloth)[corner] - point).norm(), 1e-3);
  // Moved: it follows.
  const Vec3 moved = point + Vec3(0.1f, 0, 0);
  s.world.moveDrag(drag, moved);
  for (int i = 0; i < 30; ++i) s.world.step(1.0 / 60);
  EXPECT_LT((s.world.positions(s.cloth)[corner] - moved).norm(), 1e-3);
  // Let go: it falls away; the released drag is not a break.
  s.world.endDrag(drag);
  for (int i = 0; i < 30; ++i) s.world.step(1.0 / 60);
  EXPECT_GT((s.world.positions(s.cloth)[corner] - moved).norm(), 0.1);
  EXPECT_EQ(s.world.brokenAttachments(), 0u);
  EXPECT_FALSE(s.world.attachmentBroken(drag));
  EXPECT_THROW(s.world.moveDrag(drag, moved), std::invalid_argument);  // no longer in progress
  EXPECT_THROW(s.world.endDrag(drag), std::invalid_argument);
}

TEST(GameLoop, SetPositionsAndVelocitiesTakeEffectInTheNextStep) {
  Sheet s = makeSheet();
  for (int i = 0; i < 10; ++i) s.world.step(1.0 / 60);
  const std::size_t n = s.world.positions(s.cloth).size();
  std::vector<Vec3> lifted(s.world.positions(s.cloth).begin(), s.world.positions(s.cloth).end());
  for (Vec3& p : lifted) p += Vec3(0, 1, 0);
  s.world.setPositions(s.cloth, lifted);
  s.world.setVelocities(s.cloth, std::vector<Vec3>(n, Vec3(0, 0, 0)));
  for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(s.world.positions(s.cloth)[i], lifted[i]);
  // One step from rest: every free particle falls at most g h² (the constraints between lifted
  // neighbours are as they were, so they pull nothing apart).
  s.world.step(1.0 / 60);
  const double gh2 = 9.81 / 3600.0;
  for (std::size_t i = 0; i < n; ++i)
    EXPECT_LT((s.world.positions(s.cloth)[i] - lifted[i]).norm(), 2 * gh2 + 1e-4) << i;
  EXPECT_EQ(s.world.recoveries().total(), 0u);
}

// The pressed contacts the viewer draws: none in free fall; on a sphere, points on its surface
// (within the contact distance).
TEST(GameLoop, ContactPointsLieWhereTheContactsPress) {
  World world;
  GridSpec spec;
  spec.resolution = {16, 16};
  spec.size = {1, 1};
  spec.center = Vec3(0, Real(0.55), 0);
  world.addCloth(gridCloth(spec));
  SphereCollider sphere;
  sphere.center = Vec3::Zero();
  sphere.radius = Real(0.5);
  world.addSphereCollider(sphere);
  std::vector<Vec3> points;
  world.step(1.0 / 60);
  world.contactPoints(points);
  EXPECT_TRUE(points.empty());  // 5 cm above the sphere, after one step of falling
  for (int i = 0; i < 30; ++i) world.step(1.0 / 60);
  world.contactPoints(points);
  ASSERT_FALSE(points.empty());
  for (const Vec3& p : points) EXPECT_NEAR(p.norm(), 0.5, 0.02) << p.transpose();
}

}  // namespace
}  // namespace nucleon
