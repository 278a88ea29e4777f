// Reading and writing meshes as Wavefront OBJ.
#pragma once

#include <array>
#include <span>
#include <string>

#include "nucleon/world.h"

namespace nucleon {

// Loads the vertices and faces of an OBJ file (polygons are triangulated as fans; all groups are
// merged into one mesh). Throws MeshError naming the file on a missing file or a parse error.
ObjectDef loadObj(const std::string& path);

// Writes positions (offset by `first`) with triangles as `f` lines and edges as `l` lines.
// Throws std::runtime_error if the file cannot be written.
void writeObj(const std::string& path, std::span<const Vec3> positions,
              std::span<const std::array<Index, 3>> triangles,
              std::span<const std::array<Index, 2>> edges);

}  // namespace nucleon
