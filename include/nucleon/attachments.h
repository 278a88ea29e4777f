// Attachments (Nucleus's nConstraints): compliant constraints that join a particle to another
// object's particle, to a point on another object's triangle, to a triangle's plane it slides on,
// or to an animated handle. Each is an XPBD constraint (Macklin et al. 2016), projected in every
// backend as the family "attachment" (before the round's contacts), and each breaks when the force
// it exerts exceeds its strength (glue strength): it is then removed for the rest of the run and
// counted.
//
//   Attachment a;
//   a.kind = AttachmentKind::PointToPoint;
//   a.object = cloth;  a.vertex = 12;   // this particle…
//   a.target = rope;   a.targetVertex = 0;   // …held to that one
//   a.strength = 40;   // N: torn apart beyond it
//   world.addAttachment(a);
#pragma once

#include <array>

#include "nucleon/object_def.h"
#include "nucleon/types.h"

namespace nucleon {

enum class AttachmentKind {
  // C = |x − x_target| − distance: a pin, a weld (distance 0) or a rod between two objects (or
  // two particles of one).
  PointToPoint,
  // C = |x − Σ β_k x_k| − distance: held to the point at barycentric weights β on a triangle of
  // the target object, which moves with it.
  PointToSurface,
  // C = n · (x − Σ β_k x_k) − distance, n the triangle's unit normal (right-handed in the order
  // of `triangle`): held at the signed offset along the normal of the triangle's plane, free to
  // slide along it.
  SlideOnSurface,
  // C = |x − T(t) x_rest|: pulled to where `motion` puts its rest position at the substep's end
  // (a handle; with a compliance, the input-mesh attract of a whole object towards its animated
  // rest shape).
  PointToTransform,
};

const char* toString(AttachmentKind kind);

struct Attachment {
  AttachmentKind kind = AttachmentKind::PointToPoint;
  ObjectId object;  // the attached particle's object and its local vertex index
  Index vertex = 0;
  ObjectId target;         // PointToPoint and the surface kinds: the other object
  Index targetVertex = 0;  // PointToPoint: its local vertex index
  // The surface kinds: three local vertex indices of the target (a triangle: they need not be
  // one of its mesh triangles) and barycentric weights (finite, summing to 1).
  std::array<Index, 3> triangle{0, 0, 0};
  Vec3 weights = Vec3(Real(1) / 3, Real(1) / 3, Real(1) / 3);
  ColliderMotion motion;  // PointToTransform: keyframes or a bend (animated() need not hold)
  // m: held distance, non-negative (for SlideOnSurface the signed offset along the normal).
  Real distance = 0;
  Real compliance = 0;  // m/N (XPBD α); 0 is hard
  Real strength = 0;    // N: breaks when |λ|/h² exceeds it; 0 never breaks
};

}  // namespace nucleon
