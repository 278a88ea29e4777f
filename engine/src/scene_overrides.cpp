// Scene settings changed from outside the file (nucleon/scene.h, applySceneOverrides): the
// command line's `--set` and the sweeps' grids.
#include <string>

#include <nlohmann/json.hpp>

#include "nucleon/scene.h"

namespace nucleon {

namespace {

using Json = nlohmann::json;

// "a.b.0.c" → {"a", "b", "0", "c"}; empty parts are refused by the caller.
std::vector<std::string> splitPath(const std::string& path) {
  std::vector<std::string> parts;
  std::string part;
  for (const char c : path) {
    if (c == '.') {
      parts.push_back(part);
      part.clear();
    } else
      part.push_back(c);
  }
  parts.push_back(part);
  return parts;
}

bool isIndex(const std::string& part) {
  return !part.empty() && part.size() < 10 &&
         part.find_first_not_of("0123456789") == std::string::npos;
}

}  // namespace

std::string applySceneOverrides(const std::string& text, std::span<const std::string> overrides,
                                const std::string& label) {
  if (overrides.empty()) return text;
  Json scene;
  try {
    scene = Json::parse(text);
  } catch (const Json::exception&) {
    return text;  // parseScene reports the syntax error with its position
  }
  for (const std::string& entry : overrides) {
    const std::size_t equals = entry.find('=');
    if (equals == std::string::npos || equals == 0)
      throw SceneError(label + ": setting '" + entry + "' is not KEY=VALUE");
    const std::string path = entry.substr(0, equals), raw = entry.substr(equals + 1);
    // A JSON value (number, true, [1, 2], "text"), else the text as a string: `solver.kind=jacobi`.
    Json value = Json::parse(raw, nullptr, false);
    if (value.is_discarded()) value = raw;
    Json* at = &scene;
    std::string walked;
    for (const std::string& part : splitPath(path)) {
      if (part.empty()) throw SceneError(label + ": setting '" + entry + "' has an empty key");
      walked += walked.empty() ? part : "." + part;
      if (at->is_array()) {
        if (!isIndex(part) || std::stoul(part) >= at->size())
          throw SceneError(label + ": setting '" + entry + "': '" + walked +
                           "' is not an index of the list (it has " + std::to_string(at->size()) +
                           " entries)");
        at = &(*at)[std::stoul(part)];
      } else if (at->is_object() || at->is_null()) {
        at = &(*at)[part];  // a missing key is added; parseScene then checks it as any key
      } else
        throw SceneError(label + ": setting '" + entry + "': '" + walked +
                         "' is inside a value that has no keys");
    }
    *at = value;
  }
  return scene.dump(2);
}

}  // namespace nucleon
