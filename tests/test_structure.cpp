// The engine's structure as a newcomer relies on it: the step graph follows from what each stage
// declares it reads and writes; the per-substep contact pool reuses its storage; every bundled
// scene gives the same state for one and two threads under every backend.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "engine/src/step_graph.h"
#include "engine/src/world_state.h"
#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"

namespace nucleon {
namespace {

int stageIndex(const char* name) {
  const auto stages = StepGraph::stages();
  for (std::size_t s = 0; s < stages.size(); ++s)
    if (std::string(stages[s].name) == name) return static_cast<int>(s);
  ADD_FAILURE() << "no stage " << name;
  return -1;
}

bool hasEdge(const StepGraph& graph, const char* from, const char* to) {
  const std::array<int, 2> edge = {stageIndex(from), stageIndex(to)};
  return std::find(graph.edges().begin(), graph.edges().end(), edge) != graph.edges().end();
}

TEST(StepGraph, OrdersConflictingStagesAndRunsIndependentOnesSideBySide) {
  World world = test::hangingCloth(8, 2);
  world.step(1.0 / 60);  // builds the graph
  const StepGraph& graph = *world.impl().graph;
  // Contact detection reads x and v only, so it waits for the forces but not for predict.
  EXPECT_TRUE(hasEdge(graph, "forces", "predict"));
  EXPECT_TRUE(hasEdge(graph, "forces", "detect contacts"));
  EXPECT_FALSE(hasEdge(graph, "predict", "detect contacts"));
  EXPECT_TRUE(hasEdge(graph, "predict", "solve"));
  EXPECT_TRUE(hasEdge(graph, "detect contacts", "solve"));
  EXPECT_TRUE(hasEdge(graph, "solve", "update"));
  // The animation sets the animated colliders' velocities after the forces and before anything
  // reads them, and puts the colliders on their track once update has moved them.
  EXPECT_TRUE(hasEdge(graph, "forces", "animate"));
  EXPECT_TRUE(hasEdge(graph, "animate", "predict"));
  EXPECT_TRUE(hasEdge(graph, "animate", "detect contacts"));
  EXPECT_FALSE(hasEdge(graph, "animate", "solve"));
  EXPECT_TRUE(hasEdge(graph, "update", "finish animation"));
  // Every edge goes forwards (declaration order is a topological order: no cycles).
  for (const auto& [from, to] : graph.edges()) EXPECT_LT(from, to);
}

// A cloth resting flat on the ground has the same contacts every substep: once warm, the pool is
// refilled into the same storage (no allocation in the step).
// The step diagram in ARCHITECTURE.md names every stage of the graph: a stage added to the code
// without its place in the diagram fails here.
TEST(StepGraph, ArchitectureDiagramNamesEveryStage) {
  const std::filesystem::path map =
      std::filesystem::path(NUCLEON_ASSETS_DIR).parent_path() / "ARCHITECTURE.md";
  std::ifstream in(map);
  ASSERT_TRUE(in) << map;
  std::stringstream text;
  text << in.rdbuf();
  const std::string doc = text.str();
  const std::size_t begin = doc.find("### Step graph");
  ASSERT_NE(begin, std::string::npos) << "ARCHITECTURE.md has no 'Step graph' section";
  const std::size_t end = doc.find("\n#", begin + 1);
  const std::string section = doc.substr(begin, end == std::string::npos ? end : end - begin);
  ASSERT_FALSE(StepGraph::stages().empty());
  for (const StageDeclaration& stage : StepGraph::stages()) {
    std::string quoted(1, '"');
    quoted.append(stage.name).push_back('"');
    EXPECT_NE(section.find(quoted), std::string::npos)
        << "the step diagram does not name the stage " << quoted;
  }
}

TEST(ContactPool, IsRefilledEverySubstepIntoTheSameStorage) {
  GridSpec spec;
  spec.resolution = {16, 16};
  spec.center = Vec3(0, Real(0.0051), 0);
  GroundPlane ground;
  ground.enabled = true;
  World world;
  world.setGround(ground);
  world.addCloth(gridCloth(spec));
  test::simulate(world, 10);
  const ContactPool& pool = world.impl().state.contacts;
  ASSERT_EQ(pool.size(), 256u);  // every particle touches the ground
  const Index* particles = pool.particle.data();
  const Vec3* friction = pool.friction.data();
  test::simulate(world, 30);
  EXPECT_EQ(pool.size(), 256u);
  EXPECT_EQ(pool.particle.data(), particles);
  EXPECT_EQ(pool.friction.data(), friction);
  // In particle order, one contact each.
  for (std::size_t c = 0; c < pool.size(); ++c) EXPECT_EQ(pool.particle[c], Index(c));
  EXPECT_EQ(world.recoveries().total(), 0u);
}

// Removing the ground leaves no contact behind (a stale contact would name a collider that no
// longer exists).
TEST(ContactPool, IsEmptiedWhenTheCollidersGo) {
  GroundPlane ground;
  ground.enabled = true;
  World world = test::hangingCloth(8, 2);
  world.setGround(ground);
  GridSpec spec;
  spec.resolution = {4, 4};
  spec.center = Vec3(3, Real(0.0051), 0);
  world.addCloth(gridCloth(spec));
  test::simulate(world, 3);
  EXPECT_GT(world.impl().state.contacts.size(), 0u);
  ground.enabled = false;
  world.setGround(ground);
  test::simulate(world, 1);
  EXPECT_EQ(world.impl().state.contacts.size(), 0u);
}

class SceneDeterminism : public testing::TestWithParam<std::string> {};

TEST_P(SceneDeterminism, SameStateForOneAndTwoThreads) {
#if defined(__SANITIZE_ADDRESS__)
  // Determinism is a property of the arithmetic, which the Release and double builds check; the
  // sanitizer build runs every bundled scene already (test_bundled_scenes.cpp), and running each
  // twice more adds nothing it could find (it does not detect data races).
  GTEST_SKIP() << "thread-count determinism is checked in the Release and double builds";
#endif
  Scene scene = loadScene(std::string(NUCLEON_ASSETS_DIR) + "/scenes/" + GetParam() + ".json");
  // Enough steps for every scene to reach its contacts or its pins' pull; few enough for the
  // sanitizer build. A self-colliding object has primitive contacts from the first step (its
  // neighbouring primitives are within reach), so a few steps exercise the collision stages.
  std::size_t particles = 0;
  bool selfColliding = false, liquid = false;
  for (const SceneObject& o : scene.objects) {
    particles += o.def.vertices.size();
    selfColliding |= o.def.material.selfCollision;
    liquid |= o.def.material.liquid.enabled;
  }
  // The largest (cloth_hang_388, 150 k particles) builds its tables eight times: one step. A
  // small liquid's neighbours and density constraints act from the first step; water_on_cloth's
  // water reaches the cloth in the sixth.
  const int steps = particles > 100000                  ? 1
                    : particles > 5000 || selfColliding ? 4
                    : liquid                            ? 8
                                                        : 30;
  for (SolverKind kind : {SolverKind::GaussSeidel, SolverKind::Jacobi,
                          SolverKind::ColoredGaussSeidel, SolverKind::Multigrid}) {
    scene.solver.kind = kind;
    std::uint64_t hashes[2];
    for (int threads : {1, 2}) {
      scene.threads = threads;
      World world = buildWorld(scene);
      test::simulate(world, steps, 1.0 / scene.fps);
      hashes[threads - 1] = world.stateHash();
      EXPECT_EQ(world.recoveries().total(), 0u) << toString(kind);
    }
    EXPECT_EQ(hashes[0], hashes[1]) << toString(kind);
  }
}

INSTANTIATE_TEST_SUITE_P(Bundled, SceneDeterminism, testing::ValuesIn(test::bundledSceneNames()),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

}  // namespace
}  // namespace nucleon
