#include "bench/cloth_case.h"

#include <algorithm>
#include <cmath>

#include "nucleon/shapes.h"
#include "systems/diagnostics/measures.h"

namespace nucleon::bench {

const char* toString(ClothScene scene) {
  switch (scene) {
    case ClothScene::Hanging:
      return "hanging";
    case ClothScene::Sphere:
      return "sphere";
    case ClothScene::Mesh:
      return "mesh";
  }
  return "?";
}

const char* toString(BulletCollision mode) {
  return mode == BulletCollision::Sdf ? "SDF_RS" : "CL_RS";
}

ClothCase meshDropCase(int resolution, int iterations) {
  ClothCase c;
  c.scene = ClothScene::Mesh;
  c.resolution = resolution;
  c.iterations = iterations;
  c.substeps = 2;
  c.thickness = Real(0.006);
  c.meshThickness = Real(0.005);
  c.friction = Real(0.3);
  return c;
}

double meshContactDistance(const ClothCase& c) {
  return double(c.thickness) + double(c.meshThickness);
}

namespace {

// The point of triangle abc nearest to p (Ericson, Real-Time Collision Detection, 5.1.5): by the
// Voronoi region of p among the vertices, edges and face.
Vec3d closestPointOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denominator = 1 / (va + vb + vc);
  return a + ab * (vb * denominator) + ac * (vc * denominator);
}

// Whether the ray from `origin` along `direction` crosses triangle abc (Möller–Trumbore).
bool rayCrosses(const Vec3d& origin, const Vec3d& direction, const Vec3d& a, const Vec3d& b,
                const Vec3d& c) {
  const Vec3d e1 = b - a, e2 = c - a;
  const Vec3d h = direction.cross(e2);
  const double det = e1.dot(h);
  if (std::abs(det) < 1e-300) return false;  // parallel
  const double inverse = 1 / det;
  const Vec3d s = origin - a;
  const double u = s.dot(h) * inverse;
  if (u < 0 || u > 1) return false;
  const Vec3d q = s.cross(e1);
  const double v = direction.dot(q) * inverse;
  if (v < 0 || u + v > 1) return false;
  return e2.dot(q) * inverse > 0;
}

}  // namespace

MeshDistance::MeshDistance(const ObjectDef& mesh) {
  Vec3d sum = Vec3d::Zero();
  for (const Vec3& v : mesh.vertices) sum += v.cast<double>();
  ballCenter_ = sum / double(mesh.vertices.size());
  for (const Vec3& v : mesh.vertices)
    ballRadius_ = std::max(ballRadius_, (v.cast<double>() - ballCenter_).norm());
  for (const auto& t : mesh.triangles) {
    Triangle tri;
    tri.a = mesh.vertices[t[0]].cast<double>();
    tri.b = mesh.vertices[t[1]].cast<double>();
    tri.c = mesh.vertices[t[2]].cast<double>();
    tri.centroid = (tri.a + tri.b + tri.c) / 3;
    tri.radius = std::max({(tri.a - tri.centroid).norm(), (tri.b - tri.centroid).norm(),
                           (tri.c - tri.centroid).norm()});
    triangles_.push_back(tri);
  }
}

double MeshDistance::signedDistance(const Vec3d& point, double beyond) const {
  // The mesh lies inside its bounding ball: a point far outside it is outside the mesh.
  const double fromBall = (point - ballCenter_).norm() - ballRadius_;
  if (fromBall > beyond) return fromBall;
  double nearest = 1e300;
  for (const Triangle& t : triangles_) {
    // No point of this triangle is nearer than its bounding ball allows.
    const double lowerBound = (point - t.centroid).norm() - t.radius;
    if (lowerBound >= nearest) continue;
    nearest = std::min(nearest, (closestPointOnTriangle(point, t.a, t.b, t.c) - point).norm());
  }
  if (fromBall >= 0) return nearest;  // outside the ball, so outside the mesh
  // Inside when a ray crosses the surface an odd number of times. The direction is far from any
  // axis and from the mesh's symmetry planes, so that it does not graze edges or vertices.
  const Vec3d direction = Vec3d(0.5279, 0.7314, 0.4317).normalized();
  int crossings = 0;
  for (const Triangle& t : triangles_)
    if (rayCrosses(point, direction, t.a, t.b, t.c)) ++crossings;
  return crossings % 2 == 1 ? -nearest : nearest;
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
  if (c.scene == ClothScene::Mesh) {
    mesh.collider = icosphere(c.meshCenter, c.sphereRadius, c.meshSubdivisions);
    mesh.collider.name = "ball";
    mesh.collider.material.thickness = c.meshThickness;
    mesh.collider.material.friction = c.friction;
    mesh.colliderDistance = MeshDistance(mesh.collider);
  }
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

double strainP99(const ClothMesh& mesh, const std::vector<Vec3>& positions) {
  std::vector<double> strains;
  strains.reserve(mesh.edges.size());
  for (std::size_t i = 0; i < mesh.edges.size(); ++i) {
    const auto& e = mesh.edges[i];
    strains.push_back(
        std::abs((positions[e[1]] - positions[e[0]]).norm() / mesh.restLength[i] - 1.0));
  }
  return nearestRankPercentile(strains, 0.99);
}

void observeStep(const ClothCase& c, const ClothMesh& mesh, const std::vector<Vec3>& positions,
                 int step, RunResult& result) {
  const StrainStats strain = measureStrain(mesh, positions);
  result.peakMaxStrain = std::max(result.peakMaxStrain, strain.max);
  result.averageMeanStrain += strain.mean / c.steps;
  const int lateSteps = c.steps - c.steps / 2;
  if (step >= c.steps / 2) {
    result.lateStrain.mean += strain.mean / lateSteps;
    result.lateStrain.max += strain.max / lateSteps;
    result.lateStrainP99 += strainP99(mesh, positions) / lateSteps;
  }
  if (c.scene != ClothScene::Mesh) return;
  // Only how far a vertex is inside or near the contact distance matters; farther points need
  // no exact distance.
  const double beyond = 2 * meshContactDistance(c);
  double nearest = 1e30;
  int inside = 0;
  for (const Vec3& x : positions) {
    const double s = mesh.colliderDistance.signedDistance(x.cast<double>(), beyond);
    nearest = std::min(nearest, s);
    if (s < 0) ++inside;
  }
  result.meshMinDistance = std::min(result.meshMinDistance, nearest);
  result.meshMinDistanceAtEnd = nearest;  // the last step's call leaves the end state
  result.meshInsideAtEnd = inside;
  result.meshInsidePeak = std::max(result.meshInsidePeak, inside);
}

void finishRun(const ClothCase& c, const ClothMesh& mesh, const std::vector<Vec3>& positions,
               RunResult& result) {
  result.finalStrain = measureStrain(mesh, positions);
  // The same definition as nucleon's own strain_p99, over the same edges for both engines.
  result.finalStrainP99 = strainP99(mesh, positions);
  result.penetration = spherePenetration(c, positions);
  result.lowestY = 1e30;
  for (const Vec3& v : positions) {
    result.lowestY = std::min(result.lowestY, double(v.y()));
    result.finite = result.finite && v.allFinite();
  }
}

}  // namespace nucleon::bench
