// The sweeps of one substep in execution order, derived from the world's schedule and the
// objects' own schedules (systems/setup/sweep_schedule.h). Rebuilt when objects or the solver
// settings change, read by the solve stage.
#pragma once

#include <cstdint>
#include <vector>

#include "nucleon/schedule.h"

namespace nucleon {

struct SweepOp {
  ConstraintFamily family = ConstraintFamily::Stretch;
  std::int32_t objectRunsOffset = -1;  // into SweepPlan::objectRuns; −1 = every object takes part
  bool endsRound = false;              // the last sweep of its round: contacts are projected next
};

struct SweepPlan {
  std::vector<SweepOp> ops;
  // For ops restricted to some objects: one byte per object (1 = its constraints take part).
  std::vector<std::uint8_t> objectRuns;
  int rounds = 0;                   // R: the largest sweep count of any family of any object
  std::vector<int> sweepsOfFamily;  // ops per family id (world schedule)
  std::uint64_t projectionsPerSubstep = 0;  // constraint projections the ops perform
};

}  // namespace nucleon
