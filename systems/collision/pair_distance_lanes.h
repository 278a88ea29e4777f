// Distance bounds of many vertex–face or edge–edge pairs at once, in float lanes: the narrow
// phase's first filter. Most candidate pairs never come within reach in a substep (on a cloth
// pile about three in four are ruled out by their distance at the start or the end of the
// motion); measuring them one at a time in double, with the branches of a closest-point search,
// cost as much per pair as everything else the narrow phase does. Here the distances are taken
// branch-free over kPairLanes pairs (each candidate feature of the closest point measured and
// the least kept: Ericson, Real-Time Collision Detection, 2005, §5.1.5 and §5.1.9), so that the
// compiler runs the lanes side by side; a pair they leave within reach is measured again by the
// exact double code, which makes its contact.
//
// Positions are relative to the pair's particle 0 (a distance does not change under a common
// translation), so the float rounding scales with the pair's own extent, not with where it is.
// Every figure here carries an error of at most kPairLaneTolerance × the lane's extent
// (`extent`: the largest coordinate of the relative positions): the rounding, and the two
// features skipped on purpose (the inside of a sliver triangle, the crossing point of two
// nearly parallel edges, whose distances the features around them then bound within that
// amount). A caller takes that much off before it trusts a bound. A lane with a coordinate that
// is not finite gets a bound that compares false with everything.
#pragma once

#include <cstdint>

namespace nucleon {

constexpr int kPairLanes = 16;
constexpr float kPairLaneTolerance = 4e-3f;

struct PairLanes {
  // start[k][axis][lane]: particle k at the start of the motion, less particle 0 there; end the
  // same at the end of the motion. VertexFace: particle 0 the point, 1–3 the triangle; EdgeEdge:
  // 0–1 one edge, 2–3 the other. Lanes past the used ones hold anything finite.
  float start[4][3][kPairLanes];
  float end[4][3][kPairLanes];
};

struct PairLaneBounds {
  float startDistance[kPairLanes];  // the distance at the start of the motion
  float endDistance[kPairLanes];    // at its end
  // How much the distance can shrink over the motion: the largest motion of a particle of each
  // side relative to particle 0, the two summed (as the narrow phase's motion bound).
  float motion[kPairLanes];
  float extent[kPairLanes];  // the scale of the errors above
  // Edge–edge lanes only: where the closest points of the two edges lie at the start and at the
  // end of the motion, a PairFeature (vertex–face lanes: kUnknownFeature). The classification is
  // only made with a margin (a few thousandths of an edge) on the safe side of the border
  // between the two, where the exact closest points of the edges (Ericson §5.1.9, clamped)
  // agree with it.
  float startFeature[kPairLanes];
  float endFeature[kPairLanes];
};

enum PairFeature : int {
  kUnknownFeature = 0,
  kEdgeInteriors = 1,  // inside both edges: neither clamped to an end
  kEdgeEnds = 2,       // at an end of one edge at least
};

void vertexFaceLaneBounds(const PairLanes& lanes, PairLaneBounds& out);
void edgeEdgeLaneBounds(const PairLanes& lanes, PairLaneBounds& out);

}  // namespace nucleon
