// The simplicial complex: topology invariants of closed and open surfaces and of tet meshes,
// orientation, and the handling of bad input.
#include <gtest/gtest.h>

#include <map>

#include "components/simplicial_complex.h"
#include "nucleon/shapes.h"
#include "systems/diagnostics/measures.h"

using namespace nucleon;

namespace {

// ∂∂ = 0: every (k−2)-face reached from a k-simplex through its boundary is reached twice with
// opposite signs. Checks the stored boundary relations and their signs at once.
template <int K>
void expectBoundaryOfBoundaryVanishes(const SimplexPool<K>& top, const SimplexPool<K - 1>& mid) {
  for (Index s = 0; s < top.size(); ++s) {
    std::map<Index, int> sum;
    for (const SignedFace& f : top.boundary[s])
      for (const SignedFace& g : mid.boundary[f.face]) sum[g.face] += f.sign * g.sign;
    for (const auto& [face, total] : sum) EXPECT_EQ(total, 0) << "simplex " << s;
  }
}

// The co-boundary table is the exact transpose of the boundary table.
template <int K>
void expectCoboundaryMatchesBoundary(const SimplexPool<K>& top, const SimplexPool<K - 1>& faces) {
  std::size_t links = 0;
  for (Index f = 0; f < faces.size(); ++f)
    for (const SignedFace& parent : faces.parentsOf(f)) {
      bool found = false;
      for (const SignedFace& b : top.boundary[parent.face])
        found |= b.face == f && b.sign == parent.sign;
      EXPECT_TRUE(found) << "face " << f << " parent " << parent.face;
      ++links;
    }
  EXPECT_EQ(links, top.size() * (K + 1));
}

}  // namespace

TEST(SimplicialComplex, ClosedSphereHasEulerCharacteristicTwoAndOppositeEdgeOrientations) {
  for (int subdivisions : {0, 1, 3}) {
    const ObjectDef sphere = icosphere(Vec3::Zero(), 1, subdivisions);
    SimplicialComplex c = buildFromTriangles(sphere.vertices.size(), sphere.triangles);
    EXPECT_EQ(c.eulerCharacteristic(), 2);
    EXPECT_EQ(c.points.size(), sphere.vertices.size());
    for (Index e = 0; e < c.edges.size(); ++e) {
      const auto parents = c.edges.parentsOf(e);
      ASSERT_EQ(parents.size(), 2u) << "edge " << e;
      // A consistently oriented closed surface traverses each edge once in each direction.
      EXPECT_EQ(parents[0].sign, -parents[1].sign) << "edge " << e;
    }
    EXPECT_TRUE(c.boundaryEdges().empty());
    auditGeometry(c, sphere.vertices);
    EXPECT_TRUE(c.report.clean());
    expectBoundaryOfBoundaryVanishes(c.triangles, c.edges);
    expectCoboundaryMatchesBoundary(c.triangles, c.edges);
    expectCoboundaryMatchesBoundary(c.edges, c.points);
  }
  // Outward orientation: the enclosed volume is positive and, for an inscribed polyhedron,
  // below the sphere's 4/3 π r³; at 3 subdivisions (1280 faces) within 2% of it.
  const ObjectDef sphere = icosphere(Vec3::Zero(), 1, 3);
  const double volume = enclosedVolume(sphere.triangles, sphere.vertices, 0);
  const double exact = 4.0 / 3.0 * M_PI;
  EXPECT_LT(volume, exact);
  EXPECT_GT(volume, 0.98 * exact);
}

TEST(SimplicialComplex, OpenGridBoundaryEdgesHaveOneParent) {
  GridSpec spec;
  spec.resolution = {7, 5};
  const ObjectDef grid = gridCloth(spec);
  const SimplicialComplex c = buildFromTriangles(grid.vertices.size(), grid.triangles);
  EXPECT_EQ(c.eulerCharacteristic(), 1);  // a disk
  std::size_t boundary = 0;
  for (Index e = 0; e < c.edges.size(); ++e) {
    const auto parents = c.edges.parentsOf(e);
    ASSERT_GE(parents.size(), 1u);
    ASSERT_LE(parents.size(), 2u);
    if (parents.size() == 1) {
      ++boundary;
      // Boundary edges lie on the rim of the grid.
      const Vec3 mid =
          (grid.vertices[c.edges.vertices[e][0]] + grid.vertices[c.edges.vertices[e][1]]) / 2;
      EXPECT_NEAR(std::max(std::abs(mid.x()), std::abs(mid.z() - spec.center.z())), 1.0, 1e-5);
    } else {
      EXPECT_EQ(parents[0].sign, -parents[1].sign);
    }
  }
  EXPECT_EQ(boundary, 2u * (7 - 1) + 2u * (5 - 1));
  EXPECT_EQ(c.boundaryEdges().size(), boundary);
  EXPECT_TRUE(c.report.clean());
}

TEST(SimplicialComplex, TetMeshBoundaryTrianglesFormAClosedOutwardSurface) {
  const std::array<int, 3> cells = {3, 2, 4};
  const Vec3 size(1.5f, 1.0f, 2.0f);
  const ObjectDef box = tetBox(Vec3(0, 1, 0), size, cells);
  SimplicialComplex c = buildFromTets(box.vertices.size(), box.tets);
  EXPECT_EQ(c.eulerCharacteristic(), 1);  // a solid ball
  auditGeometry(c, box.vertices);
  EXPECT_TRUE(c.report.clean());  // no inverted or flat tets, every face in at most two tets
  expectBoundaryOfBoundaryVanishes(c.tets, c.triangles);
  expectBoundaryOfBoundaryVanishes(c.triangles, c.edges);
  expectCoboundaryMatchesBoundary(c.tets, c.triangles);

  const auto surface = c.boundaryTriangles();
  // Two triangles per boundary quad of the cell grid.
  EXPECT_EQ(surface.size(), 4u * (cells[0] * cells[1] + cells[1] * cells[2] + cells[0] * cells[2]));
  // The boundary is itself a closed, consistently oriented surface...
  const SimplicialComplex shell = buildFromTriangles(box.vertices.size(), surface);
  EXPECT_TRUE(shell.report.clean());
  EXPECT_TRUE(shell.boundaryEdges().empty());
  // A sphere: V − E + F = 2 over the vertices the surface uses (interior vertices have no edge).
  const auto surfaceVertices =
      std::count_if(shell.points.vertices.begin(), shell.points.vertices.end(),
                    [&](const Simplex<0>& p) { return !shell.points.parentsOf(p[0]).empty(); });
  EXPECT_EQ(surfaceVertices - static_cast<long long>(shell.edges.size()) +
                static_cast<long long>(surface.size()),
            2);
  // ...oriented outwards: the divergence theorem gives the box's volume with a positive sign.
  EXPECT_NEAR(enclosedVolume(surface, box.vertices, 0), size.prod(), 1e-5 * size.prod());
}

TEST(SimplicialComplex, CurveVerticesKnowTheirEdges) {
  const ObjectDef rope = polylineRope(Vec3::Zero(), Vec3(1, 0, 0), 5);
  const SimplicialComplex c = buildFromEdges(rope.vertices.size(), rope.edges);
  EXPECT_EQ(c.eulerCharacteristic(), 1);
  EXPECT_EQ(c.points.parentsOf(0).size(), 1u);
  EXPECT_EQ(c.points.parentsOf(5).size(), 1u);
  for (Index v = 1; v < 5; ++v) {
    const auto parents = c.points.parentsOf(v);
    ASSERT_EQ(parents.size(), 2u);
    EXPECT_EQ(parents[0].sign, -parents[1].sign);  // ∂[a,b] = [b] − [a]: in once, out once
  }
}

TEST(SimplicialComplex, RejectsOutOfRangeRepeatedAndDuplicateSimplices) {
  const std::vector<Simplex<2>> outOfRange = {{0, 1, 2}, {0, 2, 7}};
  try {
    buildFromTriangles(4, outOfRange);
    FAIL() << "expected MeshError";
  } catch (const MeshError& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("vertex 7"), std::string::npos) << e.what();
  }
  const std::vector<Simplex<2>> repeated = {{0, 1, 1}};
  EXPECT_THROW(buildFromTriangles(3, repeated), MeshError);
  const std::vector<Simplex<2>> duplicate = {{0, 1, 2}, {1, 2, 0}};
  EXPECT_THROW(buildFromTriangles(3, duplicate), MeshError);
  const std::vector<Simplex<3>> badTet = {{0, 1, 2, 2}};
  EXPECT_THROW(buildFromTets(4, badTet), MeshError);
  const std::vector<Simplex<1>> noEdges;
  EXPECT_THROW(buildFromEdges(3, noEdges), MeshError);
  EXPECT_THROW(buildFromPoints(0), MeshError);
}

TEST(SimplicialComplex, ReportsNonManifoldFlippedAndDegenerateInput) {
  // Three triangles on edge (0,1): non-manifold.
  const std::vector<Simplex<2>> fan = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  SimplicialComplex c = buildFromTriangles(5, fan);
  EXPECT_EQ(c.report.nonManifoldFaces, 1u);
  // Two triangles that traverse their shared edge in the same direction: flipped.
  const std::vector<Simplex<2>> flipped = {{0, 1, 2}, {0, 1, 3}};
  c = buildFromTriangles(4, flipped);
  EXPECT_EQ(c.report.inconsistentOrientation, 1u);
  // A zero-area triangle (collinear points) is counted, not fatal.
  const std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(0, 1, 0)};
  const std::vector<Simplex<2>> sliver = {{0, 1, 2}, {0, 3, 1}};
  c = buildFromTriangles(4, sliver);
  auditGeometry(c, x);
  EXPECT_EQ(c.report.degenerateSimplices, 1u);
  // An inverted tet.
  const std::vector<Vec3> t = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  const std::vector<Simplex<3>> inverted = {{0, 2, 1, 3}};
  c = buildFromTets(4, inverted);
  auditGeometry(c, t);
  EXPECT_EQ(c.report.invertedSimplices, 1u);
}
