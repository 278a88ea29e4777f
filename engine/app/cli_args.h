// Argument helpers shared by the commands of the `nucleon` program.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "nucleon/scene.h"

namespace nucleon::cli {

// Thrown for a command line or input that cannot be run; the message is the whole error line.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A command's arguments after its name, walked in order:
//   for (Arguments arguments(args); arguments.next();)
//     if (arguments.current() == "--frames") frames = parseInt("--frames", arguments.value(), …);
// value() takes the argument after the current flag, or throws UsageError saying the flag needs
// one.
class Arguments {
 public:
  explicit Arguments(const std::vector<std::string>& args) : args_(args) {}
  bool next() { return ++index_ < args_.size(); }
  const std::string& current() const { return args_[index_]; }
  const std::string& value() {
    if (index_ + 1 >= args_.size()) throw UsageError(args_[index_] + " needs a value");
    return args_[++index_];
  }

 private:
  const std::vector<std::string>& args_;
  std::size_t index_ = 0;  // args_[0] is the command's name
};

// The scene file `path` with `sets` applied (applySceneOverrides): its text after them, for a
// run's label, and the scene parsed from it (meshes looked up beside the file). A SceneError
// becomes a UsageError.
struct SceneSource {
  std::string text;
  Scene scene;
};
SceneSource loadSceneWithSets(const std::string& path, const std::vector<std::string>& sets);
// The same from the file's text, read once for many sets of settings (a sweep's grid).
Scene parseSceneWithSets(const std::string& text, const std::vector<std::string>& sets,
                         const std::string& path);
// The scene file's text; a SceneError becomes a UsageError.
std::string readSceneText(const std::string& path);

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
