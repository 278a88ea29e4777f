#include "nucleon/render.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include <embree3/rtcore.h>
#include <stb/stb_image_write.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace nucleon {
namespace {

using Vec3f = Eigen::Vector3f;

// Embree takes float vertices whatever the solver's Real is. A non-finite particle is drawn at the
// origin: Embree's BVH builder assumes finite coordinates.
Vec3f toRenderPoint(const Vec3& x) {
  return x.allFinite() ? Vec3f(x.cast<float>()) : Vec3f(Vec3f::Zero());
}

struct DeviceDeleter {
  void operator()(RTCDevice d) const { rtcReleaseDevice(d); }
};
struct SceneDeleter {
  void operator()(RTCScene s) const { rtcReleaseScene(s); }
};
using DeviceHandle = std::unique_ptr<RTCDeviceTy, DeviceDeleter>;
using SceneHandle = std::unique_ptr<RTCSceneTy, SceneDeleter>;

// Albedo per object, cycling through a small palette so neighbouring objects differ.
Vec3f palette(std::size_t i) {
  static const Vec3f colors[] = {{0.80f, 0.25f, 0.20f}, {0.20f, 0.45f, 0.80f},
                                 {0.95f, 0.70f, 0.20f}, {0.30f, 0.70f, 0.35f},
                                 {0.60f, 0.35f, 0.75f}, {0.85f, 0.85f, 0.85f}};
  return colors[i % 6];
}

void addTriangles(RTCDevice device, RTCScene scene, const std::vector<Vec3f>& vertices,
                  const std::vector<std::array<unsigned, 3>>& triangles, unsigned id) {
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices.size()));
  for (std::size_t i = 0; i < vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) v[3 * i + k] = vertices[i][k];
  auto* t = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), triangles.size()));
  for (std::size_t i = 0; i < triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) t[3 * i + k] = triangles[i][k];
  rtcCommitGeometry(g);
  rtcAttachGeometryByID(scene, g, id);
  rtcReleaseGeometry(g);
}

}  // namespace

void renderPng(const World& world, const std::string& path, const RenderSettings& settings) {
  DeviceHandle device(rtcNewDevice("threads=0"));
  if (!device) throw std::runtime_error("render: cannot create an Embree device");
  SceneHandle scene(rtcNewScene(device.get()));

  // Bounds of everything, for framing and for the ground plane.
  Vec3f lo = Vec3f::Constant(1e30f), hi = Vec3f::Constant(-1e30f);
  // Object by object: a tearable cloth's unused spare particles are not drawn.
  for (std::size_t o = 0; o < world.objectCount(); ++o)
    for (const Vec3& x : world.positions(world.objectAt(o)))
      if (x.allFinite()) {
        lo = lo.cwiseMin(x.cast<float>());
        hi = hi.cwiseMax(x.cast<float>());
      }
  if (lo.x() > hi.x()) lo = hi = Vec3f::Zero();
  const float extent = std::max((hi - lo).norm(), 1e-3f);

  std::vector<Vec3f> albedo;  // by geometry id
  // Smooth shading of the triangle meshes, by geometry id (empty for curves, points, ground):
  // each vertex's normal is the sum of its triangles' area vectors, interpolated at a hit with
  // Embree's barycentric coordinates.
  std::vector<std::vector<Vec3f>> vertexNormals;
  std::vector<std::vector<std::array<unsigned, 3>>> meshTriangles;
  for (std::size_t o = 0; o < world.objectCount(); ++o) {
    const ObjectId id = world.objectAt(o);
    const auto x = world.positions(id);
    const unsigned geomId = static_cast<unsigned>(albedo.size());
    const float radius = std::max(static_cast<float>(world.thickness(id)), 0.004f * extent);
    switch (world.kind(id)) {
      case ObjectKind::Cloth:
      case ObjectKind::Solid:
      case ObjectKind::Collider: {
        std::vector<Vec3f> v;
        for (const Vec3& p : x) v.push_back(toRenderPoint(p));
        std::vector<std::array<unsigned, 3>> t(world.surfaceTriangles(id).begin(),
                                               world.surfaceTriangles(id).end());
        if (t.empty()) continue;
        addTriangles(device.get(), scene.get(), v, t, geomId);
        vertexNormals.resize(geomId + 1), meshTriangles.resize(geomId + 1);
        std::vector<Vec3f>& normals = vertexNormals[geomId];
        normals.assign(v.size(), Vec3f::Zero());
        for (const auto& tri : t) {
          const Vec3f n = (v[tri[1]] - v[tri[0]]).cross(v[tri[2]] - v[tri[0]]);
          for (unsigned k : tri) normals[k] += n;
        }
        for (Vec3f& n : normals)
          if (const float length = n.norm(); length > 0) n /= length;
        meshTriangles[geomId] = std::move(t);
        break;
      }
      case ObjectKind::Rope: {
        const auto edges = world.curveEdges(id);
        RTCGeometry g = rtcNewGeometry(device.get(), RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE);
        // Each segment gets its own two control points, so any edge list (not only a chain)
        // renders.
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
            g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 2 * edges.size()));
        auto* s = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
            g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(unsigned), edges.size()));
        for (std::size_t e = 0; e < edges.size(); ++e) {
          for (int end = 0; end < 2; ++end) {
            const Vec3f p = toRenderPoint(x[edges[e][end]]);
            float* dst = v + 4 * (2 * e + end);
            dst[0] = p.x(), dst[1] = p.y(), dst[2] = p.z(), dst[3] = radius;
          }
          s[e] = static_cast<unsigned>(2 * e);
        }
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(scene.get(), g, geomId);
        rtcReleaseGeometry(g);
        break;
      }
      case ObjectKind::Particles: {
        RTCGeometry g = rtcNewGeometry(device.get(), RTC_GEOMETRY_TYPE_SPHERE_POINT);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
            g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), x.size()));
        for (std::size_t i = 0; i < x.size(); ++i) {
          const Vec3f p = toRenderPoint(x[i]);
          v[4 * i] = p.x(), v[4 * i + 1] = p.y(), v[4 * i + 2] = p.z(), v[4 * i + 3] = radius;
        }
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(scene.get(), g, geomId);
        rtcReleaseGeometry(g);
        break;
      }
    }
    albedo.push_back(world.kind(id) == ObjectKind::Collider ? Vec3f(0.7f, 0.7f, 0.72f)
                                                            : palette(o));
  }

  // Ground: a large quad a little below the lowest point.
  const float groundY = lo.y() - 0.01f * extent;
  const Vec3f mid = 0.5f * (lo + hi);
  const float g = 20 * extent;
  const unsigned groundId = static_cast<unsigned>(albedo.size());
  addTriangles(device.get(), scene.get(),
               {{mid.x() - g, groundY, mid.z() - g},
                {mid.x() + g, groundY, mid.z() - g},
                {mid.x() + g, groundY, mid.z() + g},
                {mid.x() - g, groundY, mid.z() + g}},
               {{{0, 2, 1}}, {{0, 3, 2}}}, groundId);
  albedo.push_back({0.8f, 0.8f, 0.8f});
  rtcCommitScene(scene.get());

  // Camera: looks at the bounds' centre from the front-right and above, far enough back that
  // the bounding sphere fits the narrower field of view.
  const int w = std::clamp(settings.width, 16, 8192), h = std::clamp(settings.height, 16, 8192);
  const float fov = static_cast<float>(settings.fieldOfViewDegrees) * 3.14159265f / 180.0f;
  const float aspect = static_cast<float>(w) / static_cast<float>(h);
  const float radius = 0.5f * extent;
  const float halfFov = 0.5f * fov * std::min(1.0f, aspect);
  const Vec3f forward = -Vec3f(0.8f, 0.45f, 1.3f).normalized();
  const Vec3f eye = mid - forward * (1.1f * radius / std::sin(halfFov));
  const Vec3f right = forward.cross(Vec3f::UnitY()).normalized();
  const Vec3f up = right.cross(forward);
  const float tanHalf = std::tan(0.5f * fov);
  const Vec3f light = Vec3f(0.4f, 1.0f, 0.3f).normalized();

  std::vector<unsigned char> image(static_cast<std::size_t>(w) * h * 3);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    RTCIntersectContext context;
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        const float u = (2.0f * (static_cast<float>(x) + 0.5f) / static_cast<float>(w) - 1.0f) *
                        tanHalf * aspect;
        const float v =
            (1.0f - 2.0f * (static_cast<float>(y) + 0.5f) / static_cast<float>(h)) * tanHalf;
        const Vec3f dir = (forward + u * right + v * up).normalized();
        RTCRayHit rh{};
        rh.ray.org_x = eye.x(), rh.ray.org_y = eye.y(), rh.ray.org_z = eye.z();
        rh.ray.dir_x = dir.x(), rh.ray.dir_y = dir.y(), rh.ray.dir_z = dir.z();
        rh.ray.tnear = 0, rh.ray.tfar = 1e30f, rh.ray.mask = 0xffffffffu;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcInitIntersectContext(&context);
        rtcIntersect1(scene.get(), &context, &rh);
        Vec3f color;
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
          color = Vec3f(0.55f, 0.68f, 0.85f) * (0.6f + 0.4f * std::max(dir.y(), 0.0f)) +
                  Vec3f::Constant(0.25f) * (1 - std::max(dir.y(), 0.0f));
        } else {
          Vec3f n = Vec3f(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z).normalized();
          if (n.dot(dir) > 0) n = -n;  // two-sided: cloth is seen from both sides
          Vec3f shading = n;
          if (rh.hit.geomID < vertexNormals.size() && !vertexNormals[rh.hit.geomID].empty()) {
            const auto& tri = meshTriangles[rh.hit.geomID][rh.hit.primID];
            const auto& normals = vertexNormals[rh.hit.geomID];
            const Vec3f smooth = (1 - rh.hit.u - rh.hit.v) * normals[tri[0]] +
                                 rh.hit.u * normals[tri[1]] + rh.hit.v * normals[tri[2]];
            // On the side the ray sees, like the geometric normal.
            if (smooth.squaredNorm() > 0)
              shading = smooth.dot(n) < 0 ? -smooth.normalized() : smooth.normalized();
          }
          const Vec3f hit = eye + rh.ray.tfar * dir;
          Vec3f base = albedo[rh.hit.geomID];
          if (rh.hit.geomID == groundId) {
            const float cell = 0.1f * extent;
            const int checker = (static_cast<int>(std::floor(hit.x() / cell)) +
                                 static_cast<int>(std::floor(hit.z() / cell))) &
                                1;
            base = checker ? Vec3f(0.82f, 0.82f, 0.80f) : Vec3f(0.62f, 0.62f, 0.60f);
          }
          RTCRay shadow{};
          const Vec3f origin = hit + 1e-4f * extent * n;
          shadow.org_x = origin.x(), shadow.org_y = origin.y(), shadow.org_z = origin.z();
          shadow.dir_x = light.x(), shadow.dir_y = light.y(), shadow.dir_z = light.z();
          shadow.tnear = 0, shadow.tfar = 1e30f, shadow.mask = 0xffffffffu;
          rtcInitIntersectContext(&context);
          rtcOccluded1(scene.get(), &context, &shadow);
          const bool lit = shadow.tfar >= 0;  // Embree sets tfar = −inf when occluded
          const float diffuse = lit ? std::max(shading.dot(light), 0.0f) : 0.0f;
          color = base * (0.3f + 0.7f * diffuse);
          const float fog = std::min(1.0f, rh.ray.tfar / (30 * extent));
          color = (1 - fog) * color + fog * Vec3f(0.7f, 0.75f, 0.8f);
        }
        unsigned char* px = &image[(static_cast<std::size_t>(y) * w + x) * 3];
        for (int k = 0; k < 3; ++k)  // gamma 2.2 for display
          px[k] = static_cast<unsigned char>(
              std::clamp(std::pow(color[k], 1.0f / 2.2f) * 255.0f + 0.5f, 0.0f, 255.0f));
      }
  });
  if (!stbi_write_png(path.c_str(), w, h, 3, image.data(), w * 3))
    throw std::runtime_error(path + ": cannot write PNG");
}

}  // namespace nucleon
