// The comparison cloth in Bullet's btSoftBody, built the way Bullet's own demos build cloth
// (btSoftRigidDynamicsWorld with the default soft-body solver), from the shared mesh: one node
// per vertex with nucleon's lumped mass (mass 0 pins a node), one link per mesh edge with the
// default material (linear stiffness kLST = 1: hard), optionally Bullet's bending links
// (generateBendingConstraints(2)), K position iterations, no velocity or drift iterations.
// stepSimulation(dt, 0) advances by exactly dt in one step.
#include <algorithm>
#include <chrono>

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
  body->getCollisionShape()->setMargin(c.thickness);
  world.addSoftBody(body);

  btSphereShape sphereShape(c.sphereRadius);
  btRigidBody sphere(btRigidBody::btRigidBodyConstructionInfo(0, nullptr, &sphereShape));
  if (c.scene == ClothScene::Sphere) world.addRigidBody(&sphere);

  RunResult r;
  std::vector<Vec3> x(nodes.size());
  auto read = [&] {
    for (int i = 0; i < body->m_nodes.size(); ++i) {
      const btVector3& p = body->m_nodes[i].m_x;
      x[i] = Vec3(Real(p.x()), Real(p.y()), Real(p.z()));
    }
  };
  double timed = 0;
  for (int step = 0; step < c.steps; ++step) {
    const auto start = Clock::now();
    world.stepSimulation(btScalar(c.dt), 0);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    if (step >= c.warmup) timed += seconds;
    read();
    const StrainStats strain = measureStrain(mesh, x);
    r.peakMaxStrain = std::max(r.peakMaxStrain, strain.max);
    r.averageMeanStrain += strain.mean / c.steps;
  }
  r.msPerStep = timed * 1e3 / (c.steps - c.warmup);
  finishRun(c, mesh, x, r);
  if (c.scene == ClothScene::Sphere) world.removeRigidBody(&sphere);
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
