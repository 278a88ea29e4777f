// Scene files: JSON describing the objects, solver settings and run length of a simulation.
// The format is documented in assets/scenes/README.md.
#pragma once

#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "nucleon/world.h"

namespace nucleon {

// A scene that cannot be loaded; what() is one line naming the file and the problem.
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SceneObject {
  ObjectKind kind = ObjectKind::Cloth;
  ObjectDef def;
};

// An entry of the scene's "attachments" list: one attachment, a weld (every vertex of `object`
// within `within` of a vertex of `target`) or a handle on several vertices (one PointToTransform
// attachment per vertex of `vertices`). Objects by their index in Scene::objects.
struct SceneAttachment {
  Attachment attachment;  // its object and target ids are set when the world is built
  std::size_t object = 0, target = 0;
  std::vector<Index> vertices;
  bool weld = false;
  Real within = 0;
};

// The solver settings a scene file starts from: SolverSettings' own, with the multigrid backend
// and two substeps.
inline SolverSettings sceneSolverDefaults() {
  SolverSettings settings;
  settings.kind = SolverKind::Multigrid;
  settings.substeps = 2;
  return settings;
}

struct Scene {
  std::string path;
  std::string name;
  std::string description;
  int frames = 120;
  double fps = 60;
  int threads = 0;  // 0 = all cores
  Vec3 gravity = Vec3(0, Real(-9.81), 0);
  GroundPlane ground;  // enabled when the scene has a "ground" entry
  std::vector<PlaneCollider> planes;
  std::vector<SphereCollider> spheres;
  // Multigrid at two substeps where the file names neither: parallel, deterministic and the
  // furthest converged per sweep, and a substep half as long for the first contacts. A 160² sheet
  // left at every default and dropped on a ball stretched its edges to 8.6 times their length
  // under one substep of the serial Gauss–Seidel sweep, 3.1 times under one of multigrid, 2.6
  // times under two; a pellet shot through a sheet (bullet_cloth without its own settings) 13.5
  // times under one substep of multigrid, 1.8 times under two
  // (bench/results/2core-AMD-EPYC/torture.md, "A large sheet at the default thickness").
  SolverSettings solver = sceneSolverDefaults();
  std::vector<SceneObject> objects;
  std::vector<SceneAttachment> attachments;
  // Pairs of objects (indices in `objects`; the same one twice: its self-collision) that never
  // collide with each other, and pairs of vertex sets of objects that never do.
  std::vector<std::array<std::size_t, 2>> excludedCollisions;
  struct VertexSets {
    std::size_t object = 0, target = 0;
    std::vector<Index> vertices, targetVertices;
  };
  std::vector<VertexSets> excludedVertexSets;
};

// The scene's JSON text with settings changed: each override is "PATH=VALUE", PATH the keys down
// to the setting joined by dots (a list's entries by number: "objects.0.material.friction") and
// VALUE JSON ("10", "true", "[0, 1, 0]"; text that is not JSON is taken as a string:
// "solver.kind=jacobi"). A key the file lacks is added and then checked by parseScene as any key
// (an unknown one is refused). Throws SceneError, naming `label` and the override, for an override
// without '=', an empty key, an index past a list's end or a key inside a number or string.
std::string applySceneOverrides(const std::string& text, std::span<const std::string> overrides,
                                const std::string& label);
// A scene file's text (SceneError if it cannot be read).
std::string readSceneFile(const std::string& path);

// Reads and validates a scene file. Meshes named in it are looked up relative to the scene's
// folder, then in <assets>/meshes. Throws SceneError.
Scene loadScene(const std::string& path);
// The same from JSON text; `label` names the source in error messages, `folder` resolves meshes.
Scene parseScene(const std::string& json, const std::string& label, const std::string& folder);

// Makes a world holding the scene's objects and settings; throws SceneError if an object is
// rejected by the world (for example a degenerate mesh).
World buildWorld(const Scene& scene);

// The folder of bundled assets (scenes/, meshes/): $NUCLEON_ASSETS if set, else the source tree's
// assets/ folder, else the installed share/nucleon/assets.
std::string assetsFolder();

}  // namespace nucleon
