// The USD ASCII writer (nucleon/usd.h). The format: the USD specification's text layer
// (openusd.org, "USD file formats"); attribute types from UsdGeom's schemas.
#include "nucleon/usd.h"

#include <cstdio>
#include <map>
#include <memory>
#include <stdexcept>

namespace nucleon {
namespace {

// A prim name: letters, digits and underscores, not starting with a digit.
std::string primName(const std::string& name, std::size_t index) {
  std::string out;
  for (const char c : name)
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '_') ? c : '_';
  if (out.empty() || std::isdigit(static_cast<unsigned char>(out[0]))) out = "_" + out;
  return out + "_" + std::to_string(index);
}

// Chains a rope's segments into polylines: from each end (a vertex of one segment) along the
// chain; what is left are closed loops, cut open at their lowest vertex. A vertex of three or more
// segments ends the chains through it.
std::vector<std::vector<Index>> chains(std::span<const std::array<Index, 2>> edges,
                                       std::size_t vertices) {
  std::vector<std::vector<Index>> neighbours(vertices);
  for (const auto& e : edges) neighbours[e[0]].push_back(e[1]), neighbours[e[1]].push_back(e[0]);
  std::map<std::pair<Index, Index>, bool> used;
  const auto key = [](Index a, Index b) { return std::make_pair(std::min(a, b), std::max(a, b)); };
  std::vector<std::vector<Index>> out;
  const auto walk = [&](Index start, Index next) {
    std::vector<Index> chain = {start};
    Index from = start, at = next;
    while (!used[key(from, at)]) {
      used[key(from, at)] = true;
      chain.push_back(at);
      if (neighbours[at].size() != 2) break;
      const Index after = neighbours[at][0] == from ? neighbours[at][1] : neighbours[at][0];
      from = at, at = after;
    }
    if (chain.size() > 1) out.push_back(chain);
  };
  for (Index v = 0; v < vertices; ++v)
    if (neighbours[v].size() != 2)
      for (Index n : neighbours[v]) walk(v, n);
  for (Index v = 0; v < vertices; ++v)
    for (Index n : neighbours[v]) walk(v, n);
  return out;
}

}  // namespace

UsdRecorder::UsdRecorder(const World& world, double fps) : fps_(fps) {
  for (std::size_t i = 0; i < world.objectCount(); ++i) {
    const ObjectId id = world.objectAt(i);
    Prim prim;
    prim.object = i;
    prim.name = primName(world.name(id), i);
    prim.width = float(2 * world.thickness(id));
    const auto triangles = world.surfaceTriangles(id);
    const auto edges = world.curveEdges(id);
    if (!triangles.empty()) {
      prim.type = "Mesh";
      for (const auto& t : triangles) {
        prim.counts.push_back(3);
        prim.indices.insert(prim.indices.end(), t.begin(), t.end());
      }
    } else if (!edges.empty()) {
      prim.type = "BasisCurves";
      for (const std::vector<Index>& chain : chains(edges, world.positions(id).size())) {
        prim.counts.push_back(static_cast<int>(chain.size()));
        prim.pointOrder.insert(prim.pointOrder.end(), chain.begin(), chain.end());
      }
    } else
      prim.type = "Points";
    prims_.push_back(std::move(prim));
  }
  spheres_.assign(world.sphereColliders().begin(), world.sphereColliders().end());
  samples_.resize(prims_.size());
}

void UsdRecorder::addFrame(const World& world, int frame) {
  frames_.push_back(frame);
  for (std::size_t k = 0; k < prims_.size(); ++k) {
    const Prim& prim = prims_[k];
    const auto x = world.positions(world.objectAt(prim.object));
    std::vector<float>& sample = samples_[k].emplace_back();
    const auto add = [&](const Vec3& p) {
      sample.push_back(float(p.x())), sample.push_back(float(p.y())),
          sample.push_back(float(p.z()));
    };
    if (prim.type == "BasisCurves")
      for (Index v : prim.pointOrder) add(x[v]);
    else
      for (const Vec3& p : x) add(p);
  }
}

void UsdRecorder::write(const std::string& path) const {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "w"), &std::fclose);
  if (!file) throw std::runtime_error(path + ": cannot write");
  std::FILE* f = file.get();
  const int first = frames_.empty() ? 0 : frames_.front();
  const int last = frames_.empty() ? 0 : frames_.back();
  std::fprintf(f,
               "#usda 1.0\n(\n    defaultPrim = \"World\"\n    startTimeCode = %d\n"
               "    endTimeCode = %d\n    timeCodesPerSecond = %.9g\n"
               "    framesPerSecond = %.9g\n    upAxis = \"Y\"\n    metersPerUnit = 1\n)\n\n"
               "def Xform \"World\"\n{\n",
               first, last, fps_, fps_);
  const auto intArray = [&](const char* name, const auto& values) {
    std::fprintf(f, "        %s = [", name);
    for (std::size_t i = 0; i < values.size(); ++i)
      std::fprintf(f, i ? ", %d" : "%d", static_cast<int>(values[i]));
    std::fprintf(f, "]\n");
  };
  for (std::size_t k = 0; k < prims_.size(); ++k) {
    const Prim& prim = prims_[k];
    std::fprintf(f, "    def %s \"%s\"\n    {\n", prim.type.c_str(), prim.name.c_str());
    if (prim.type == "Mesh") {
      intArray("int[] faceVertexCounts", prim.counts);
      intArray("int[] faceVertexIndices", prim.indices);
      std::fprintf(f, "        uniform token subdivisionScheme = \"none\"\n");
    } else if (prim.type == "BasisCurves") {
      std::fprintf(f, "        uniform token type = \"linear\"\n");
      intArray("int[] curveVertexCounts", prim.counts);
    }
    if (prim.type != "Mesh")
      std::fprintf(f,
                   "        float[] widths = [%.9g] (\n            interpolation = \"constant\"\n"
                   "        )\n",
                   prim.width);
    std::fprintf(f, "        point3f[] points.timeSamples = {\n");
    for (std::size_t s = 0; s < frames_.size(); ++s) {
      const std::vector<float>& sample = samples_[k][s];
      std::fprintf(f, "            %d: [", frames_[s]);
      for (std::size_t i = 0; i + 2 < sample.size(); i += 3)
        std::fprintf(f, i ? ", (%.9g, %.9g, %.9g)" : "(%.9g, %.9g, %.9g)", double(sample[i]),
                     double(sample[i + 1]), double(sample[i + 2]));
      std::fprintf(f, "],\n");
    }
    std::fprintf(f, "        }\n    }\n");
  }
  for (std::size_t k = 0; k < spheres_.size(); ++k) {
    const SphereCollider& sphere = spheres_[k];
    std::fprintf(f,
                 "    def Sphere \"sphere_collider_%zu\"\n    {\n        double radius = %.9g\n"
                 "        double3 xformOp:translate = (%.9g, %.9g, %.9g)\n"
                 "        uniform token[] xformOpOrder = [\"xformOp:translate\"]\n    }\n",
                 k, double(sphere.radius), double(sphere.center.x()), double(sphere.center.y()),
                 double(sphere.center.z()));
  }
  std::fprintf(f, "}\n");
  if (std::ferror(f)) throw std::runtime_error(path + ": write failed");
}

}  // namespace nucleon
