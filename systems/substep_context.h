// What every stage of a substep receives: its length and where it sits in the step and in time.
// The world makes one per substep (World::step); the step graph hands it to each stage, and the
// stages hand what they need of it to their systems.
#pragma once

#include <cstdint>

#include "nucleon/types.h"

namespace nucleon {

struct SubstepContext {
  Real h = 0;              // substep length in seconds
  Real inverseH = 0;       // 1/h
  int substep = 0;         // this substep's index in its step, from 0
  int substeps = 1;        // substeps per step
  double time = 0;         // simulated seconds when the substep starts
  double endTime = 0;      // … and when it ends (the step's end exactly, for its last substep)
  std::uint64_t step = 0;  // 1-based number of the step the substep belongs to
};

}  // namespace nucleon
