#include "systems/setup/sweep_schedule.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace nucleon {
namespace {

using Counts = std::vector<int>;

Counts countsOf(const Schedule& schedule, std::size_t familyCount) {
  Counts counts(familyCount, 0);
  for (const ScheduleEntry& e : schedule) counts[familyIndex(e.family)] = e.sweeps;
  return counts;
}

bool runsInRound(int sweeps, int round, int rounds) {
  return sweeps > 0 && (round + 1) * sweeps / rounds > round * sweeps / rounds;
}

}  // namespace

void validateSchedule(const Schedule& schedule, const std::string& what, std::size_t familyCount) {
  std::vector<bool> seen(familyCount, false);
  for (const ScheduleEntry& e : schedule) {
    const std::size_t f = familyIndex(e.family);
    if (f >= familyCount) throw std::invalid_argument(what + ": unknown family");
    if (seen[f])
      throw std::invalid_argument(what + ": family '" + toString(e.family) + "' appears twice");
    seen[f] = true;
    if (e.sweeps < 0 || e.sweeps > 100000)
      throw std::invalid_argument(what + ": sweeps of '" + toString(e.family) +
                                  "' must be in [0, 100000]");
  }
}

Schedule rescaleSchedule(const Schedule& schedule, int sweeps) {
  int largest = 0;
  for (const ScheduleEntry& e : schedule) largest = std::max(largest, e.sweeps);
  Schedule out = schedule;
  if (largest == 0) return out;
  for (ScheduleEntry& e : out)
    if (e.sweeps > 0)
      e.sweeps =
          sweeps == 0
              ? 0
              : std::max(1, static_cast<int>(std::lround(double(e.sweeps) * sweeps / largest)));
  return out;
}

SweepPlan planSweeps(const SolverSettings& solver, std::span<const ObjectRecord> objects,
                     std::size_t familyCount) {
  // The default order is the family table's, then the registered families by id.
  std::vector<ConstraintFamily> defaultOrder(familyCount);
  for (std::size_t f = 0; f < familyCount; ++f) defaultOrder[f] = static_cast<ConstraintFamily>(f);
  std::vector<ConstraintFamily> order;
  Counts world(familyCount, 0);
  if (solver.schedule.empty()) {
    order = defaultOrder;
    std::fill(world.begin(), world.end(), solver.iterations);
  } else {
    for (const ScheduleEntry& e : solver.schedule) order.push_back(e.family);
    for (ConstraintFamily f : defaultOrder)
      if (std::find(order.begin(), order.end(), f) == order.end()) order.push_back(f);
    world = countsOf(solver.schedule, familyCount);
  }
  std::vector<Counts> perObject;
  bool anyOwn = false;
  for (const ObjectRecord& o : objects) {
    anyOwn = anyOwn || !o.schedule.empty();
    perObject.push_back(o.schedule.empty() ? world : countsOf(o.schedule, familyCount));
  }

  SweepPlan plan;
  plan.sweepsOfFamily.assign(familyCount, 0);
  for (int count : world) plan.rounds = std::max(plan.rounds, count);
  for (const Counts& c : perObject)
    for (int count : c) plan.rounds = std::max(plan.rounds, count);
  std::vector<std::uint8_t> runs(objects.size());
  for (int r = 0; r < plan.rounds; ++r) {
    const std::size_t roundStart = plan.ops.size();
    for (ConstraintFamily f : order) {
      const std::size_t fi = familyIndex(f);
      if (!anyOwn) {
        if (runsInRound(world[fi], r, plan.rounds)) {
          plan.ops.push_back({f, -1});
          ++plan.sweepsOfFamily[fi];
        }
        continue;
      }
      bool any = false, all = true;
      for (std::size_t o = 0; o < objects.size(); ++o) {
        runs[o] = runsInRound(perObject[o][fi], r, plan.rounds) ? 1 : 0;
        any = any || runs[o];
        all = all && runs[o];
      }
      if (!any) continue;
      ++plan.sweepsOfFamily[fi];
      if (all) {
        plan.ops.push_back({f, -1});
      } else {
        plan.ops.push_back({f, static_cast<std::int32_t>(plan.objectRuns.size())});
        plan.objectRuns.insert(plan.objectRuns.end(), runs.begin(), runs.end());
      }
    }
    if (plan.ops.size() > roundStart) plan.ops.back().endsRound = true;
  }
  return plan;
}

}  // namespace nucleon
