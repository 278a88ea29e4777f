// `nucleon bench`: runs scenes headless at several thread counts and reports step time (median
// of repeats, warm-up excluded), the engine's per-stage profile, constraint projections per
// second, parallel speedup and efficiency, strain, the repairs the step made, and the final
// state hash.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace nucleon {

extern const char* const kBenchHelp;

// args[0] is "bench". Throws cli::UsageError on bad input.
int runBench(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace nucleon
