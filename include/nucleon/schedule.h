// The schedule: how often and in which order the constraint families are swept.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "nucleon/constraint_family.h"

namespace nucleon {

// How many sweeps per substep each family gets, and the order in which they interleave: the
// families are visited in list order within a round, and a family with n sweeps runs in n of the
// R rounds of a substep (R = the largest count), spread evenly. {stretch 4, bend 2} solves
// stretch, stretch, bend, stretch, stretch, bend. Families the list leaves out are not solved.
struct ScheduleEntry {
  ConstraintFamily family = ConstraintFamily::Stretch;
  int sweeps = 1;
};
using Schedule = std::vector<ScheduleEntry>;
// The same schedule with its largest count set to `sweeps` and the others scaled in proportion
// (rounded, and at least 1 where they were non-zero).
Schedule rescaleSchedule(const Schedule& schedule, int sweeps);

}  // namespace nucleon
