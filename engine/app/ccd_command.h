// `nucleon ccd`: runs the continuous collision detection narrow phase (systems/collision/ccd.h)
// over a file of vertex–face and edge–edge queries, reports hits and time per query, writes the
// answers, and counts false negatives and false positives against the truth column when the file
// has one.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace nucleon {

extern const char* const kCcdHelp;

// args[0] is "ccd". Throws cli::UsageError on bad input.
int runCcd(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace nucleon
