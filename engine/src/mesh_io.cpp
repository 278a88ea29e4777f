#include "nucleon/mesh_io.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include <tiny_obj_loader.h>

#include "components/simplicial_complex.h"

namespace nucleon {

ObjectDef loadObj(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw MeshError(path + ": no such mesh file");
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(path, config)) {
    std::string message = reader.Error();
    while (!message.empty() && (message.back() == '\n' || message.back() == '\r'))
      message.pop_back();
    throw MeshError(path + ": " + (message.empty() ? "cannot parse OBJ" : message));
  }
  ObjectDef def;
  const auto& coords = reader.GetAttrib().vertices;
  for (std::size_t i = 0; i + 2 < coords.size(); i += 3)
    def.vertices.emplace_back(static_cast<Real>(coords[i]), static_cast<Real>(coords[i + 1]),
                              static_cast<Real>(coords[i + 2]));
  for (const auto& shape : reader.GetShapes()) {
    const auto& idx = shape.mesh.indices;
    std::size_t offset = 0;
    for (unsigned char count : shape.mesh.num_face_vertices) {
      if (count != 3)
        throw MeshError(path + ": a face with " + std::to_string(count) + " vertices");
      std::array<Index, 3> t;
      for (int k = 0; k < 3; ++k) {
        const int v = idx[offset + k].vertex_index;
        if (v < 0 || static_cast<std::size_t>(v) >= def.vertices.size())
          throw MeshError(path + ": face uses vertex " + std::to_string(v + 1) +
                          " but the file has " + std::to_string(def.vertices.size()));
        t[k] = static_cast<Index>(v);
      }
      def.triangles.push_back(t);
      offset += count;
    }
    for (std::size_t k = 0; k + 1 < shape.lines.indices.size(); k += 2)
      def.edges.push_back({static_cast<Index>(shape.lines.indices[k].vertex_index),
                           static_cast<Index>(shape.lines.indices[k + 1].vertex_index)});
  }
  if (def.vertices.empty()) throw MeshError(path + ": no vertices");
  return def;
}

void writeObj(const std::string& path, std::span<const Vec3> positions,
              std::span<const std::array<Index, 3>> triangles,
              std::span<const std::array<Index, 2>> edges) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "w"), &std::fclose);
  if (!file) throw std::runtime_error(path + ": cannot write");
  std::FILE* f = file.get();
  for (const Vec3& p : positions)
    std::fprintf(f, "v %.9g %.9g %.9g\n", double(p.x()), double(p.y()), double(p.z()));
  for (const auto& t : triangles) std::fprintf(f, "f %u %u %u\n", t[0] + 1, t[1] + 1, t[2] + 1);
  for (const auto& e : edges) std::fprintf(f, "l %u %u\n", e[0] + 1, e[1] + 1);
  if (std::ferror(f)) throw std::runtime_error(path + ": write failed");
}

}  // namespace nucleon
