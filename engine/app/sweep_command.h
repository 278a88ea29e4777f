// `nucleon sweep`: a grid of scene settings expanded into independent runs of `nucleon run`, run
// here in parallel processes or written out as a job list for GNU parallel and a Slurm array,
// and their stats gathered into one CSV.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace nucleon {

extern const char* const kSweepHelp;

// args[0] is "sweep". Throws cli::UsageError on bad input; returns 1 when a run failed.
int runSweep(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace nucleon
