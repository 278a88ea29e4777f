// Scene files and the command line: every bundled scene loads; bad input gives one clear error
// line, exit code 2 and no output files; a good run writes its stats, meshes and picture.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include <nlohmann/json.hpp>

#include "components/simplicial_complex.h"
#include "engine/app/cli.h"
#include "nucleon/mesh_io.h"
#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "sim_test_context.h"

using namespace nucleon;
namespace fs = std::filesystem;

namespace {

// A fresh folder per test under the system's temporary folder.
class TempFolder {
 public:
  TempFolder() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            (std::string("nucleon_") + info->test_suite_name() + "_" + info->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempFolder() { fs::remove_all(path_); }
  std::string file(const std::string& name, const std::string& text = "") const {
    const fs::path p = path_ / name;
    if (!text.empty()) std::ofstream(p) << text;
    return p.string();
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

using test::sceneError;

const char* kSmallCloth = R"({
  "name": "small", "frames": 5,
  "solver": {"type": "gauss-seidel", "iterations": 4},
  "objects": [{"type": "cloth", "name": "sheet",
               "shape": {"grid": {"resolution": [6, 6], "size": [1, 1]}},
               "pins": [0, 5]}]
})";

}  // namespace

TEST(Scene, EveryBundledSceneLoadsAndBuilds) {
  std::size_t count = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(NUCLEON_ASSETS_DIR) / "scenes")) {
    if (entry.path().extension() != ".json") continue;
    ++count;
    const Scene scene = loadScene(entry.path().string());
    EXPECT_FALSE(scene.description.empty()) << entry.path();
    const World world = buildWorld(scene);
    EXPECT_GT(world.particleCount(), 0u) << entry.path();
  }
  EXPECT_GE(count, 2u);
}

TEST(Scene, ClothHangIsA64By64ClothPinnedAtTwoCorners) {
  const Scene scene = loadScene(std::string(NUCLEON_ASSETS_DIR) + "/scenes/cloth_hang.json");
  const World world = buildWorld(scene);
  EXPECT_EQ(world.particleCount(), 64u * 64u);
  const auto w = world.inverseMasses();
  EXPECT_EQ(std::count(w.begin(), w.end(), Real(0)), 2);
  const auto x = world.positions();
  Vec3 lo = x[0], hi = x[0];
  for (const Vec3& p : x) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  EXPECT_NEAR(hi.x() - lo.x(), 2.0, 1e-5);
  EXPECT_NEAR(hi.z() - lo.z(), 2.0, 1e-5);
}

TEST(Scene, ErrorsNameTheProblem) {
  auto expectError = [](const std::string& json, const std::string& needle) {
    const std::string message = sceneError(json);
    EXPECT_NE(message.find(needle), std::string::npos)
        << "for " << json << "\ngot: '" << message << "'";
    EXPECT_EQ(message.find('\n'), std::string::npos) << "one line: " << message;
    EXPECT_EQ(message.rfind("test.json", 0), 0u) << "names the file: " << message;
  };
  expectError("{\"objects\": [", "malformed JSON");
  expectError("{\"objects\": [], \"colour\": 1}", "unknown key 'colour'");
  expectError("{\"objects\": []}", "objects");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"grid": {}}, "pins": [9999]}]})",
              "vertex 9999 is out of range");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"mesh": {"vertices":
                 [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,3]]}}}]})",
              "vertex 3");
  expectError(R"({"gravity": [0, 1e999, 0], "objects": [{"type": "particles",
                 "shape": {"points": [[0,0,0]]}}]})",
              "malformed JSON: number overflow");
  expectError(R"({"fps": 0, "objects": [{"type": "particles", "shape": {"points": [[0,0,0]]}}]})",
              "fps: must be in");
  expectError(R"({"objects": [{"type": "jelly", "shape": {"points": [[0,0,0]]}}]})", "got 'jelly'");
  expectError(R"({"solver": {"type": "magic"}, "objects": [{"type": "particles",
                 "shape": {"points": [[0,0,0]]}}]})",
              "unknown solver 'magic'");
  expectError(R"({"objects": [{"type": "rope", "shape": {"polyline": {"segments": 0}}}]})",
              "segments");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"obj": "nowhere.obj"}}]})",
              "no such mesh file");
  expectError(R"({"objects": [{"type": "particles", "shape": {"points": [[0,0,0]]},
                 "material": {"mass": 0}}]})",
              "mass");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"grid": {}},
                 "material": {"bend_compliance": 0.1, "bend_model": "bergou"}}]})",
              "objects[0].material.bend_model: expected dihedral or isometric, got 'bergou'");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"grid": {}},
                 "material": {"stretch_compliance": 1e-4, "stretch_limit": -0.5}}]})",
              "objects[0].material.stretch_limit: must be in [0, 1000], got -0.5");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"tube": {"resolution": [2, 4]}}}]})",
              "shape.tube.resolution: expected whole numbers [around ≥ 3, along ≥ 2]");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"tube": {"axis": [0, 0, 0]}}}]})",
              "shape.tube.axis: must not be zero");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"tube": {"radius_top": 0}}}]})",
              "shape.tube.radius_top: must be in");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"tube": {"radius": 1, "height": 2}}}]})",
              "unknown key 'height'");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"tube": {}},
                 "pin_groups": [{"ring": 40, "motion": {"keyframes": [{"time": 0}]}}]}]})",
              "objects[0].pin_groups[0].ring: must be in [-32, 31], got 40");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"tube": {}},
                 "pin_groups": [{"vertices": [], "motion": {"keyframes": [{"time": 0}]}}]}]})",
              "objects[0].pin_groups[0].vertices: expected a non-empty list");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"tube": {}},
                 "pin_groups": [{"vertices": [5000], "motion": {"keyframes": [{"time": 0}]}}]}]})",
              "vertex 5000 is out of range");
  expectError(
      R"({"objects": [{"type": "cloth", "shape": {"tube": {}},
                 "pin_groups": [{"ring": 0, "motion": {"loop": true}}]}]})",
      "objects[0].pin_groups[0].motion.loop: a looping motion needs at least two keyframes");
  expectError(R"({"objects": [{"type": "cloth", "shape": {"tube": {}},
                 "pin_groups": [{"ring": 0, "motion": {}}]}]})",
              "objects[0].pin_groups[0].motion: give keyframes or a bend");
}

// The tube shape: rings of `around` vertices in order along the axis, the seam closed (no
// repeated vertex), every triangle facing outwards, the only boundary the two end rings; a cone
// when the radii differ; with caps, a closed surface.
TEST(Shapes, TubeIsAnOpenCylinderWithAClosedSeam) {
  TubeSpec spec;
  spec.resolution = {12, 5};
  spec.center = Vec3(1, 2, 3);
  spec.axis = Vec3(0, 0, 2);  // any length
  spec.length = 2;
  spec.radiusBottom = Real(0.5);
  spec.radiusTop = Real(0.25);
  const ObjectDef def = tube(spec);
  ASSERT_EQ(def.vertices.size(), 60u);
  EXPECT_EQ(def.triangles.size(), 2u * 12 * 4);
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 12; ++j) {
      const Vec3 r = def.vertices[k * 12 + j] - spec.center;
      EXPECT_NEAR(r.z(), -1 + 0.5 * k, 1e-6) << "ring " << k;
      EXPECT_NEAR(std::hypot(r.x(), r.y()), 0.5 - 0.0625 * k, 1e-6) << "ring " << k;
      // Right-handed about +z from +x (the world axis least aligned with z, the first in a tie).
      const double angle = std::atan2(r.y(), r.x());
      EXPECT_NEAR(std::remainder(angle - 2 * std::numbers::pi * j / 12, 2 * std::numbers::pi), 0,
                  1e-6)
          << "ring " << k << ", vertex " << j;
    }
  for (std::size_t a = 0; a < def.vertices.size(); ++a)
    for (std::size_t b = a + 1; b < def.vertices.size(); ++b)
      EXPECT_GT((def.vertices[a] - def.vertices[b]).norm(), 0.1) << "no duplicate vertices";
  const SimplicialComplex c = buildFromTriangles(def.vertices.size(), def.triangles);
  EXPECT_EQ(c.report.inconsistentOrientation, 0u);
  EXPECT_EQ(c.report.nonManifoldFaces, 0u);
  EXPECT_EQ(c.boundaryEdges().size(), 24u) << "only the two end rings are open";
  for (const auto& [a, b, t] : def.triangles) {
    const Vec3 n = (def.vertices[b] - def.vertices[a]).cross(def.vertices[t] - def.vertices[a]);
    Vec3 out = (def.vertices[a] + def.vertices[b] + def.vertices[t]) / 3 - spec.center;
    out.z() = 0;
    EXPECT_GT(n.dot(out), 0) << "faces outwards";
  }
  spec.caps = true;
  const ObjectDef capped = tube(spec);
  EXPECT_EQ(capped.vertices.size(), 62u);
  EXPECT_NEAR((capped.vertices[60] - spec.center).z(), -1, 1e-6);
  EXPECT_NEAR((capped.vertices[61] - spec.center).z(), 1, 1e-6);
  const SimplicialComplex closed = buildFromTriangles(capped.vertices.size(), capped.triangles);
  EXPECT_TRUE(closed.boundaryEdges().empty());
  EXPECT_EQ(closed.report.inconsistentOrientation, 0u);
  spec.radiusTop = 0;
  EXPECT_THROW(tube(spec), std::invalid_argument);
}

// `stretch_limit` is read into the material; left out, the material keeps the default (−1: 0
// when inextensible, none when stretchable).
TEST(Scene, ReadsAStretchLimit) {
  const auto limitOf = [](const char* material) {
    const Scene scene = parseScene(
        std::string(R"({"objects": [{"type": "cloth", "shape": {"grid": {}}, "material": )") +
            material + "}]}",
        "test.json", ".");
    return scene.objects.at(0).def.material;
  };
  const Material limited = limitOf(R"({"stretch_compliance": 1e-4, "stretch_limit": 0.05})");
  EXPECT_FLOAT_EQ(limited.stretchLimit, 0.05f);
  EXPECT_FLOAT_EQ(limited.longRangeStrain(), 0.05f);
  const Material free = limitOf(R"({"stretch_compliance": 1e-4})");
  EXPECT_LT(free.longRangeStrain(), 0);
  EXPECT_EQ(limitOf("{}").longRangeStrain(), 0);
}

TEST(Scene, ReadsATube) {
  const Scene scene = parseScene(R"({"objects": [{"type": "cloth", "shape": {"tube": {
      "center": [0, 1, 0], "axis": [1, 0, 0], "length": 0.6, "radius": 0.2, "radius_top": 0.1,
      "resolution": [8, 4]}}}]})",
                                 "test.json", ".");
  const ObjectDef& def = scene.objects.at(0).def;
  ASSERT_EQ(def.vertices.size(), 32u);
  EXPECT_NEAR(def.vertices[0].x(), -0.3, 1e-6);  // ring 0 at the −axis end
  EXPECT_NEAR(def.vertices[0].y(), 1.2, 1e-6);   // vertex 0 on +y: the axis is x
  EXPECT_NEAR(def.vertices[24].x(), 0.3, 1e-6);  // the last ring
  EXPECT_NEAR(def.vertices[24].y(), 1.1, 1e-6);  // radius_top
  const World world = buildWorld(scene);
  EXPECT_EQ(world.particleCount(), 32u);
}

// A scene file that names no solver runs multigrid at two substeps (Scene::solver); one that names
// its type keeps it; the C++ default stays Gauss–Seidel at one substep, which every registered
// family is converged by.
TEST(Scene, SolvesWithMultigridWhereTheFileNamesNoSolver) {
  const char* cloth =
      R"("objects": [{"type": "cloth", "shape": {"grid": {"resolution": [4, 4]}}}])";
  const Scene bare = parseScene(std::string("{") + cloth + "}", "test.json", ".");
  EXPECT_EQ(bare.solver.kind, SolverKind::Multigrid);
  EXPECT_EQ(bare.solver.iterations, 10);
  EXPECT_EQ(bare.solver.substeps, 2);
  const Scene counted =
      parseScene(std::string(R"({"solver": {"iterations": 5}, )") + cloth + "}", "test.json", ".");
  EXPECT_EQ(counted.solver.kind, SolverKind::Multigrid);
  EXPECT_EQ(counted.solver.iterations, 5);
  const Scene named = parseScene(
      std::string(R"({"solver": {"type": "gauss-seidel"}, )") + cloth + "}", "test.json", ".");
  EXPECT_EQ(named.solver.kind, SolverKind::GaussSeidel);
  EXPECT_EQ(SolverSettings{}.kind, SolverKind::GaussSeidel);
  EXPECT_EQ(SolverSettings{}.substeps, 1);
  EXPECT_EQ(buildWorld(bare).solver().kind, SolverKind::Multigrid);
}

TEST(Scene, ObjLoaderReportsMissingFilesAndBadFaces) {
  TempFolder tmp;
  EXPECT_THROW(loadObj(tmp.file("missing.obj")), MeshError);
  const std::string bad = tmp.file("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  EXPECT_THROW(loadObj(bad), MeshError);
  const std::string quad = tmp.file("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  const ObjectDef def = loadObj(quad);
  EXPECT_EQ(def.vertices.size(), 4u);
  EXPECT_EQ(def.triangles.size(), 2u);  // triangulated
}

TEST(CommandLine, BadInputExitsWithTwoAndWritesNothing) {
  TempFolder tmp;
  const std::string stats = tmp.file("stats.json"), out = tmp.file("frames"),
                    picture = tmp.file("picture.png");
  const std::string broken = tmp.file("broken.json", "{\"objects\": [ {\"type\": ");
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"run", tmp.file("missing.json")},
        {"run", broken, "--stats", stats, "--out", out, "--render", picture},
        {"run", tmp.file("ok.json", kSmallCloth), "--frames", "zero"},
        {"run", tmp.file("ok.json", kSmallCloth), "--bogus"},
        {"run", tmp.file("ok.json", kSmallCloth), "--solver", "nope", "--stats", stats},
        {"frobnicate"}}) {
    std::ostringstream o, e;
    EXPECT_EQ(runCommandLine(args, o, e), 2) << args[0] << ' ' << args.back();
    const std::string error = e.str();
    EXPECT_EQ(std::count(error.begin(), error.end(), '\n'), 1) << error;
    EXPECT_FALSE(fs::exists(stats));
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(picture));
  }
  std::ostringstream o, e;
  runCommandLine({"run", tmp.file("missing.json")}, o, e);
  EXPECT_NE(e.str().find("missing.json: no such scene file"), std::string::npos) << e.str();
}

TEST(CommandLine, RunWritesStatsMeshesAndPicture) {
  TempFolder tmp;
  const std::string scene = tmp.file("small.json", kSmallCloth);
  const std::string stats = tmp.file("stats.json"), out = tmp.file("frames"),
                    picture = tmp.file("picture.png");
  std::ostringstream o, e;
  ASSERT_EQ(runCommandLine({"run", scene, "--frames", "3", "--threads", "1", "--stats", stats,
                            "--out", out, "--render", picture, "--quiet"},
                           o, e),
            0)
      << e.str();
  EXPECT_TRUE(e.str().empty()) << "--quiet prints no progress: " << e.str();
  std::ifstream in(stats);
  const nlohmann::json j = nlohmann::json::parse(in);
  for (const char* key :
       {"scene", "frames", "steps", "threads", "solver", "particles", "constraints", "wall_s",
        "ms_per_step", "max_strain", "mean_strain", "intersections", "nan_count", "min_height",
        "volume_ratio", "energy", "state_hash", "per_frame"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["frames"], 3);
  EXPECT_EQ(j["particles"], 36);
  EXPECT_EQ(j["constraints"]["stretch"], 5 * 6 * 2 + 25);  // grid edges + one diagonal per cell
  EXPECT_EQ(j["nan_count"], 0);
  EXPECT_EQ(j["energy"].size(), 3u);
  EXPECT_EQ(j["per_frame"].size(), 3u);
  EXPECT_EQ(j["state_hash"].get<std::string>().size(), 16u);
  EXPECT_GT(j["ms_per_step"].get<double>(), 0.0);
  EXPECT_TRUE(fs::exists(fs::path(out) / "sheet_0003.obj"));
  EXPECT_EQ(loadObj((fs::path(out) / "sheet_0003.obj").string()).triangles.size(), 50u);
  std::ifstream png(picture, std::ios::binary);
  char magic[4] = {};
  png.read(magic, 4);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
}

TEST(CommandLine, ScenesListsTheBundledScenes) {
  std::ostringstream o, e;
  EXPECT_EQ(runCommandLine({"scenes"}, o, e), 0) << e.str();
  EXPECT_NE(o.str().find("cloth_hang.json"), std::string::npos);
  EXPECT_NE(o.str().find("rope_pendulum.json"), std::string::npos);
}
