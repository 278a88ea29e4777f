#include "bench/cloth_case.h"

#include <algorithm>
#include <cmath>

#include "nucleon/shapes.h"
#include "systems/measures.h"

namespace nucleon::bench {

const char* toString(ClothScene scene) {
  return scene == ClothScene::Hanging ? "hanging" : "sphere";
}

ClothMesh makeClothMesh(const ClothCase& c) {
  GridSpec spec;
  spec.resolution = {c.resolution, c.resolution};
  spec.size = {2, 2};
  spec.center = Vec3(0, 1, 0);
  ClothMesh mesh;
  mesh.def = gridCloth(spec);
  mesh.def.name = "cloth";
  mesh.def.material.mass = 1;
  mesh.def.material.thickness = c.thickness;
  mesh.def.material.bending = c.bending;
  if (c.scene == ClothScene::Hanging)  // two adjacent corners: (0, 0) and (N−1, 0)
    mesh.def.pins = {0, static_cast<Index>(c.resolution - 1)};
  for (const auto& t : mesh.def.triangles)
    for (int k = 0; k < 3; ++k) {
      const Index a = t[k], b = t[(k + 1) % 3];
      mesh.edges.push_back({std::min(a, b), std::max(a, b)});
    }
  std::sort(mesh.edges.begin(), mesh.edges.end());
  mesh.edges.erase(std::unique(mesh.edges.begin(), mesh.edges.end()), mesh.edges.end());
  for (const auto& e : mesh.edges)
    mesh.restLength.push_back((mesh.def.vertices[e[1]] - mesh.def.vertices[e[0]]).norm());
  // The masses nucleon lumps (area around each vertex), so both engines carry the same weight.
  World world;
  world.addCloth(mesh.def);
  for (Real w : world.inverseMasses()) mesh.mass.push_back(w > 0 ? 1 / w : 0);
  return mesh;
}

StrainStats measureStrain(const ClothMesh& mesh, const std::vector<Vec3>& positions) {
  StrainStats s;
  for (std::size_t i = 0; i < mesh.edges.size(); ++i) {
    const auto& e = mesh.edges[i];
    const double strain =
        std::abs((positions[e[1]] - positions[e[0]]).norm() / mesh.restLength[i] - 1.0);
    s.max = std::max(s.max, strain);
    s.mean += strain;
  }
  if (!mesh.edges.empty()) s.mean /= double(mesh.edges.size());
  return s;
}

double spherePenetration(const ClothCase& c, const std::vector<Vec3>& positions) {
  double deepest = -1e30;
  for (const Vec3& x : positions)
    deepest = std::max(deepest, double(c.sphereRadius + c.thickness) - double(x.norm()));
  return deepest;
}

void finishRun(const ClothCase& c, const ClothMesh& mesh, const std::vector<Vec3>& positions,
               RunResult& result) {
  result.finalStrain = measureStrain(mesh, positions);
  // The same definition as nucleon's own strain_p99, over the same edges for both engines.
  std::vector<double> strains;
  strains.reserve(mesh.edges.size());
  for (std::size_t i = 0; i < mesh.edges.size(); ++i) {
    const auto& e = mesh.edges[i];
    strains.push_back(
        std::abs((positions[e[1]] - positions[e[0]]).norm() / mesh.restLength[i] - 1.0));
  }
  result.finalStrainP99 = nearestRankPercentile(strains, 0.99);
  result.penetration = spherePenetration(c, positions);
  result.lowestY = 1e30;
  for (const Vec3& v : positions) {
    result.lowestY = std::min(result.lowestY, double(v.y()));
    result.finite = result.finite && v.allFinite();
  }
}

}  // namespace nucleon::bench
