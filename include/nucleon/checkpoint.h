// Checkpoints: a World's state written between steps and read back into a world built the same
// way, so that a run can stop and go on. A resumed world steps to the same bits as one that never
// stopped (World::stateHash).
//
//   std::ofstream out("frame_0060.ckpt", std::ios::binary);
//   nucleon::saveCheckpoint(world, out, sceneFingerprint);
//   ...
//   nucleon::World resumed = nucleon::buildWorld(scene);   // the same scene and settings
//   std::ifstream in("frame_0060.ckpt", std::ios::binary);
//   nucleon::loadCheckpoint(resumed, in, sceneFingerprint);
//
// What a checkpoint holds: every particle's position, velocity, prediction and inverse mass; the
// world's clock and step count; gas amounts, broken attachments, targets given to colliders, the
// tear timers, every counter of the reports, and the collision caches a step hands to the next
// (candidate pairs, their bounds, the broad phase's boxes, the narrow phase's per-pair bounds).
// The rest (objects, constraints, colliders, settings, derived tables) comes from the scene the
// world is built from (ARCHITECTURE.md §5, "Checkpoints").
#pragma once

#include <cstdint>
#include <iosfwd>
#include <stdexcept>
#include <string>

#include "nucleon/world.h"

namespace nucleon {

// A checkpoint that cannot be read into this world: another format or library version, another
// precision, another scene (the label or the world's structure differ), a world with a cloth torn
// since it was built (a checkpoint loads into a world as built), or a truncated file. what() is
// one line.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The format's version: a checkpoint written under another is refused.
constexpr std::uint32_t kCheckpointFormat = 2;

// Writes the world's state. `label` is the caller's name for what the world was built from (the
// command line uses a hash of the scene file and its settings); loadCheckpoint refuses a label
// that differs. A torn cloth's mesh is written as the tears left it. Throws std::runtime_error
// when the stream fails.
void saveCheckpoint(const World& world, std::ostream& out, const std::string& label);

// Reads a checkpoint into `world`, which must have been built like the one that wrote it (same
// objects in the same order, same particles and constraints, same label). Throws CheckpointError
// and leaves the world as it was when anything does not match.
void loadCheckpoint(World& world, std::istream& in, const std::string& label);

// The label a checkpoint was written with, read from its header (CheckpointError if the file is
// not a checkpoint of this format).
std::string checkpointLabel(std::istream& in);

}  // namespace nucleon
