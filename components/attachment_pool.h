// Attachments (nucleon/attachments.h) as the solver holds them: one row per attachment, particles
// in global indices. Static lifetime apart from the multipliers (one substep), the handles'
// targets (each substep) and the broken flags, which only ever turn on.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "components/kinematic_tracks.h"
#include "nucleon/attachments.h"
#include "nucleon/types.h"

namespace nucleon {

struct AttachmentPool {
  std::vector<AttachmentKind> kind;
  // [attached, target or triangle corner 0, corner 1, corner 2] (unused entries repeat the first).
  std::vector<std::array<Index, 4>> particles;
  std::vector<Vec3> weights;  // barycentric weights of the surface kinds
  std::vector<Real> distance, compliance, strength;
  std::vector<double> lambda;
  std::vector<std::uint8_t> broken;
  // Taken out by the host (World::removeAttachment, a drag let go): skipped like a broken one,
  // but not a break.
  std::vector<std::uint8_t> removed;
  std::vector<std::uint8_t> drag;  // made by World::beginDrag: its target moves by moveDrag
  // PointToTransform: the track (in `tracks`) that poses the particle's rest position `rest`, and
  // where it puts it at the end of the current substep.
  std::vector<Index> track;
  std::vector<Vec3> rest;
  std::vector<Vec3> target;
  std::vector<KinematicTrack> tracks;
  std::uint64_t brokenCount = 0;

  std::size_t size() const { return kind.size(); }
};

}  // namespace nucleon
