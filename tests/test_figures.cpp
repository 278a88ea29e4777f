// Figures that can fail: the repairs the step counts (World::recoveries, and through the command
// line's stats) rise when the state goes non-finite, and the strain figures (percentile, the two
// signs of the strain apart, tether violation) match values worked out by hand.
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/app/cli.h"
#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"
#include "systems/diagnostics/measures.h"

namespace nucleon {
namespace {

namespace fs = std::filesystem;

constexpr double kDt = 1.0 / 60;
constexpr Real kLargest = std::numeric_limits<Real>::max();

// A rope of `segments` unit segments along x from the origin, optionally pinned at vertex 0.
ObjectDef straightRope(int segments, bool pinned) {
  ObjectDef rope = polylineRope(Vec3(0, 0, 0), Vec3(Real(segments), 0, 0), segments);
  if (pinned) rope.pins = {0};
  return rope;
}

// A world holding one rope whose positions are then set by hand; no step is taken, so the
// measures see exactly these positions.
World ropeAt(const std::vector<Real>& xs, bool pinned) {
  World world;
  world.addRope(straightRope(static_cast<int>(xs.size()) - 1, pinned));
  std::vector<Vec3>& x = world.impl().state.particles.x;
  for (std::size_t i = 0; i < xs.size(); ++i) x[i] = Vec3(xs[i], 0, 0);
  return world;
}

// Vertex positions along x for unit segments of the given strains (length 1 + s each).
std::vector<Real> positionsForStrains(const std::vector<double>& strains) {
  std::vector<Real> xs = {0};
  double at = 0;
  for (double s : strains) xs.push_back(static_cast<Real>(at += 1 + s));
  return xs;
}

TEST(Recoveries, ParticleWhosePredictionOverflowsIsRepairedAndCounted) {
  auto build = [] {
    World world;
    SolverSettings settings;
    settings.kind = SolverKind::GaussSeidel;
    world.setSolver(settings);
    world.setThreads(1);
    world.addRope(straightRope(8, true));
    return world;
  };
  World world = build(), reference = build();
  for (int i = 0; i < 3; ++i) {
    world.step(kDt);
    reference.step(kDt);
  }
  EXPECT_EQ(world.recoveries().total(), 0u);
  EXPECT_EQ(world.recoveries().firstStep, 0u);

  // A finite start whose prediction x + h v is not: the step must repair it, not carry it.
  ObjectDef bad;
  bad.name = "runaway";
  bad.vertices = {Vec3(Real(0.999) * kLargest, 0, 0)};
  bad.velocity = Vec3(kLargest, 0, 0);
  world.addParticles(bad);
  for (int i = 0; i < 3; ++i) {
    world.step(kDt);
    reference.step(kDt);
  }

  const Recoveries& r = world.recoveries();
  EXPECT_EQ(r.nonFinite, 1u);  // once: it kept its position and lost its velocity
  EXPECT_EQ(r.missedContacts, 0u);
  EXPECT_EQ(r.total(), 1u);
  EXPECT_EQ(r.firstStep, 4u);               // the first step after it was added, 1-based
  EXPECT_EQ(world.measure().nanCount, 0u);  // nothing non-finite is left in the state
  const Vec3 runaway = world.positions(world.objectAt(1))[0];
  EXPECT_TRUE(runaway.allFinite());
  EXPECT_EQ(runaway.x(), Real(0.999) * kLargest);

  // The rope beside it never saw it: the same state as in a world without it.
  const auto rope = world.positions(world.objectAt(0));
  const auto alone = reference.positions(reference.objectAt(0));
  ASSERT_EQ(rope.size(), alone.size());
  for (std::size_t i = 0; i < rope.size(); ++i) EXPECT_EQ(rope[i], alone[i]) << "vertex " << i;
  EXPECT_EQ(reference.recoveries().total(), 0u);
}

// Writes `text` to a file in a fresh temporary folder, returns the folder.
class TemporaryFolder {
 public:
  explicit TemporaryFolder(const std::string& name)
      : path_(fs::temp_directory_path() / ("nucleon_figures_" + name)) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TemporaryFolder() { fs::remove_all(path_); }
  std::string write(const std::string& file, const std::string& text) const {
    std::ofstream(path_ / file) << text;
    return (path_ / file).string();
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// Scene numbers are bounded (±1e9), so a scene cannot state an absurd value directly; an OBJ
// vertex can, up to the largest float (the OBJ reader's range). A particle at −half the largest
// float sits deep below the ground: the contact pushes it to the surface, and the velocity that
// move implies, depth / h, overflows a float. The step repairs it every frame (one substep each).
// With double precision no input a scene accepts gets near overflow; the API test above covers that
// build.
TEST(Recoveries, RunStatsReportRepairsAndNonFiniteValues) {
  if constexpr (sizeof(Real) != sizeof(float))
    GTEST_SKIP() << "no scene file reaches a non-finite value in double precision";
  TemporaryFolder folder("run_stats");
  char vertex[128];
  std::snprintf(vertex, sizeof vertex, "v 0 %.9g 0\n",
                -0.5 * double(std::numeric_limits<float>::max()));
  folder.write("deep.obj", vertex);
  const std::string scene = folder.write("deep.json", R"({
    "name": "deep", "frames": 3, "fps": 60, "solver": { "substeps": 1 },
    "ground": { "height": 0 },
    "objects": [ { "type": "particles", "shape": { "obj": "deep.obj" } } ]
  })");
  const std::string stats = folder.file("stats.json");
  std::ostringstream out, err;
  ASSERT_EQ(runCommandLine({"run", scene, "--quiet", "--stats", stats}, out, err), 0) << err.str();
  const nlohmann::json j = readJson(stats);
  EXPECT_EQ(j.at("recoveries").get<int>(), 3);  // one per frame
  EXPECT_EQ(j.at("recoveries_by_kind").at("non_finite").get<int>(), 3);
  EXPECT_EQ(j.at("recoveries_by_kind").at("missed_contacts").get<int>(), 0);
  EXPECT_EQ(j.at("first_recovery_frame").get<int>(), 1);
  EXPECT_GT(j.at("nan_count").get<int>(), 0);
  EXPECT_GE(j.at("nan_count").get<int>(), j.at("recoveries_by_kind").at("non_finite").get<int>());
  EXPECT_NE(out.str().find("recoveries 3 (first at frame 1)"), std::string::npos) << out.str();
}

TEST(Recoveries, CleanRunReportsNone) {
  TemporaryFolder folder("clean");
  const std::string scene = folder.write("rope.json", R"({
    "name": "rope", "frames": 10, "fps": 60,
    "objects": [ { "type": "rope", "pins": [0],
                   "shape": { "polyline": { "from": [0, 1, 0], "to": [1, 1, 0], "segments": 8 } } } ]
  })");
  const std::string stats = folder.file("stats.json");
  std::ostringstream out, err;
  ASSERT_EQ(runCommandLine({"run", scene, "--quiet", "--stats", stats}, out, err), 0) << err.str();
  const nlohmann::json j = readJson(stats);
  EXPECT_EQ(j.at("recoveries").get<int>(), 0);
  EXPECT_TRUE(j.at("first_recovery_frame").is_null());
  EXPECT_EQ(j.at("nan_count").get<int>(), 0);
  EXPECT_NE(out.str().find("recoveries 0,"), std::string::npos) << out.str();
}

TEST(StrainFigures, NearestRankPercentile) {
  std::vector<double> hundred;
  for (int i = 100; i >= 1; --i) hundred.push_back(i);
  EXPECT_EQ(nearestRankPercentile(hundred, 0.99), 99);  // rank 99 of 100
  std::vector<double> ten = {10, 9, 8, 7, 6, 5, 4, 3, 2, 1};
  EXPECT_EQ(nearestRankPercentile(ten, 0.99), 10);  // rank ⌈9.9⌉ = 10
  std::vector<double> threeHundred;
  for (int i = 1; i <= 300; ++i) threeHundred.push_back(i);
  EXPECT_EQ(nearestRankPercentile(threeHundred, 0.99), 297);  // 0.99 × 300 is exactly rank 297
  std::vector<double> one = {0.5};
  EXPECT_EQ(nearestRankPercentile(one, 0.99), 0.5);
  std::vector<double> none;
  EXPECT_EQ(nearestRankPercentile(none, 0.99), 0);
}

// Segment k (k = 0..199) has strain ±(k + 1)/1000, stretched for even k and compressed for odd
// k: |s| runs over 0.001 .. 0.200, the largest stretch is 0.199 (k = 198) and the largest
// compression 0.200 (k = 199). Rank ⌈0.99 × 200⌉ = 198 gives p99 = 0.198; the mean of |s| is
// 0.1005.
TEST(StrainFigures, SignsApartAndPercentileOnAKnownDistribution) {
  std::vector<double> strains;
  for (int k = 0; k < 200; ++k) strains.push_back((k % 2 == 0 ? 1 : -1) * (k + 1) / 1000.0);
  const World world = ropeAt(positionsForStrains(strains), false);
  const Measures m = world.measure();
  // Positions are Real: at x ≈ 200 a float is good to about 1e-5.
  const double tolerance = 1e-4;
  EXPECT_NEAR(m.maxStrain, 0.200, tolerance);
  EXPECT_NEAR(m.maxStretch, 0.199, tolerance);
  EXPECT_NEAR(m.maxCompression, 0.200, tolerance);
  EXPECT_NEAR(m.strainP99, 0.198, tolerance);
  EXPECT_NEAR(m.meanStrain, 0.1005, tolerance);
  EXPECT_EQ(m.maxTetherViolation, 0);  // no pins, no tethers
}

TEST(StrainFigures, OnlyStretchedOrOnlyCompressed) {
  const Measures stretched = ropeAt({0, Real(1.25), Real(2.25)}, false).measure();
  EXPECT_NEAR(stretched.maxStretch, 0.25, 1e-6);
  EXPECT_EQ(stretched.maxCompression, 0);  // segment 2 is at rest: neither sign
  EXPECT_NEAR(stretched.maxStrain, 0.25, 1e-6);
  EXPECT_NEAR(stretched.meanStrain, 0.125, 1e-6);
  const Measures compressed = ropeAt({0, Real(0.5), Real(1.4)}, false).measure();
  EXPECT_EQ(compressed.maxStretch, 0);
  EXPECT_NEAR(compressed.maxCompression, 0.5, 1e-6);
  EXPECT_NEAR(compressed.strainP99, 0.5, 1e-6);  // of two values, rank 2
}

// A rope of three unit segments pinned at vertex 0 has a tether from each free vertex to the pin
// with the rest distance along the rope: 1, 2, 3.
TEST(StrainFigures, TetherViolation) {
  {
    World world = ropeAt({0, 1, 2, Real(3.3)}, true);
    const TetherConstraints& tethers = world.impl().state.constraints.tether;
    bool farEnd = false;
    for (std::size_t c = 0; c < tethers.size(); ++c)
      farEnd = farEnd || (tethers.particles[c] == std::array<Index, 2>{3, 0} &&
                          std::abs(tethers.rest[c] - 3) < 1e-6);
    ASSERT_TRUE(farEnd) << "expected a tether from the far end to the pin, rest 3";
    const Measures m = world.measure();
    EXPECT_NEAR(m.maxTetherViolation, 0.1, 1e-6);  // 3.3 / 3 − 1
    EXPECT_NEAR(m.maxStretch, 0.3, 1e-6);          // the last segment, 1.3
  }
  {
    // Folded back: every vertex is nearer the pin than along the rope; no tether is violated,
    // although the stretch constraints are.
    const Measures m = ropeAt({0, Real(0.9), Real(0.5), Real(1.0)}, true).measure();
    EXPECT_EQ(m.maxTetherViolation, 0);
    EXPECT_GT(m.maxStrain, 0.1);
  }
}

}  // namespace
}  // namespace nucleon
