// `nucleon view SCENE.json`: the scene run live in a window (GLFW, OpenGL 3.3, Dear ImGui), the
// simulation on a thread of its own so that a slow step never freezes the window; with --frames
// and --screenshot it runs that many frames, saves the picture and exits (tests, scripts).
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace nucleon {

extern const char* const kViewHelp;

// args[0] is "view". Throws cli::UsageError on bad input; returns 1 when no window could be
// opened (no display, no OpenGL 3.3).
int runView(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace nucleon
