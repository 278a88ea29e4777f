#include "engine/app/cli_args.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <sstream>

namespace nucleon::cli {

std::string readSceneText(const std::string& path) {
  try {
    return readSceneFile(path);
  } catch (const SceneError& e) {
    throw UsageError(e.what());
  }
}

Scene parseSceneWithSets(const std::string& text, const std::vector<std::string>& sets,
                         const std::string& path) {
  try {
    return parseScene(applySceneOverrides(text, sets, path), path,
                      std::filesystem::path(path).parent_path().string());
  } catch (const SceneError& e) {
    throw UsageError(e.what());
  }
}

SceneSource loadSceneWithSets(const std::string& path, const std::vector<std::string>& sets) {
  SceneSource source;
  try {
    source.text = applySceneOverrides(readSceneFile(path), sets, path);
    source.scene =
        parseScene(source.text, path, std::filesystem::path(path).parent_path().string());
  } catch (const SceneError& e) {
    throw UsageError(e.what());
  }
  return source;
}

int parseInt(const std::string& flag, const std::string& value, int lo, int hi) {
  std::size_t used = 0;
  long long x = 0;
  try {
    x = std::stoll(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != value.size() || value.empty() || x < lo || x > hi)
    throw UsageError(flag + " expects an integer in [" + std::to_string(lo) + ", " +
                     std::to_string(hi) + "], got '" + value + "'");
  return static_cast<int>(x);
}

double parseNumber(const std::string& flag, const std::string& value, double lo, double hi) {
  char* end = nullptr;
  const double x = std::strtod(value.c_str(), &end);
  if (value.empty() || end != value.c_str() + value.size() || !std::isfinite(x) || x < lo ||
      x > hi) {
    std::ostringstream expected;
    if (std::isinf(hi))
      expected << "a finite number >= " << lo;
    else
      expected << "a number in [" << lo << ", " << hi << ']';
    throw UsageError(flag + " expects " + expected.str() + ", got '" + value + "'");
  }
  return x;
}

std::vector<std::string> splitList(const std::string& value) {
  std::vector<std::string> out;
  std::stringstream in(value);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

std::vector<int> parseIntList(const std::string& flag, const std::string& value, int lo, int hi) {
  std::vector<int> out;
  for (const std::string& item : splitList(value)) out.push_back(parseInt(flag, item, lo, hi));
  if (out.empty()) throw UsageError(flag + " expects a comma-separated list, got '" + value + "'");
  return out;
}

std::string hex16(std::uint64_t value) {
  std::ostringstream s;
  s << std::hex << std::setw(16) << std::setfill('0') << value;
  return s.str();
}

}  // namespace nucleon::cli
