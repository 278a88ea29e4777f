// Turns schedules (sweep counts per family, world-wide and per object) into the ordered list of
// sweeps a substep runs.
#pragma once

#include <span>

#include "components/objects.h"
#include "components/sweep_plan.h"
#include "nucleon/solver_settings.h"

namespace nucleon {

// Round r of R runs a family with n sweeps when ⌊(r+1)n/R⌋ > ⌊rn/R⌋ (Bresenham spacing), so
// families interleave evenly instead of running one after another. Families are visited in the
// world schedule's order within a round; families only an object's schedule names come after,
// in the default order.
// `familyCount`: the built-in families and the world's registered ones.
SweepPlan planSweeps(const SolverSettings& solver, std::span<const ObjectRecord> objects,
                     std::size_t familyCount = kBuiltinFamilyCount);

// Throws std::invalid_argument naming `what` if a schedule names a family the world does not
// have, repeats a family or has a count outside [0, 100000].
void validateSchedule(const Schedule& schedule, const std::string& what,
                      std::size_t familyCount = kBuiltinFamilyCount);

}  // namespace nucleon
