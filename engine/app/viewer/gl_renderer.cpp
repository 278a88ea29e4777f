#include "engine/app/viewer/gl_renderer.h"

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "nucleon/shapes.h"

namespace nucleon::viewer {
namespace {

const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 colour;
uniform mat4 viewProjection;
uniform float pointSize;
out vec3 vNormal;
out vec3 vColour;
out vec3 vPosition;
void main() {
  gl_Position = viewProjection * vec4(position, 1.0);
  gl_PointSize = pointSize;
  vNormal = normal;
  vColour = colour;
  vPosition = position;
}
)";

// Lambert from a light at the eye plus a fill light, both sides lit: a cloth's back face takes
// the flipped normal and a darker tint, so a fold reads at a glance.
const char* kFragmentShader = R"(#version 330 core
in vec3 vNormal;
in vec3 vColour;
in vec3 vPosition;
uniform vec3 eye;
uniform int lit;
out vec4 colour;
void main() {
  if (lit == 0) { colour = vec4(vColour, 1.0); return; }
  vec3 n = normalize(vNormal);
  vec3 base = vColour;
  if (!gl_FrontFacing) { n = -n; base *= 0.7; }
  vec3 toEye = normalize(eye - vPosition);
  float key = max(dot(n, toEye), 0.0);
  float fill = max(dot(n, normalize(vec3(0.3, 1.0, 0.2))), 0.0);
  colour = vec4(base * (0.25 + 0.55 * key + 0.3 * fill), 1.0);
}
)";

unsigned compile(GLenum kind, const char* source) {
  const unsigned shader = glCreateShader(kind);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[1024];
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    throw std::runtime_error(std::string("viewer: shader: ") + log);
  }
  return shader;
}

// Blue at rest through white to red at `scale` strain.
std::array<float, 3> strainColour(float strain, float scale) {
  const float t = std::min(strain / scale, 1.f);
  if (t < 0.5f) return {0.25f + 1.5f * t, 0.45f + 1.1f * t, 0.9f + 0.2f * t};
  const float u = (t - 0.5f) * 2;
  return {1.f, 1.f - 0.8f * u, 1.f - 0.85f * u};
}

std::array<float, 3> objectColour(ObjectKind kind, std::size_t index) {
  if (kind == ObjectKind::Collider) return {0.62f, 0.62f, 0.6f};
  static const std::array<std::array<float, 3>, 4> palette = {
      {{0.85f, 0.42f, 0.25f}, {0.25f, 0.55f, 0.85f}, {0.35f, 0.7f, 0.35f}, {0.8f, 0.7f, 0.25f}}};
  return palette[index % palette.size()];
}

}  // namespace

Vec3d Camera::eye() const {
  return target + distance * Vec3d(std::cos(pitch) * std::sin(yaw), std::sin(pitch),
                                   std::cos(pitch) * std::cos(yaw));
}

std::array<float, 16> Camera::viewProjection(double aspect) const {
  const Vec3d e = eye();
  const Vec3d f = (target - e).normalized();
  const Vec3d s = f.cross(Vec3d(0, 1, 0)).normalized();
  const Vec3d u = s.cross(f);
  Eigen::Matrix4d view = Eigen::Matrix4d::Identity();
  view.block<1, 3>(0, 0) = s.transpose();
  view.block<1, 3>(1, 0) = u.transpose();
  view.block<1, 3>(2, 0) = -f.transpose();
  view(0, 3) = -s.dot(e), view(1, 3) = -u.dot(e), view(2, 3) = f.dot(e);
  const double nearPlane = std::max(0.01, distance * 0.01), farPlane = distance * 50 + 10;
  const double t = 1 / std::tan(fovY / 2);
  Eigen::Matrix4d projection = Eigen::Matrix4d::Zero();
  projection(0, 0) = t / aspect, projection(1, 1) = t;
  projection(2, 2) = -(farPlane + nearPlane) / (farPlane - nearPlane);
  projection(2, 3) = -2 * farPlane * nearPlane / (farPlane - nearPlane);
  projection(3, 2) = -1;
  const Eigen::Matrix4f m = (projection * view).cast<float>();
  std::array<float, 16> out;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) out[c * 4 + r] = m(r, c);
  return out;
}

GlRenderer::GlRenderer() {
  const ObjectDef unitSphere = icosphere(Vec3::Zero(), 1, 3);
  for (const auto& t : unitSphere.triangles)
    for (Index v : t) unitSphereCorners_.push_back(unitSphere.vertices[v].normalized());
  const unsigned vs = compile(GL_VERTEX_SHADER, kVertexShader);
  const unsigned fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
  program_ = glCreateProgram();
  glAttachShader(program_, vs);
  glAttachShader(program_, fs);
  glLinkProgram(program_);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program_, GL_LINK_STATUS, &ok);
  if (!ok) throw std::runtime_error("viewer: the shaders do not link");
  viewProjection_ = glGetUniformLocation(program_, "viewProjection");
  eye_ = glGetUniformLocation(program_, "eye");
  pointSize_ = glGetUniformLocation(program_, "pointSize");
  lit_ = glGetUniformLocation(program_, "lit");
  glGenVertexArrays(1, &vao_);
  glGenBuffers(1, &vbo_);
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  for (int a = 0; a < 3; ++a) {
    glEnableVertexAttribArray(a);
    glVertexAttribPointer(a, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                          reinterpret_cast<void*>(std::size_t(a) * 3 * sizeof(float)));
  }
}

GlRenderer::~GlRenderer() {
  glDeleteBuffers(1, &vbo_);
  glDeleteVertexArrays(1, &vao_);
  glDeleteProgram(program_);
}

void GlRenderer::upload(const std::vector<Vertex>& vertices) {
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(vertices.size() * sizeof(Vertex)), vertices.data(),
               GL_STREAM_DRAW);
}

void GlRenderer::draw(const SceneSnapshot& scene, const Camera& camera, int width, int height,
                      const DrawOptions& options) {
  triangles_.clear(), lines_.clear(), points_.clear();
  const auto push = [](std::vector<Vertex>& to, const Vec3& p, const Vec3& n,
                       const std::array<float, 3>& c) {
    to.push_back({float(p.x()), float(p.y()), float(p.z()), float(n.x()), float(n.y()),
                  float(n.z()), c[0], c[1], c[2]});
  };
  std::vector<Vec3> normals;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const ObjectSnapshot& o = scene.objects[i];
    if (o.kind == ObjectKind::Collider && !options.colliders) continue;
    const std::array<float, 3> base = objectColour(o.kind, i);
    const auto colour = [&](Index v) {
      return options.strainColours && o.kind != ObjectKind::Collider
                 ? strainColour(o.strain[v], options.strainScale)
                 : base;
    };
    // Smooth shading: each vertex's normal is the sum of its triangles' area vectors.
    normals.assign(o.x.size(), Vec3::Zero());
    for (const auto& t : o.triangles) {
      const Vec3 n = (o.x[t[1]] - o.x[t[0]]).cross(o.x[t[2]] - o.x[t[0]]);
      for (Index v : t) normals[v] += n;
    }
    for (Vec3& n : normals)
      if (const float length = n.norm(); length > 0) n /= length;
    for (const auto& t : o.triangles)
      for (Index v : t) push(triangles_, o.x[v], normals[v], colour(v));
    for (const auto& e : o.edges)
      for (Index v : e) push(lines_, o.x[v], Vec3::UnitY(), colour(v));
    if (o.triangles.empty() && o.edges.empty())
      for (Index v = 0; v < o.x.size(); ++v) push(points_, o.x[v], Vec3::UnitY(), colour(v));
  }
  if (options.contacts)
    for (const Vec3& p : scene.contactPoints) push(points_, p, Vec3::UnitY(), {0.2f, 0.95f, 0.3f});
  if (options.colliders)
    for (const SphereCollider& sphere : scene.spheres)
      for (const Vec3& u : unitSphereCorners_)
        push(triangles_, sphere.center + sphere.radius * u, u, {0.62f, 0.62f, 0.6f});
  if (options.ground && scene.ground.enabled) {
    // A checkered square around the target, two triangles per cell.
    const float y = float(scene.ground.height), cell = 0.5f;
    const int cells = 24;
    const Vec3 up = Vec3::UnitY();
    const float x0 = std::floor(float(camera.target.x()) / cell) * cell - cells / 2 * cell;
    const float z0 = std::floor(float(camera.target.z()) / cell) * cell - cells / 2 * cell;
    for (int a = 0; a < cells; ++a)
      for (int b = 0; b < cells; ++b) {
        const std::array<float, 3> c = (a + b) % 2 ? std::array<float, 3>{0.78f, 0.78f, 0.76f}
                                                   : std::array<float, 3>{0.68f, 0.68f, 0.66f};
        const Vec3 p(x0 + a * cell, y, z0 + b * cell);
        const Vec3 dx(cell, 0, 0), dz(0, 0, cell);
        for (const Vec3& q :
             {Vec3(p), Vec3(p + dz), Vec3(p + dx), Vec3(p + dx), Vec3(p + dz), Vec3(p + dx + dz)})
          push(triangles_, q, up, c);
      }
  }

  glViewport(0, 0, width, height);
  glClearColor(0.16f, 0.17f, 0.2f, 1);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_PROGRAM_POINT_SIZE);
  glUseProgram(program_);
  const std::array<float, 16> vp =
      camera.viewProjection(double(width) / double(std::max(height, 1)));
  glUniformMatrix4fv(viewProjection_, 1, GL_FALSE, vp.data());
  const Vec3d eye = camera.eye();
  glUniform3f(eye_, float(eye.x()), float(eye.y()), float(eye.z()));
  glUniform1f(pointSize_, 4.f);
  glBindVertexArray(vao_);
  glUniform1i(lit_, 1);
  upload(triangles_);
  glDrawArrays(GL_TRIANGLES, 0, GLsizei(triangles_.size()));
  glUniform1i(lit_, 0);
  upload(lines_);
  glDrawArrays(GL_LINES, 0, GLsizei(lines_.size()));
  upload(points_);
  glDrawArrays(GL_POINTS, 0, GLsizei(points_.size()));
  glBindVertexArray(0);
  glUseProgram(0);
}

}  // namespace nucleon::viewer
