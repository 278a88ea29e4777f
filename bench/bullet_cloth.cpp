// The comparison cloth in Bullet's btSoftBody, built the way Bullet's own demos build cloth
// (btSoftRigidDynamicsWorld with the default soft-body solver), from the shared mesh: one node
// per vertex with nucleon's lumped mass (mass 0 pins a node), one link per mesh edge with the
// default material (linear stiffness kLST = 1: hard), optionally Bullet's bending links
// (generateBendingConstraints(2)), K position iterations, no velocity or drift iterations.
// stepSimulation(dt, 0) advances by exactly dt in one step; with S substeps it is called S times
// with dt/S (Bullet's own fixed substepping accumulates dt in single precision and may take one
// or three substeps where two were meant).
//
// Mesh scene: the icosphere's triangles as a btBvhTriangleMeshShape on a static btRigidBody (mass
// 0). Bullet's concave collision algorithm turns each triangle near the soft body into a convex
// prism (the triangle extruded 6 cm along both sides of its normal) and hands it to the soft
// body's collision mode: SDF_RS (the default) evaluates the prism's signed distance at the nodes
// from a sparse grid, CL_RS collides clusters (one per triangle of the cloth) with the prism.
#include <algorithm>
#include <chrono>
#include <memory>

#include "bench/cloth_case.h"

#ifdef NUCLEON_HAVE_BULLET
#include <BulletSoftBody/btDefaultSoftBodySolver.h>
#include <BulletSoftBody/btSoftBody.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <btBulletDynamicsCommon.h>
#endif

namespace nucleon::bench {

#ifdef NUCLEON_HAVE_BULLET

bool bulletAvailable() {
  return true;
}

namespace {

// Bullet's bending links: one link between every two nodes exactly two links apart, what
// btSoftBody::generateBendingConstraints(2) adds. That function builds a dense node×node distance
// table, which overflows int beyond 46 340 nodes (it crashes at 256²); the same set is found here
// by walking two rings of the edge graph.
void appendBendingLinks(btSoftBody& body, const ClothMesh& mesh) {
  const std::size_t n = mesh.def.vertices.size();
  std::vector<std::vector<int>> neighbours(n);
  for (const auto& e : mesh.edges) {
    neighbours[e[0]].push_back(int(e[1]));
    neighbours[e[1]].push_back(int(e[0]));
  }
  std::vector<int> mark(n, -1);  // mark[k] = i: k is i itself or a neighbour of i
  for (int i = 0; i < int(n); ++i) {
    mark[i] = i;
    for (int j : neighbours[i]) mark[j] = i;
    for (int j : neighbours[i])
      for (int k : neighbours[j])
        if (k > i && mark[k] != i) {
          mark[k] = i;  // once per pair
          body.appendLink(i, k, body.m_materials[0]);
          body.m_links[body.m_links.size() - 1].m_bbending = 1;
        }
  }
}

}  // namespace

RunResult runBulletCloth(const ClothCase& c, const ClothMesh& mesh) {
  using Clock = std::chrono::steady_clock;
  btSoftBodyRigidBodyCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher(&configuration);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver rigidSolver;
  btDefaultSoftBodySolver softSolver;
  btSoftRigidDynamicsWorld world(&dispatcher, &broadphase, &rigidSolver, &configuration,
                                 &softSolver);
  const btVector3 gravity(0, btScalar(-9.81), 0);
  world.setGravity(gravity);
  btSoftBodyWorldInfo& info = world.getWorldInfo();
  info.m_gravity = gravity;
  info.m_broadphase = &broadphase;
  info.m_dispatcher = &dispatcher;
  info.m_sparsesdf.Initialize();

  std::vector<btVector3> nodes;
  for (const Vec3& v : mesh.def.vertices) nodes.emplace_back(v.x(), v.y(), v.z());
  std::vector<btScalar> masses(mesh.mass.begin(), mesh.mass.end());
  auto* body = new btSoftBody(&info, int(nodes.size()), nodes.data(), masses.data());
  for (const auto& e : mesh.edges) body->appendLink(int(e[0]), int(e[1]));
  for (const auto& t : mesh.def.triangles) body->appendFace(int(t[0]), int(t[1]), int(t[2]));
  if (c.bending) appendBendingLinks(*body, mesh);
  body->m_cfg.piterations = c.iterations;
  body->m_cfg.viterations = 0;
  body->m_cfg.diterations = 0;
  body->m_cfg.citerations = c.iterations;
  body->m_cfg.kDF = c.friction;
  // The distance the soft body keeps from rigid shapes: against the mesh, the sum of the two
  // thicknesses, what nucleon keeps between cloth and collider.
  body->getCollisionShape()->setMargin(
      btScalar(c.scene == ClothScene::Mesh ? meshContactDistance(c) : double(c.thickness)));
  if (c.scene == ClothScene::Mesh && c.bulletCollision == BulletCollision::Cluster) {
    body->m_cfg.collisions = btSoftBody::fCollision::CL_RS;
    body->generateClusters(0);  // one cluster per triangle, as Bullet's cloth cluster demo
  } else {
    body->m_cfg.collisions = btSoftBody::fCollision::SDF_RS;  // Bullet's default
  }
  world.addSoftBody(body);

  btSphereShape sphereShape(c.sphereRadius);
  btRigidBody sphere(btRigidBody::btRigidBodyConstructionInfo(0, nullptr, &sphereShape));
  if (c.scene == ClothScene::Sphere) world.addRigidBody(&sphere);

  // The mesh scene's collider: the same triangles as nucleon's, in world coordinates.
  btTriangleMesh meshTriangles(/*use32bitIndices*/ true, /*use4componentVertices*/ false);
  std::unique_ptr<btBvhTriangleMeshShape> meshShape;
  std::unique_ptr<btRigidBody> meshBody;
  if (c.scene == ClothScene::Mesh) {
    const auto& v = mesh.collider.vertices;
    auto point = [&](Index i) { return btVector3(v[i].x(), v[i].y(), v[i].z()); };
    for (const auto& t : mesh.collider.triangles)
      meshTriangles.addTriangle(point(t[0]), point(t[1]), point(t[2]),
                                /*removeDuplicateVertices*/ false);
    meshShape = std::make_unique<btBvhTriangleMeshShape>(&meshTriangles,
                                                         /*useQuantizedAabbCompression*/ true);
    meshBody = std::make_unique<btRigidBody>(
        btRigidBody::btRigidBodyConstructionInfo(0, nullptr, meshShape.get()));
    // SDF_RS multiplies kDF by the rigid body's friction, CL_RS takes the smaller of the two:
    // with 1 here both give kDF, the case's coefficient.
    meshBody->setFriction(1);
    world.addRigidBody(meshBody.get());
  }

  RunResult r;
  std::vector<Vec3> x(nodes.size());
  auto read = [&] {
    for (int i = 0; i < body->m_nodes.size(); ++i) {
      const btVector3& p = body->m_nodes[i].m_x;
      x[i] = Vec3(Real(p.x()), Real(p.y()), Real(p.z()));
    }
  };
  double timed = 0;
  const btScalar substepLength = btScalar(c.dt / c.substeps);
  for (int step = 0; step < c.steps; ++step) {
    const auto start = Clock::now();
    for (int substep = 0; substep < c.substeps; ++substep) world.stepSimulation(substepLength, 0);
    // Bullet's soft-body demos drop stale cells of the sparse distance field once per frame; the
    // mesh scene creates cells for every prism the cloth passes.
    if (c.scene == ClothScene::Mesh) info.m_sparsesdf.GarbageCollect();
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    if (step >= c.warmup) timed += seconds;
    read();
    observeStep(c, mesh, x, step, r);
  }
  r.msPerStep = timed * 1e3 / (c.steps - c.warmup);
  finishRun(c, mesh, x, r);
  if (c.scene == ClothScene::Sphere) world.removeRigidBody(&sphere);
  if (meshBody) world.removeRigidBody(meshBody.get());
  world.removeSoftBody(body);
  delete body;
  return r;
}

#else

bool bulletAvailable() {
  return false;
}

RunResult runBulletCloth(const ClothCase&, const ClothMesh&) {
  return {};
}

#endif

}  // namespace nucleon::bench
