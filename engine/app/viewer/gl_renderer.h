// Draws a SceneSnapshot with OpenGL 3.3 core: surfaces smooth-shaded with area-weighted vertex
// normals (both sides lit, back faces a darker tint), optionally coloured by strain; ropes as
// lines, particles as round points, sphere colliders as shaded spheres, the ground as a
// checkered plane. Needs a current GL 3.3 context.
#pragma once

#include <array>
#include <vector>

#include "engine/app/viewer/scene_snapshot.h"

namespace nucleon::viewer {

struct Camera {
  Vec3d target = Vec3d::Zero();
  double yaw = 0.6, pitch = 0.35, distance = 4;  // radians, radians, m
  double fovY = 0.7;                             // radians
  Vec3d eye() const;
  // Column-major view-projection for an aspect ratio (width / height).
  std::array<float, 16> viewProjection(double aspect) const;
};

struct DrawOptions {
  bool strainColours = false;
  bool contacts = false;  // the pressed contacts as green points
  bool colliders = true;
  bool ground = true;
  float strainScale = 0.05f;  // strain drawn fully red
};

class GlRenderer {
 public:
  GlRenderer();  // compiles the shaders: needs the context
  ~GlRenderer();
  GlRenderer(const GlRenderer&) = delete;
  GlRenderer& operator=(const GlRenderer&) = delete;
  void draw(const SceneSnapshot& scene, const Camera& camera, int width, int height,
            const DrawOptions& options);

 private:
  struct Vertex {
    float x, y, z, nx, ny, nz, r, g, b;
  };
  void upload(const std::vector<Vertex>& vertices);
  unsigned program_ = 0, vao_ = 0, vbo_ = 0;
  int viewProjection_ = -1, eye_ = -1, pointSize_ = -1, lit_ = -1;
  std::vector<Vertex> triangles_, lines_, points_;
  // A sphere collider's mesh, the unit icosphere's triangle corners in draw order (each corner is
  // its own normal), built once and scaled and moved per sphere per frame.
  std::vector<Vec3> unitSphereCorners_;
};

}  // namespace nucleon::viewer
