// `nucleon run --usd`: the USD layer read back (a small parser of the text format, written here
// so that the test does not trust the writer's own reading) holds, for every object and frame,
// the points the OBJ export of the same run holds: meshes vertex for vertex, curves segment for
// segment, particle clouds point for point; the header's time range and the sphere colliders are
// there too.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/scene_run.h"

namespace nucleon {
namespace {

namespace fs = std::filesystem;

using Points = std::vector<std::array<double, 3>>;

struct UsdPrim {
  std::string type, name;
  std::vector<int> counts;        // faceVertexCounts or curveVertexCounts
  std::map<int, Points> samples;  // time code → points
};

std::string readFile(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Reads "(x, y, z), (x, y, z), …]" from `at` up to the closing bracket.
Points readPoints(const std::string& text, std::size_t& at) {
  Points points;
  while (at < text.size() && text[at] != ']') {
    if (text[at] != '(') {
      ++at;
      continue;
    }
    std::array<double, 3> p{};
    const char* c = text.c_str() + at + 1;
    for (double& value : p) {
      char* end = nullptr;
      value = std::strtod(c, &end);
      c = end;
      while (*c == ',' || *c == ' ') ++c;
    }
    points.push_back(p);
    at = static_cast<std::size_t>(c - text.c_str());
  }
  return points;
}

std::vector<int> readInts(const std::string& block, const std::string& name) {
  std::vector<int> values;
  const std::size_t at = block.find(name + " = [");
  if (at == std::string::npos) return values;
  std::istringstream in(block.substr(at + name.size() + 4, block.find(']', at) - at));
  for (std::string item; std::getline(in, item, ',');) values.push_back(std::stoi(item));
  return values;
}

std::vector<UsdPrim> readUsd(const std::string& text) {
  std::vector<UsdPrim> prims;
  for (std::size_t at = text.find("    def "); at != std::string::npos;
       at = text.find("\n    def ", at + 1)) {
    UsdPrim prim;
    std::istringstream head(text.substr(at, text.find('\n', at + 1) - at));
    std::string def, quotedName;
    head >> def >> prim.type >> quotedName;
    prim.name = quotedName.substr(1, quotedName.size() - 2);
    const std::size_t end = text.find("\n    }", at);
    const std::string block = text.substr(at, end - at);
    prim.counts =
        readInts(block, prim.type == "Mesh" ? "int[] faceVertexCounts" : "int[] curveVertexCounts");
    std::size_t s = block.find("points.timeSamples = {");
    if (s != std::string::npos) {
      for (s = block.find('\n', s); s != std::string::npos && s + 1 < block.size();) {
        const std::size_t colon = block.find(": [", s);
        if (colon == std::string::npos) break;
        const int code = std::stoi(block.substr(s + 1, colon - s - 1));
        std::size_t p = colon + 3;
        prim.samples[code] = readPoints(block, p);
        s = block.find('\n', p);
      }
    }
    prims.push_back(prim);
  }
  return prims;
}

struct Obj {
  Points v;
  std::vector<std::array<int, 2>> lines;
};

Obj readObj(const fs::path& path) {
  Obj obj;
  std::ifstream in(path);
  EXPECT_TRUE(in) << path;
  for (std::string line; std::getline(in, line);) {
    std::istringstream row(line);
    std::string tag;
    row >> tag;
    if (tag == "v") {
      std::array<double, 3> p{};
      row >> p[0] >> p[1] >> p[2];
      obj.v.push_back(p);
    } else if (tag == "l") {
      std::array<int, 2> e{};
      row >> e[0] >> e[1];
      obj.lines.push_back({e[0] - 1, e[1] - 1});
    }
  }
  return obj;
}

// Both files print floats with 9 significant digits; the USD's are floats of the state.
bool near(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(a[k] - b[k]) > 1e-6 * std::max(1.0, std::abs(a[k]))) return false;
  return true;
}

class UsdExport : public ::testing::TestWithParam<const char*> {};

TEST_P(UsdExport, HoldsTheObjExportsPointsEveryFrame) {
  const std::string scene = std::string(NUCLEON_ASSETS_DIR) + "/scenes/" + GetParam() + ".json";
  const fs::path dir = fs::temp_directory_path() / (std::string("nucleon_usd_") + GetParam());
  fs::remove_all(dir);
  fs::create_directories(dir);
  const int frames = 3;
  const test::SceneRun run =
      test::runScene(scene, {"--frames", std::to_string(frames), "--out", dir.string(), "--usd",
                             (dir / "run.usda").string()});
  ASSERT_FALSE(run.stats.is_null());
  const std::string text = readFile(dir / "run.usda");
  ASSERT_EQ(text.rfind("#usda 1.0\n", 0), 0u);
  EXPECT_NE(text.find("startTimeCode = 1\n"), std::string::npos);
  EXPECT_NE(text.find("endTimeCode = 3\n"), std::string::npos);
  const std::vector<UsdPrim> prims = readUsd(text);
  std::size_t geometry = 0;
  for (const UsdPrim& prim : prims) {
    if (prim.type == "Sphere") continue;
    ++geometry;
    const std::string object = prim.name.substr(0, prim.name.rfind('_'));
    ASSERT_EQ(prim.samples.size(), std::size_t(frames)) << prim.name;
    for (int frame = 1; frame <= frames; ++frame) {
      std::ostringstream file;
      file << object << '_' << std::setw(4) << std::setfill('0') << frame << ".obj";
      const Obj obj = readObj(dir / file.str());
      const Points& points = prim.samples.at(frame);
      if (prim.type == "Mesh" || prim.type == "Points") {
        ASSERT_EQ(points.size(), obj.v.size()) << prim.name;
        for (std::size_t i = 0; i < points.size(); ++i)
          ASSERT_TRUE(near(points[i], obj.v[i])) << prim.name << " frame " << frame << " " << i;
      } else {
        ASSERT_EQ(prim.type, "BasisCurves");
        // Every segment of every curve is one of the OBJ's lines, and every line is one segment.
        std::size_t segments = 0, first = 0, matched = 0;
        for (const int count : prim.counts) {
          for (int k = 0; k + 1 < count; ++k, ++segments) {
            const auto& a = points[first + k];
            const auto& b = points[first + k + 1];
            for (const auto& e : obj.lines)
              if ((near(a, obj.v[e[0]]) && near(b, obj.v[e[1]])) ||
                  (near(a, obj.v[e[1]]) && near(b, obj.v[e[0]]))) {
                ++matched;
                break;
              }
          }
          first += count;
        }
        EXPECT_EQ(first, points.size()) << prim.name;
        EXPECT_EQ(segments, obj.lines.size()) << prim.name;
        EXPECT_EQ(matched, segments) << prim.name << " frame " << frame;
      }
    }
  }
  // One prim per object: as many as the OBJ export wrote files for a frame.
  std::size_t objects = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    objects += entry.path().filename().string().ends_with("_0001.obj");
  EXPECT_EQ(geometry, objects);
  EXPECT_GT(geometry, 0u);
  fs::remove_all(dir);
}

// A cloth and a rope (attachments), a liquid's particles and a cloth (water_on_cloth), a cloth
// over a sphere collider (cloth_sphere).
INSTANTIATE_TEST_SUITE_P(Scenes, UsdExport,
                         ::testing::Values("attachments", "water_on_cloth", "cloth_sphere"));

TEST(UsdExport, SphereCollidersAreSpherePrims) {
  const std::string scene = std::string(NUCLEON_ASSETS_DIR) + "/scenes/cloth_sphere.json";
  const fs::path file = fs::temp_directory_path() / "nucleon_usd_sphere.usda";
  const test::SceneRun run = test::runScene(scene, {"--frames", "1", "--usd", file.string()});
  ASSERT_FALSE(run.stats.is_null());
  const std::vector<UsdPrim> prims = readUsd(readFile(file));
  std::size_t spheres = 0, meshes = 0;
  for (const UsdPrim& prim : prims) spheres += prim.type == "Sphere", meshes += prim.type == "Mesh";
  EXPECT_EQ(spheres, 1u);
  EXPECT_GE(meshes, 1u);
  EXPECT_NE(readFile(file).find("double radius = "), std::string::npos);
  fs::remove(file);
}

}  // namespace
}  // namespace nucleon
