// Rigid bodies and deform resistance (Material::rigidity, shape matching) against physics: a rigid
// box keeps its shape through its impacts, a free collision of two rigid balls keeps momentum, a
// box on a trampoline comes to rest, and a rigidity below 1 holds a sheet's shape in part.
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <cmath>

#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"
#include "systems/solver/shape_matching.h"

using namespace nucleon;

namespace {

// Root-mean-square distance of an object's particles from the best rigid fit of its rest shape
// (Kabsch: centroid and polar rotation), over the rest shape's radius about its centroid.
double shapeError(std::span<const Vec3> x, std::span<const Vec3> rest) {
  Vec3d c = Vec3d::Zero(), c0 = Vec3d::Zero();
  for (std::size_t i = 0; i < x.size(); ++i) c += x[i].cast<double>(), c0 += rest[i].cast<double>();
  c /= double(x.size()), c0 /= double(x.size());
  Mat3d a = Mat3d::Zero();
  double radius = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    a += (x[i].cast<double>() - c) * (rest[i].cast<double>() - c0).transpose();
    radius = std::max(radius, (rest[i].cast<double>() - c0).norm());
  }
  const Mat3d r = polarRotation(a);
  double sum = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    sum += (x[i].cast<double>() - (c + r * (rest[i].cast<double>() - c0))).squaredNorm();
  return std::sqrt(sum / double(x.size())) / radius;
}

Vec3d momentum(const World& world) {
  Vec3d p = Vec3d::Zero();
  const auto v = world.velocities();
  const auto w = world.inverseMasses();
  for (std::size_t i = 0; i < v.size(); ++i)
    if (w[i] > 0) p += v[i].cast<double>() / double(w[i]);
  return p;
}

GroundPlane ground() {
  GroundPlane g;
  g.enabled = true;
  return g;
}

}  // namespace

TEST(Rigidity, PolarRotationIsTheNearestRotation) {
  const Mat3d turn = Eigen::AngleAxisd(0.7, Vec3d(1, 2, 3).normalized()).toRotationMatrix();
  Mat3d stretch;
  stretch << 2, 0.3, 0, 0.3, 1, 0.1, 0, 0.1, 0.5;  // symmetric positive definite
  const Mat3d r = polarRotation(turn * stretch);
  EXPECT_LT((r - turn).norm(), 1e-12);
  EXPECT_NEAR(r.determinant(), 1, 1e-12);
  // A reflection is not a rotation: det A < 0 still gives det R = +1.
  EXPECT_NEAR(polarRotation(-Mat3d::Identity()).determinant(), 1, 1e-12);
}

// A rigid box (0.3 m, 56 particles) dropped tilted from 0.5 m onto the ground bounces, tumbles and
// settles within the first second. After its impacts its shape error is below 1e-3 of its radius
// at every frame end (the required bound; measured 1.3e-4). In the frame of an impact it is larger:
// the ground's contacts are projected particle by particle after each round's shape matching, and
// the last round's leave the struck corner pushed in by what the rounds have not yet carried to
// the whole body (measured 1.7e-2 of the radius with 10 sweeps, 5.3e-3 with 40; bound 2e-2). It
// comes to rest on a face, its lowest corner at the ground's thickness.
TEST(Rigidity, ARigidBoxKeepsItsShapeThroughItsImpacts) {
  ObjectDef box = boxSurface(Vec3(0, Real(0.5), 0), Vec3(Real(0.3), Real(0.3), Real(0.3)), 3);
  const Eigen::Matrix<Real, 3, 3> tilt =
      Eigen::AngleAxis<Real>(Real(0.5), Vec3(1, 0, 1).normalized()).toRotationMatrix();
  for (Vec3& v : box.vertices) v = Vec3(0, Real(0.5), 0) + tilt * (v - Vec3(0, Real(0.5), 0));
  box.material.mass = 1;
  box.material.rigidity = 1;
  box.material.thickness = Real(0.005);
  const std::vector<Vec3> rest = box.vertices;
  World world;
  world.setGround(ground());
  world.setSolver(test::solverSettings(SolverKind::Multigrid, 10, 2));
  const ObjectId id = world.addCloth(box);
  double worstInImpacts = 0, worstAfter = 0;
  for (int frame = 0; frame < 180; ++frame) {
    world.step(1.0 / 60);
    const double error = shapeError(world.positions(id), rest);
    (frame < 60 ? worstInImpacts : worstAfter) =
        std::max(frame < 60 ? worstInImpacts : worstAfter, error);
  }
  EXPECT_LT(worstInImpacts, 2e-2);
  EXPECT_LT(worstAfter, 1e-3);
  const Measures m = world.measure();
  EXPECT_LT(m.kineticEnergy, 1e-3);  // at rest (the drop released 1.5 J)
  EXPECT_NEAR(m.minHeight, 0.005, 1e-3);
  EXPECT_EQ(world.recoveries().total(), 0u);
}

// Two rigid balls in zero gravity, one at 1.5 m/s striking the other at rest off-centre: the
// contacts push both ways with the particles' masses and shape matching moves each ball's
// particles as one body, so the total linear momentum after the impact is within 1% of what it
// was (the required bound), and the struck ball carries a good part of it away. Measured: 3e-6 in
// the serial Gauss–Seidel backend, whose contacts are projected one by one; 0.54% in the parallel
// backends (multigrid, colored-gs, Jacobi), whose contact rounds move each particle by the mean of
// its pressed contacts' corrections (not exactly opposite for the two sides) and whose fail-safe
// stopped 35 particles at the impact (0.28% at 1 m/s with none stopped, 0.93% at 2 m/s).
TEST(Rigidity, AFreeCollisionOfTwoRigidBallsKeepsMomentum) {
  for (SolverKind kind : {SolverKind::GaussSeidel, SolverKind::Multigrid, SolverKind::Jacobi}) {
    SCOPED_TRACE(toString(kind));
    World world;
    world.setGravity(Vec3::Zero());
    world.setSolver(test::solverSettings(kind, 10, 2));
    ObjectDef a = icosphere(Vec3(Real(-0.3), 1, 0), Real(0.12), 2);
    a.material.mass = Real(0.6);
    a.material.rigidity = 1;
    a.material.thickness = Real(0.004);
    a.velocity = Vec3(Real(1.5), 0, 0);
    ObjectDef b = icosphere(Vec3(Real(0.3), Real(1.06), 0), Real(0.12), 2);
    b.material = a.material;
    b.material.mass = Real(0.4);
    world.addCloth(a);
    const ObjectId struck = world.addCloth(b);
    const Vec3d before = momentum(world);
    EXPECT_NEAR(before.x(), 0.9, 1e-5);
    for (int frame = 0; frame < 45; ++frame) world.step(1.0 / 60);
    const Vec3d after = momentum(world);
    EXPECT_LT((after - before).norm(), 0.01 * before.norm());
    const std::size_t first = world.positions(world.objectAt(0)).size();
    Vec3d struckMomentum = Vec3d::Zero();
    for (const Vec3& v : world.velocities().subspan(first, world.positions(struck).size()))
      struckMomentum += v.cast<double>() * (0.4 / double(world.positions(struck).size()));
    EXPECT_GT(struckMomentum.x(), 0.2 * before.x());
    EXPECT_GT(world.collisionReport().contacts, 0u);
    EXPECT_EQ(world.recoveries().total(), 0u);
  }
}

// A rigid 0.2 m box of 0.5 kg set down on a rug lying on the ground, the stack that jitters where
// contacts fight: after two seconds the kinetic energy of everything is below 1e-5 J (the box at
// 6 mm/s would have 1e-5 J; the box's 5 mm fall released 2.5e-2 J), it is still rigid, and it
// rests on the rug: its lowest particle at the ground's thickness (where the rug lies) plus the
// two objects' thicknesses. The rug weighs 3 kg: its particles are a fifth of the box's. Under a
// light cloth (0.3 kg, particles 37 times lighter than the box's) the box presses the cloth's
// particles into the ground contact by contact, the ground pushes them back, and the box ends
// within the cloth's layer (its bottom at 3.2 mm against 7): the contacts lack the mass scaling of
// a stack (shock propagation), which is not built.
TEST(Rigidity, ABoxSetDownOnAClothComesToRest) {
  World world;
  world.setSolver(test::solverSettings(SolverKind::Multigrid, 10, 4));
  GroundPlane floor = ground();
  floor.thickness = Real(0.003);
  world.setGround(floor);
  GridSpec spec;
  spec.resolution = {24, 24};
  spec.size = {1, 1};
  spec.center = Vec3(0, Real(0.004), 0);
  ObjectDef cloth = gridCloth(spec);
  cloth.material.mass = 3;
  cloth.material.thickness = Real(0.002);
  world.addCloth(cloth);
  ObjectDef box = boxSurface(Vec3(0, Real(0.114), 0), Vec3(Real(0.2), Real(0.2), Real(0.2)), 2);
  box.material.mass = Real(0.5);
  box.material.rigidity = 1;
  box.material.thickness = Real(0.002);
  const std::vector<Vec3> rest = box.vertices;
  const ObjectId id = world.addCloth(box);
  for (int frame = 0; frame < 120; ++frame) world.step(1.0 / 60);
  const Measures m = world.measure();
  EXPECT_LT(m.kineticEnergy, 1e-5);
  EXPECT_LT(shapeError(world.positions(id), rest), 1e-3);
  double lowest = 1;
  for (const Vec3& x : world.positions(id)) lowest = std::min(lowest, double(x.y()));
  EXPECT_NEAR(lowest, 0.003 + 0.002 + 0.002, 1e-3);
  EXPECT_EQ(m.intersections, 0u);
  EXPECT_EQ(world.recoveries().total(), 0u);
}

// Rigidity below 1 resists deformation in part (Nucleus's deform resistance): a 0.6 m sheet
// dropped onto a ball 0.2 m across drapes over it, its corners hanging down; the more rigid it is,
// the less they droop, and at rigidity 1 it lies flat across the ball like a board. Measured, the
// centre's height above the corners after 1.5 s at rigidity 0, 0.05, 0.3 and 1: 0.26, 0.066,
// 0.031 and 0.006 m.
TEST(Rigidity, DeformResistanceHoldsASheetsShapeInPart) {
  std::vector<double> droops;
  for (Real rigidity : {Real(0), Real(0.05), Real(0.3), Real(1)}) {
    World world;
    world.setSolver(test::solverSettings(SolverKind::Multigrid, 10, 2));
    SphereCollider ball;
    ball.center = Vec3(0, Real(0.3), 0);
    ball.radius = Real(0.1);
    world.addSphereCollider(ball);
    GridSpec spec;
    spec.resolution = {20, 20};
    spec.size = {Real(0.6), Real(0.6)};
    spec.center = Vec3(0, Real(0.45), 0);
    ObjectDef sheet = gridCloth(spec);
    sheet.material.mass = Real(0.1);
    sheet.material.thickness = Real(0.004);
    sheet.material.rigidity = rigidity;
    sheet.material.bending = true;  // a little bending keeps the free sheet from crumpling
    sheet.material.bendCompliance = Real(1);
    const ObjectId id = world.addCloth(sheet);
    for (int frame = 0; frame < 90; ++frame) world.step(1.0 / 60);
    const auto x = world.positions(id);
    const double corners = (x[0].y() + x[19].y() + x[380].y() + x[399].y()) / 4;
    droops.push_back(x[190].y() - corners);
    EXPECT_EQ(world.measure().nanCount, 0u);
    EXPECT_EQ(world.recoveries().total(), 0u);
  }
  for (std::size_t k = 1; k < droops.size(); ++k) EXPECT_LT(droops[k], droops[k - 1]);
  EXPECT_GT(droops[0], 0.15);  // draped
  EXPECT_LT(droops[3], 0.01);  // a board
}

TEST(Rigidity, BadRigidityIsRefused) {
  World world;
  ObjectDef ball = icosphere(Vec3::Zero(), 1, 1);
  ball.material.rigidity = Real(1.5);
  EXPECT_THROW(world.addCloth(ball), std::invalid_argument);
  ball.material.rigidity = 1;
  ball.pins = {0};
  EXPECT_THROW(world.addCloth(ball), std::invalid_argument);
  ball.pins.clear();
  EXPECT_THROW(world.addCollider(ball), std::invalid_argument);
  EXPECT_EQ(world.objectCount(), 0u);
  const auto errorOf = test::sceneError;
  EXPECT_NE(errorOf(R"({"name": "r", "objects": [{"type": "cloth", "shape": {"box": {}},
                       "material": {"rigidity": 2}}]})")
                .find("objects[0].material.rigidity"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"name": "r", "objects": [{"type": "collider", "shape": {"box": {}},
                       "material": {"rigidity": 1}}]})")
                .find("objects[0].material.rigidity"),
            std::string::npos);
  const Scene scene = parseScene(R"({"name": "r", "objects": [{"type": "cloth", "shape":
      {"box": {"size": [0.2, 0.3, 0.4], "cells": 3, "turn": 30}}, "material": {"rigidity": 1}}]})",
                                 "test", "");
  EXPECT_EQ(scene.objects[0].def.material.rigidity, 1);
  EXPECT_EQ(scene.objects[0].def.vertices.size(), 56u);  // 4³ − 2³ lattice points on the surface
}
