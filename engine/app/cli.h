// The `nucleon` command line (documented in README.md): run, scenes, help. Kept in a library so
// tests can drive it without starting a process.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace nucleon {

// Runs one command line (without the program name). Normal output goes to `out`, progress and
// errors to `err`. Returns the exit code: 0 success, 2 bad input or usage.
int runCommandLine(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace nucleon
