// The narrow phase's float lanes (systems/collision/pair_distance_lanes.h): every distance and
// motion they give is within kPairLaneTolerance × the lane's extent of the exact double figure,
// so that a bound less that amount is a true lower bound, and every edge–edge classification of
// the closest points agrees with the exact (clamped) closest points, on random cloth-sized pairs
// far from the origin, on the degenerate shapes a cloth pile makes (slivers, parallel and crossing
// edges, coincident and collapsed primitives) and on the public CCD query set's configurations.
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "ccd_public_set.h"
#include "systems/collision/pair_distance_lanes.h"
#include "systems/collision/primitive_distance.h"

namespace nucleon {
namespace {

// Four particles at the start and the end of a motion; `vertexFace`: 0 the point, 1–3 the
// triangle, else 0–1 and 2–3 the edges.
struct PairMotion {
  bool vertexFace = true;
  std::array<Vec3d, 4> start, end;
};

double exactDistance(bool vertexFace, const std::array<Vec3d, 4>& y) {
  if (vertexFace) {
    const auto w = closestOnTriangle(y[0], y[1], y[2], y[3]);
    return (y[0] - (w[0] * y[1] + w[1] * y[2] + w[2] * y[3])).norm();
  }
  const auto s = closestBetweenSegments(y[0], y[1], y[2], y[3]);
  return ((y[0] + s[0] * (y[1] - y[0])) - (y[2] + s[1] * (y[3] - y[2]))).norm();
}

// The narrow phase's motion bound: the largest motion of a particle of each side relative to
// particle 0, summed over the sides.
double exactMotion(const PairMotion& m) {
  const int firstSide = m.vertexFace ? 1 : 2;
  const Vec3d u0 = m.end[0] - m.start[0];
  double a = 0, b = 0;
  for (int k = 1; k < 4; ++k) {
    const double d = (m.end[k] - m.start[k] - u0).norm();
    (k < firstSide ? a : b) = std::max(k < firstSide ? a : b, d);
  }
  return a + b;
}

// Whether the exact closest points of two edges (Ericson's clamped parameters, which the narrow
// phase's duplicateFeature reads) lie at an end of either edge.
bool atAnEdgeEnd(const std::array<Vec3d, 4>& y) {
  const auto s = closestBetweenSegments(y[0], y[1], y[2], y[3]);
  return s[0] == 0 || s[0] == 1 || s[1] == 0 || s[1] == 1;
}

// Edge–edge lanes classified, by PairFeature, over all the checks of a test.
struct FeatureCounts {
  int counts[3] = {0, 0, 0};
};

// Checks one classification of an edge–edge lane against the exact closest points.
void checkFeature(float feature, const std::array<Vec3d, 4>& y, FeatureCounts& tally,
                  std::size_t pair) {
  ASSERT_TRUE(feature == float(kUnknownFeature) || feature == float(kEdgeInteriors) ||
              feature == float(kEdgeEnds));
  ++tally.counts[int(feature)];
  if (feature == float(kEdgeInteriors)) {
    EXPECT_FALSE(atAnEdgeEnd(y)) << "pair " << pair;
  }
  if (feature == float(kEdgeEnds)) {
    EXPECT_TRUE(atAnEdgeEnd(y)) << "pair " << pair;
  }
}

// Runs the lanes over `motions` (all of one kind) and checks every lane against the exact
// figures; returns how many lanes were checked.
int checkLanes(const std::vector<PairMotion>& motions, FeatureCounts* features = nullptr) {
  FeatureCounts unused;
  FeatureCounts& tally = features ? *features : unused;
  int checked = 0;
  for (std::size_t begin = 0; begin < motions.size(); begin += kPairLanes) {
    PairLanes lanes{};
    const std::size_t count = std::min<std::size_t>(kPairLanes, motions.size() - begin);
    for (std::size_t lane = 0; lane < count; ++lane) {
      const PairMotion& m = motions[begin + lane];
      for (int k = 1; k < 4; ++k)
        for (int axis = 0; axis < 3; ++axis) {
          // As the narrow phase fills them: the float difference of float positions.
          lanes.start[k][axis][lane] =
              static_cast<float>(m.start[k][axis]) - static_cast<float>(m.start[0][axis]);
          lanes.end[k][axis][lane] =
              static_cast<float>(m.end[k][axis]) - static_cast<float>(m.end[0][axis]);
        }
    }
    PairLaneBounds bounds{};
    if (motions[begin].vertexFace)
      vertexFaceLaneBounds(lanes, bounds);
    else
      edgeEdgeLaneBounds(lanes, bounds);
    for (std::size_t lane = 0; lane < count; ++lane) {
      const PairMotion& m = motions[begin + lane];
      // The exact figures of the float positions the lanes saw.
      std::array<Vec3d, 4> start, end;
      for (int k = 0; k < 4; ++k) {
        start[k] = m.start[k].cast<float>().cast<double>();
        end[k] = m.end[k].cast<float>().cast<double>();
      }
      const PairMotion rounded{m.vertexFace, start, end};
      const double error = double(kPairLaneTolerance) * double(bounds.extent[lane]);
      const double d0 = exactDistance(m.vertexFace, start), d1 = exactDistance(m.vertexFace, end);
      EXPECT_NEAR(bounds.startDistance[lane], d0, error) << "pair " << begin + lane;
      EXPECT_NEAR(bounds.endDistance[lane], d1, error) << "pair " << begin + lane;
      EXPECT_NEAR(bounds.motion[lane], exactMotion(rounded), error) << "pair " << begin + lane;
      // The extent is the scale of the relative configuration.
      double extent = 0;
      for (int k = 1; k < 4; ++k)
        extent = std::max({extent, (start[k] - start[0]).cwiseAbs().maxCoeff(),
                           (end[k] - end[0]).cwiseAbs().maxCoeff()});
      EXPECT_NEAR(bounds.extent[lane], extent, 1e-6 * extent);
      if (m.vertexFace) {
        EXPECT_EQ(bounds.startFeature[lane], float(kUnknownFeature));
        EXPECT_EQ(bounds.endFeature[lane], float(kUnknownFeature));
      } else {
        checkFeature(bounds.startFeature[lane], start, tally, begin + lane);
        checkFeature(bounds.endFeature[lane], end, tally, begin + lane);
      }
      ++checked;
    }
  }
  return checked;
}

Vec3d randomIn(std::mt19937& rng, double half) {
  std::uniform_real_distribution<double> u(-half, half);
  return {u(rng), u(rng), u(rng)};
}

TEST(PairDistanceLanes, RandomClothSizedPairsFarFromTheOrigin) {
  std::mt19937 rng(7);
  FeatureCounts features;
  for (const bool vertexFace : {true, false}) {
    for (const double offset : {0.0, 3.0, 150.0}) {
      std::vector<PairMotion> motions;
      for (int i = 0; i < 2000; ++i) {
        PairMotion m;
        m.vertexFace = vertexFace;
        const Vec3d centre = Vec3d::Constant(offset) + randomIn(rng, 0.5);
        // Primitives of 2 cm edges within a few centimetres, moving up to 1 cm.
        for (int k = 0; k < 4; ++k) {
          m.start[k] = centre + randomIn(rng, 0.02);
          m.end[k] = m.start[k] + randomIn(rng, 0.01);
        }
        motions.push_back(m);
      }
      EXPECT_EQ(checkLanes(motions, &features), 2000);
    }
  }
  // Random edges a few centimetres apart: most are classified, both ways (2 × 3 × 2,000 edge
  // pairs' start and end).
  EXPECT_GT(features.counts[kEdgeInteriors], 500);
  EXPECT_GT(features.counts[kEdgeEnds], 3000);
  EXPECT_LT(features.counts[kUnknownFeature], 1200);
}

TEST(PairDistanceLanes, DegenerateShapesOfAPile) {
  std::vector<PairMotion> faces, edges;
  const Vec3d o(1.25, 0.5, -0.75);
  const double h = 0.02;
  for (int i = 0; i <= 12; ++i) {
    const double tiny = std::pow(10.0, -i);  // 1 down to 1e-12 of an edge
    // A sliver triangle under a point, and a point over its long edge.
    faces.push_back({true,
                     {o + Vec3d(0.3 * h, 0.004, tiny * h), o, o + Vec3d(h, 0, 0),
                      o + Vec3d(0.5 * h, 0, tiny * h)},
                     {o + Vec3d(0.3 * h, 0.002, tiny * h), o, o + Vec3d(h, 0, 0),
                      o + Vec3d(0.5 * h, tiny * h, tiny * h)}});
    // Two edges at a tiny angle, crossing or passing over each other.
    edges.push_back(
        {false,
         {o, o + Vec3d(h, 0, 0), o + Vec3d(0, -tiny * h, 0.003), o + Vec3d(h, tiny * h, 0.003)},
         {o, o + Vec3d(h, 0, 0), o + Vec3d(0, -tiny * h, 0.0), o + Vec3d(h, tiny * h, 0.0)}});
    // Parallel edges side by side, overlapping by a part.
    edges.push_back(
        {false,
         {o, o + Vec3d(h, 0, 0), o + Vec3d(0.5 * h, 0.005, 0), o + Vec3d(1.5 * h, 0.005, tiny * h)},
         {o, o + Vec3d(h, 0, 0), o + Vec3d(0.5 * h, 0.004, 0),
          o + Vec3d(1.5 * h, 0.004, tiny * h)}});
  }
  // Collapsed primitives: a triangle and an edge of one point, a point on a triangle's plane.
  faces.push_back({true, {o + Vec3d(0, 0.003, 0), o, o, o}, {o, o, o, o}});
  faces.push_back({true,
                   {o + Vec3d(0.25 * h, 0.25 * h, 0), o, o + Vec3d(h, 0, 0), o + Vec3d(0, h, 0)},
                   {o + Vec3d(2 * h, 2 * h, 0), o, o + Vec3d(h, 0, 0), o + Vec3d(0, h, 0)}});
  edges.push_back({false, {o, o, o + Vec3d(0, 0.004, 0), o + Vec3d(h, 0.004, 0)}, {o, o, o, o}});
  FeatureCounts features;
  EXPECT_EQ(checkLanes(faces), 15);
  EXPECT_EQ(checkLanes(edges, &features), 27);
  // Nearly parallel edges are left unclassified; the crossing ones at 1e-1 are not.
  EXPECT_GT(features.counts[kUnknownFeature], 20);
  EXPECT_GT(features.counts[kEdgeInteriors] + features.counts[kEdgeEnds], 0);
}

TEST(PairDistanceLanes, PublicCcdQueryConfigurations) {
  std::vector<PairMotion> faces, edges;
  for (const test::CcdQuery& q : test::loadPublicCcdSet()) {
    PairMotion m;
    m.vertexFace = q.vertexFace;
    for (int k = 0; k < 4; ++k) m.start[k] = q.x[k], m.end[k] = q.x[k + 4];
    (m.vertexFace ? faces : edges).push_back(m);
  }
  FeatureCounts features;
  EXPECT_EQ(checkLanes(faces), 1353);
  EXPECT_EQ(checkLanes(edges, &features), 1508);
}

}  // namespace
}  // namespace nucleon
