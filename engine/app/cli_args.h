// Argument helpers shared by the commands of the `nucleon` program.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace nucleon::cli {

// Thrown for a command line or input that cannot be run; the message is the whole error line.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// An integer in [lo, hi], or UsageError naming the flag.
int parseInt(const std::string& flag, const std::string& value, int lo, int hi);
// A finite number in [lo, hi] (hi may be infinite: no upper bound), or UsageError naming the flag.
double parseNumber(const std::string& flag, const std::string& value, double lo, double hi);
// A comma-separated list of such integers ("1,2,4").
std::vector<int> parseIntList(const std::string& flag, const std::string& value, int lo, int hi);
// Splits "a,b,c" into its non-empty items.
std::vector<std::string> splitList(const std::string& value);
// 16 lowercase hex digits.
std::string hex16(std::uint64_t value);

}  // namespace nucleon::cli
