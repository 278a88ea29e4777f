#include "nucleon/lanes.h"

#include <atomic>

#include "systems/solver/distance_lanes.h"

namespace nucleon {
namespace {

LaneIsa detectLaneIsa() {
#if NUCLEON_DISTANCE_LANES
  __builtin_cpu_init();
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) return LaneIsa::None;
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl"))
    return LaneIsa::Avx512;
  return LaneIsa::Avx2;
#else
  return LaneIsa::None;  // double state, or not x86-64: the kernels are not built
#endif
}

// Relaxed: the set is read at every batched call and only changed between steps.
std::atomic<LaneIsa>& currentLaneIsa() {
  static std::atomic<LaneIsa> current{bestLaneIsa()};
  return current;
}

}  // namespace

LaneIsa bestLaneIsa() {
  static const LaneIsa best = detectLaneIsa();  // a property of the CPU, read once
  return best;
}

LaneIsa laneIsa() {
  return currentLaneIsa().load(std::memory_order_relaxed);
}

bool selectLaneIsa(LaneIsa isa) {
  if (static_cast<int>(isa) > static_cast<int>(bestLaneIsa())) return false;
  currentLaneIsa().store(isa, std::memory_order_relaxed);
  return true;
}

const char* laneIsaName(LaneIsa isa) {
  switch (isa) {
    case LaneIsa::Avx2:
      return "avx2";
    case LaneIsa::Avx512:
      return "avx512";
    default:
      return "none";
  }
}

bool parseLaneIsa(std::string_view name, LaneIsa& isa) {
  for (LaneIsa candidate : {LaneIsa::None, LaneIsa::Avx2, LaneIsa::Avx512})
    if (name == laneIsaName(candidate)) {
      isa = candidate;
      return true;
    }
  return false;
}

}  // namespace nucleon
