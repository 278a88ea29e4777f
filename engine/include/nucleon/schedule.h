// Constraint families and the schedule that says how often and in which order they are swept.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace nucleon {

// The constraint families a schedule names (ARCHITECTURE.md §2): stretch (type 1, edges), shear
// (type 2 at triangle corners), bend (type 3 hinges of cloth and type 2 angles of curves), twist
// (type 3 on four consecutive curve points), volume (tetrahedra), tether (long-range
// attachments of free particles to the nearest pin).
enum class ConstraintFamily { Stretch, Shear, Bend, Twist, Volume, Tether };
constexpr std::size_t kConstraintFamilyCount = 6;
const char* toString(ConstraintFamily family);
// Parses "stretch", "shear", "bend", "twist", "volume", "tether"; false on anything else.
bool parseConstraintFamily(const std::string& name, ConstraintFamily& out);

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
