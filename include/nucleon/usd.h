// A run as one USD ASCII layer (.usda): every object's points sampled once per frame, readable by
// any USD tool (usdview, Houdini, Blender, Omniverse). Cloths, colliders and solids' surfaces are
// UsdGeomMesh prims, ropes BasisCurves (linear, one curve per chain of segments), particle clouds
// Points, sphere colliders Sphere prims; all under /World, Y up, metres, the scene's frame rate.
//
//   nucleon::UsdRecorder usd(world, 60);
//   for (int frame = 1; frame <= 120; ++frame) { world.step(1.0 / 60); usd.addFrame(world, frame);
//   } usd.write("run.usda");
//
// The samples are kept in memory (12 bytes per particle per frame) until write().
#pragma once

#include <string>
#include <vector>

#include "nucleon/world.h"

namespace nucleon {

class UsdRecorder {
 public:
  // Takes the objects' names and topology as they are now (a cloth torn later keeps its first
  // triangles: the points are sampled, the faces are not).
  UsdRecorder(const World& world, double fps);
  // Samples every object's points at time code `frame`.
  void addFrame(const World& world, int frame);
  // Writes the layer; throws std::runtime_error when the file cannot be written.
  void write(const std::string& path) const;

 private:
  struct Prim {
    std::string type, name;
    std::size_t object = 0;
    std::vector<int> counts;        // faceVertexCounts or curveVertexCounts
    std::vector<Index> indices;     // faceVertexIndices; for curves, the object's vertices
    std::vector<Index> pointOrder;  // curves: which of the object's vertices, in curve order
    float width = 0;                // curves and points: the contact thickness twice
  };
  double fps_ = 60;
  std::vector<Prim> prims_;
  std::vector<SphereCollider> spheres_;
  std::vector<int> frames_;
  std::vector<std::vector<std::vector<float>>> samples_;  // per prim, per frame: x y z …
};

}  // namespace nucleon
