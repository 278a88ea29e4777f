#include "nucleon/scene.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "components/simplicial_complex.h"
#include "nucleon/mesh_io.h"
#include "nucleon/shapes.h"

namespace nucleon {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

// Reads typed values out of a JSON object, naming the JSON path of whatever is wrong.
class Reader {
 public:
  Reader(const Json& j, std::string where, const std::string& label)
      : j_(j), where_(std::move(where)), label_(label) {
    if (!j_.is_object()) fail("expected an object");
  }

  // Rejects keys the format does not know, so that a typo is an error and not a silent default.
  void allowOnly(std::initializer_list<const char*> keys) const {
    std::set<std::string> allowed(keys.begin(), keys.end());
    for (const auto& [key, value] : j_.items())
      if (!allowed.count(key)) fail("unknown key '" + key + "'");
  }
  bool has(const char* key) const { return j_.contains(key); }
  Reader child(const char* key) const { return Reader(j_.at(key), at(key), label_); }
  const Json& raw(const char* key) const { return j_.at(key); }

  double number(const char* key, double fallback, double lo, double hi) const {
    if (!has(key)) return fallback;
    return checkNumber(j_.at(key), at(key), lo, hi);
  }
  int integer(const char* key, int fallback, int lo, int hi) const {
    if (!has(key)) return fallback;
    const Json& v = j_.at(key);
    if (!v.is_number_integer()) fail(at(key), "expected an integer");
    const long long x = v.get<long long>();
    if (x < lo || x > hi)
      fail(at(key), "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                        std::to_string(x));
    return static_cast<int>(x);
  }
  // Sweeps per multigrid level: one integer for every level, or a list, level 1 first.
  std::vector<int> levelSweeps(const char* key) const {
    const Json& v = j_.at(key);
    auto check = [&](const Json& x) {
      if (!x.is_number_integer()) fail(at(key), "expected an integer or a list of integers");
      const long long n = x.get<long long>();
      if (n < 0 || n > 1000) fail(at(key), "sweeps must be in [0, 1000], got " + std::to_string(n));
      return static_cast<int>(n);
    };
    if (!v.is_array()) return {check(v)};
    if (v.empty() || v.size() > 64) fail(at(key), "expected 1 to 64 values");
    std::vector<int> out;
    for (const Json& x : v) out.push_back(check(x));
    return out;
  }
  bool boolean(const char* key, bool fallback) const {
    if (!has(key)) return fallback;
    if (!j_.at(key).is_boolean()) fail(at(key), "expected true or false");
    return j_.at(key).get<bool>();
  }
  std::string string(const char* key, const std::string& fallback) const {
    if (!has(key)) return fallback;
    if (!j_.at(key).is_string()) fail(at(key), "expected a string");
    return j_.at(key).get<std::string>();
  }
  Vec3 vec3(const char* key, const Vec3& fallback) const {
    if (!has(key)) return fallback;
    return toVec3(j_.at(key), at(key));
  }
  template <std::size_t N>
  std::array<double, N> numbers(const char* key, std::array<double, N> fallback, double lo,
                                double hi) const {
    if (!has(key)) return fallback;
    const Json& v = j_.at(key);
    if (!v.is_array() || v.size() != N) fail(at(key), "expected " + std::to_string(N) + " numbers");
    std::array<double, N> out;
    for (std::size_t i = 0; i < N; ++i) out[i] = checkNumber(v[i], at(key), lo, hi);
    return out;
  }

  Vec3d vec3d(const char* key, const Vec3d& fallback) const {
    if (!has(key)) return fallback;
    const Json& v = j_.at(key);
    if (!v.is_array() || v.size() != 3) fail(at(key), "expected [x, y, z]");
    Vec3d out;
    for (int k = 0; k < 3; ++k) out[k] = checkNumber(v[k], at(key), -1e9, 1e9);
    return out;
  }
  Vec3 toVec3(const Json& v, const std::string& where) const {
    if (!v.is_array() || v.size() != 3) fail(where, "expected [x, y, z]");
    Vec3 out;
    for (int k = 0; k < 3; ++k) out[k] = static_cast<Real>(checkNumber(v[k], where, -1e9, 1e9));
    return out;
  }
  template <std::size_t N>
  std::vector<std::array<Index, N>> indexTuples(const char* key) const {
    std::vector<std::array<Index, N>> out;
    if (!has(key)) return out;
    const Json& list = j_.at(key);
    if (!list.is_array()) fail(at(key), "expected a list");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string where = at(key) + "[" + std::to_string(i) + "]";
      if (!list[i].is_array() || list[i].size() != N)
        fail(where, "expected " + std::to_string(N) + " vertex indices");
      std::array<Index, N> t;
      for (std::size_t k = 0; k < N; ++k) t[k] = toIndex(list[i][k], where);
      out.push_back(t);
    }
    return out;
  }
  // [{"family": "stretch", "sweeps": 26}, {"family": "bend", "sweeps": 9}, ...]
  Schedule schedule(const char* key) const {
    Schedule out;
    const Json& list = j_.at(key);
    if (!list.is_array()) fail(at(key), "expected a list of {\"family\", \"sweeps\"}");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const Reader entry(list[i], at(key) + "[" + std::to_string(i) + "]", label_);
      entry.allowOnly({"family", "sweeps"});
      ScheduleEntry e;
      const std::string family = entry.string("family", "");
      if (!parseConstraintFamily(family, e.family))
        entry.fail(entry.at("family"),
                   "expected stretch, shear, bend, twist, volume or tether, got '" + family + "'");
      for (const ScheduleEntry& earlier : out)
        if (earlier.family == e.family) entry.fail(entry.at("family"), "'" + family + "' repeats");
      if (!entry.has("sweeps")) entry.fail("missing 'sweeps'");
      e.sweeps = entry.integer("sweeps", 0, 0, 100000);
      out.push_back(e);
    }
    return out;
  }
  Index toIndex(const Json& v, const std::string& where) const {
    if (!v.is_number_integer() || v.get<long long>() < 0 || v.get<long long>() > 0x7fffffff)
      fail(where, "expected a non-negative integer index");
    return static_cast<Index>(v.get<long long>());
  }

  [[noreturn]] void fail(const std::string& message) const { fail(where_, message); }
  [[noreturn]] void fail(const std::string& where, const std::string& message) const {
    throw SceneError(label_ + ": " + (where.empty() ? "" : where + ": ") + message);
  }
  std::string at(const char* key) const { return where_.empty() ? key : where_ + "." + key; }
  const std::string& label() const { return label_; }

 private:
  double checkNumber(const Json& v, const std::string& where, double lo, double hi) const {
    if (!v.is_number()) fail(where, "expected a number");
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(where, "number is not finite");
    if (x < lo || x > hi) {
      std::ostringstream out;
      out << "must be in [" << lo << ", " << hi << "], got " << x;
      fail(where, out.str());
    }
    return x;
  }

  const Json& j_;
  std::string where_;
  const std::string& label_;
};

// A direction given as a vector of any non-zero length.
Vec3d readDirection(const Reader& r, const char* key, const Vec3d& fallback) {
  const Vec3d v = r.vec3d(key, fallback);
  if (!(v.norm() > 1e-12)) r.fail(r.at(key), "must not be zero");
  return v;
}

// The rings of a tube shape, which pin groups can name: ring k is the vertices k·around …
// k·around + around − 1 (TubeSpec in nucleon/shapes.h). count = 0 for other shapes.
struct Rings {
  int around = 0;
  int count = 0;
};

ObjectDef readShape(const Reader& shape, const std::string& folder, Rings& rings) {
  shape.allowOnly({"grid", "polyline", "icosphere", "tube", "box", "tet_box", "obj", "mesh",
                   "points", "block"});
  int given = 0;
  for (const char* k : {"grid", "polyline", "icosphere", "tube", "box", "tet_box", "obj", "mesh",
                        "points", "block"})
    given += shape.has(k);
  if (given != 1)
    shape.fail(
        "give exactly one of grid, polyline, icosphere, tube, box, tet_box, obj, mesh, points, "
        "block");
  try {
    if (shape.has("tube")) {
      const Reader t = shape.child("tube");
      t.allowOnly({"center", "axis", "length", "radius", "radius_bottom", "radius_top",
                   "resolution", "caps"});
      TubeSpec spec;
      spec.center = t.vec3("center", spec.center);
      spec.axis = readDirection(t, "axis", spec.axis.cast<double>()).cast<Real>();
      spec.length = static_cast<Real>(t.number("length", spec.length, 1e-6, 1e6));
      const double radius = t.number("radius", spec.radiusTop, 1e-6, 1e6);
      spec.radiusBottom = static_cast<Real>(t.number("radius_bottom", radius, 1e-6, 1e6));
      spec.radiusTop = static_cast<Real>(t.number("radius_top", radius, 1e-6, 1e6));
      const auto res = t.numbers<2>("resolution", {48, 32}, 2, 100000);
      if (res[0] < 3 || res[0] != std::floor(res[0]) || res[1] != std::floor(res[1]))
        t.fail(t.at("resolution"), "expected whole numbers [around ≥ 3, along ≥ 2]");
      spec.resolution = {static_cast<int>(res[0]), static_cast<int>(res[1])};
      spec.caps = t.boolean("caps", false);
      rings = {spec.resolution[0], spec.resolution[1]};
      return tube(spec);
    }
    if (shape.has("grid")) {
      const Reader g = shape.child("grid");
      g.allowOnly({"resolution", "size", "center", "vertical"});
      GridSpec spec;
      const auto res = g.numbers<2>("resolution", {64, 64}, 2, 8192);
      const auto size = g.numbers<2>("size", {2, 2}, 1e-6, 1e6);
      spec.resolution = {static_cast<int>(res[0]), static_cast<int>(res[1])};
      spec.size = {static_cast<Real>(size[0]), static_cast<Real>(size[1])};
      spec.center = g.vec3("center", spec.center);
      spec.vertical = g.boolean("vertical", false);
      return gridCloth(spec);
    }
    if (shape.has("polyline")) {
      const Reader p = shape.child("polyline");
      p.allowOnly({"from", "to", "segments", "points"});
      if (p.has("points")) {
        const Json& list = p.raw("points");
        if (!list.is_array()) p.fail(p.at("points"), "expected a list of [x, y, z]");
        std::vector<Vec3> points;
        for (const Json& v : list) points.push_back(p.toVec3(v, p.at("points")));
        return polylineRope(points);
      }
      return polylineRope(p.vec3("from", Vec3(0, 2, 0)), p.vec3("to", Vec3(1, 2, 0)),
                          p.integer("segments", 10, 1, 1000000));
    }
    if (shape.has("icosphere")) {
      const Reader s = shape.child("icosphere");
      s.allowOnly({"center", "radius", "subdivisions"});
      return icosphere(s.vec3("center", Vec3::Zero()),
                       static_cast<Real>(s.number("radius", 0.5, 1e-6, 1e6)),
                       s.integer("subdivisions", 3, 0, 7));
    }
    if (shape.has("box")) {
      const Reader b = shape.child("box");
      b.allowOnly({"center", "size", "cells", "turn"});
      ObjectDef def = boxSurface(b.vec3("center", Vec3(0, 1, 0)), b.vec3("size", Vec3(1, 1, 1)),
                                 b.integer("cells", 2, 1, 512));
      // A turn about the vertical axis through the centre, in degrees.
      const double turn = b.number("turn", 0, -360, 360) * std::numbers::pi / 180;
      const Vec3 center = b.vec3("center", Vec3(0, 1, 0));
      const Real c = static_cast<Real>(std::cos(turn)), s = static_cast<Real>(std::sin(turn));
      for (Vec3& v : def.vertices) {
        const Vec3 d = v - center;
        v = center + Vec3(c * d.x() + s * d.z(), d.y(), -s * d.x() + c * d.z());
      }
      return def;
    }
    if (shape.has("tet_box")) {
      const Reader b = shape.child("tet_box");
      b.allowOnly({"center", "size", "cells"});
      const auto cells = b.numbers<3>("cells", {4, 4, 4}, 1, 512);
      return tetBox(
          b.vec3("center", Vec3(0, 1, 0)), b.vec3("size", Vec3(1, 1, 1)),
          {static_cast<int>(cells[0]), static_cast<int>(cells[1]), static_cast<int>(cells[2])});
    }
    if (shape.has("obj")) {
      if (!shape.raw("obj").is_string()) shape.fail(shape.at("obj"), "expected a file name");
      const std::string name = shape.raw("obj").get<std::string>();
      fs::path file = fs::path(folder) / name;
      if (!fs::exists(file)) file = fs::path(assetsFolder()) / "meshes" / name;
      return loadObj(file.string());
    }
    if (shape.has("block")) {
      const Reader b = shape.child("block");
      b.allowOnly({"center", "size", "spacing"});
      return particleBlock(b.vec3("center", Vec3(0, 1, 0)), b.vec3("size", Vec3(1, 1, 1)),
                           static_cast<Real>(b.number("spacing", 0.05, 1e-4, 1e3)));
    }
    if (shape.has("points")) {
      const Json& list = shape.raw("points");
      if (!list.is_array()) shape.fail(shape.at("points"), "expected a list of [x, y, z]");
      ObjectDef def;
      for (const Json& v : list) def.vertices.push_back(shape.toVec3(v, shape.at("points")));
      return def;
    }
    const Reader m = shape.child("mesh");
    m.allowOnly({"vertices", "edges", "triangles", "tets"});
    ObjectDef def;
    if (!m.has("vertices") || !m.raw("vertices").is_array())
      m.fail(m.at("vertices"), "expected a list of [x, y, z]");
    for (const Json& v : m.raw("vertices")) def.vertices.push_back(m.toVec3(v, m.at("vertices")));
    def.edges = m.indexTuples<2>("edges");
    def.triangles = m.indexTuples<3>("triangles");
    def.tets = m.indexTuples<4>("tets");
    return def;
  } catch (const std::invalid_argument& e) {
    shape.fail(e.what());
  } catch (const MeshError& e) {
    shape.fail(e.what());
  }
}

// A collider's thickness and Coulomb coefficients; μ_s defaults to at least μ_k.
void readSurface(const Reader& r, Real& thickness, Real& friction, Real& staticFriction) {
  thickness = static_cast<Real>(r.number("thickness", thickness, 0, 10));
  friction = static_cast<Real>(r.number("friction", friction, 0, 10));
  staticFriction =
      static_cast<Real>(r.number("static_friction", std::max(staticFriction, friction), 0, 10));
}

// "motion": {"pivot", "keyframes": [{"time", "translation", "axis", "degrees"}, ...], "loop",
// "bend": {"axis", "along", "degrees_per_meter", "frequency"}}. The checks the world makes again
// are made here too, so that the error names the JSON path.
ColliderMotion readMotion(const Reader& m) {
  m.allowOnly({"pivot", "keyframes", "loop", "bend"});
  ColliderMotion out;
  out.pivot = m.vec3d("pivot", out.pivot);
  if (m.has("keyframes")) {
    const Json& list = m.raw("keyframes");
    if (!list.is_array() || list.empty()) m.fail(m.at("keyframes"), "expected a list of keyframes");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const Reader k(list[i], m.at("keyframes") + "[" + std::to_string(i) + "]", m.label());
      k.allowOnly({"time", "translation", "axis", "degrees"});
      if (!k.has("time")) k.fail("missing 'time'");
      Keyframe f;
      f.time = k.number("time", 0, -1e9, 1e9);
      f.translation = k.vec3d("translation", f.translation);
      f.axis = readDirection(k, "axis", f.axis);
      f.angle = k.number("degrees", 0, -1e6, 1e6) * std::numbers::pi / 180;
      if (!out.keyframes.empty()) {
        const Keyframe& e = out.keyframes.back();
        if (!(f.time > e.time)) {
          std::ostringstream message;
          message << "must be later than the previous keyframe's time " << e.time << ", got "
                  << f.time;
          k.fail(k.at("time"), message.str());
        }
        const Eigen::Quaterniond a(Eigen::AngleAxisd(e.angle, e.axis.normalized()));
        const Eigen::Quaterniond b(Eigen::AngleAxisd(f.angle, f.axis.normalized()));
        if (!(std::abs(a.dot(b)) > 1e-6))
          k.fail(
              "half a turn from the previous keyframe: the way round is ambiguous; add a "
              "keyframe between");
      }
      out.keyframes.push_back(f);
    }
  }
  out.loop = m.boolean("loop", false);
  if (out.loop && out.keyframes.size() < 2)
    m.fail(m.at("loop"), "a looping motion needs at least two keyframes");
  if (m.has("bend")) {
    const Reader b = m.child("bend");
    b.allowOnly({"axis", "along", "degrees_per_meter", "frequency"});
    BendMotion& bend = out.bend;
    bend.axis = readDirection(b, "axis", bend.axis);
    bend.along = readDirection(b, "along", bend.along);
    if (std::abs(bend.axis.normalized().dot(bend.along.normalized())) >= 1e-6)
      b.fail(b.at("along"), "must be perpendicular to 'axis'");
    if (!b.has("degrees_per_meter")) b.fail("missing 'degrees_per_meter'");
    if (!b.has("frequency")) b.fail("missing 'frequency'");
    bend.curvature = b.number("degrees_per_meter", 0, -1e6, 1e6) * std::numbers::pi / 180;
    bend.frequency = b.number("frequency", 0, 1e-9, 1e6);
  }
  if (!out.animated()) m.fail("give keyframes or a bend with non-zero degrees_per_meter");
  return out;
}

// "pin_groups": [{"vertices": [i, ...] or "ring": k, "motion": {...} or "NAME"}, ...]: pinned
// vertices moved by a motion (PinGroup in nucleon/object_def.h). A ring names a tube's ring,
// counted from the last with a negative k; a motion given by name is a copy of the motion of the
// animated collider of that name listed earlier, so that pins ride on a body exactly. The checks
// the world makes again are made here too, so that the error names the JSON path.
void readPinGroups(const Reader& o, ObjectKind kind, const Rings& rings,
                   const std::vector<SceneObject>& earlier, ObjectDef& def) {
  if (kind == ObjectKind::Collider)
    o.fail(o.at("pin_groups"), "a collider takes no pin groups (its motion moves all of it)");
  const Json& list = o.raw("pin_groups");
  if (!list.is_array() || list.empty())
    o.fail(o.at("pin_groups"),
           "expected a non-empty list of {\"vertices\" or \"ring\", \"motion\"}");
  const std::size_t n = def.vertices.size();
  std::vector<std::string> owner(n);  // per vertex: "" or what holds it already
  for (Index pin : def.pins) owner[pin] = "a pin";
  for (std::size_t g = 0; g < list.size(); ++g) {
    const Reader r(list[g], o.at("pin_groups") + "[" + std::to_string(g) + "]", o.label());
    r.allowOnly({"vertices", "ring", "motion"});
    if (r.has("vertices") == r.has("ring")) r.fail("give exactly one of 'vertices', 'ring'");
    PinGroup group;
    if (r.has("ring")) {
      if (rings.count == 0) r.fail(r.at("ring"), "only a tube shape has rings");
      int k = r.integer("ring", 0, -rings.count, rings.count - 1);
      if (k < 0) k += rings.count;
      for (int j = 0; j < rings.around; ++j)
        group.vertices.push_back(static_cast<Index>(k * rings.around + j));
    } else {
      const Json& vertices = r.raw("vertices");
      if (!vertices.is_array() || vertices.empty())
        r.fail(r.at("vertices"), "expected a non-empty list of vertex indices");
      for (const Json& v : vertices) {
        const Index vertex = r.toIndex(v, r.at("vertices"));
        if (vertex >= n)
          r.fail(r.at("vertices"), "vertex " + std::to_string(vertex) +
                                       " is out of range (the shape has " + std::to_string(n) +
                                       " vertices)");
        group.vertices.push_back(vertex);
      }
    }
    const std::string self = "pin group " + std::to_string(g);
    for (Index v : group.vertices) {
      if (!owner[v].empty())
        r.fail("vertex " + std::to_string(v) + " is already held by " + owner[v]);
      owner[v] = self;
    }
    if (!r.has("motion")) r.fail("missing 'motion' (vertices held still are 'pins')");
    if (r.raw("motion").is_string()) {  // the motion of a collider given earlier
      const std::string name = r.raw("motion").get<std::string>();
      const auto found = std::find_if(earlier.begin(), earlier.end(), [&](const SceneObject& e) {
        return e.kind == ObjectKind::Collider && !name.empty() && e.def.name == name &&
               e.def.motion.animated();
      });
      if (found == earlier.end())
        r.fail(r.at("motion"), "no animated collider named '" + name + "' before this object");
      group.motion = found->def.motion;
    } else {
      group.motion = readMotion(r.child("motion"));
    }
    def.pinGroups.push_back(std::move(group));
  }
}

// `earlier`: the objects listed before this one, whose motions pin groups may name.
SceneObject readObject(const Reader& o, const std::string& folder,
                       const std::vector<SceneObject>& earlier) {
  o.allowOnly({"type", "name", "shape", "material", "pins", "pin_groups", "velocity", "offset",
               "schedule", "motion"});
  SceneObject out;
  const std::string type = o.string("type", "");
  if (type == "cloth")
    out.kind = ObjectKind::Cloth;
  else if (type == "rope")
    out.kind = ObjectKind::Rope;
  else if (type == "solid")
    out.kind = ObjectKind::Solid;
  else if (type == "particles")
    out.kind = ObjectKind::Particles;
  else if (type == "collider")
    out.kind = ObjectKind::Collider;
  else
    o.fail(o.at("type"), "expected cloth, rope, solid, particles or collider, got '" + type + "'");
  if (!o.has("shape")) o.fail("missing 'shape'");
  Rings rings;
  out.def = readShape(o.child("shape"), folder, rings);
  out.def.name = o.string("name", "");
  const Vec3 offset = o.vec3("offset", Vec3::Zero());
  for (Vec3& v : out.def.vertices) v += offset;
  out.def.velocity = o.vec3("velocity", Vec3::Zero());
  if (o.has("motion")) {
    if (out.kind != ObjectKind::Collider)
      o.fail(o.at("motion"), "only colliders can have a motion");
    if (o.has("velocity"))
      o.fail(o.at("velocity"), "a collider with a motion takes no velocity (the motion sets it)");
    out.def.motion = readMotion(o.child("motion"));
  }
  if (o.has("material")) {
    const Reader m = o.child("material");
    m.allowOnly({"mass",
                 "stretch_compliance",
                 "compression_compliance",
                 "bend_compliance",
                 "bend_model",
                 "shear_compliance",
                 "twist_compliance",
                 "volume_compliance",
                 "damping",
                 "thickness",
                 "tethers",
                 "stretch_limit",
                 "collide",
                 "self_collision",
                 "friction",
                 "static_friction",
                 "restitution",
                 "stickiness",
                 "pressure",
                 "rigidity",
                 "liquid",
                 "tear"});
    Material& mat = out.def.material;
    mat.mass = static_cast<Real>(m.number("mass", mat.mass, 1e-9, 1e9));
    mat.stretchCompliance =
        static_cast<Real>(m.number("stretch_compliance", mat.stretchCompliance, 0, 1e6));
    mat.compressionCompliance =
        static_cast<Real>(m.number("compression_compliance", mat.compressionCompliance, 0, 1e6));
    mat.thickness = static_cast<Real>(m.number("thickness", mat.thickness, 0, 1e3));
    mat.bending = m.has("bend_compliance");
    mat.bendCompliance = static_cast<Real>(m.number("bend_compliance", 0, 0, 1e6));
    const std::string bendModel = m.string("bend_model", "dihedral");
    if (bendModel == "dihedral")
      mat.bendModel = BendModel::Dihedral;
    else if (bendModel == "isometric")
      mat.bendModel = BendModel::Isometric;
    else
      m.fail(m.at("bend_model"), "expected dihedral or isometric, got '" + bendModel + "'");
    mat.shear = m.has("shear_compliance");
    mat.shearCompliance = static_cast<Real>(m.number("shear_compliance", 0, 0, 1e6));
    mat.twist = m.has("twist_compliance");
    mat.twistCompliance = static_cast<Real>(m.number("twist_compliance", 0, 0, 1e6));
    mat.volumeCompliance =
        static_cast<Real>(m.number("volume_compliance", mat.volumeCompliance, 0, 1e6));
    mat.damping = static_cast<Real>(m.number("damping", mat.damping, 0, 1e3));
    mat.tethers = m.boolean("tethers", mat.tethers);
    if (m.has("stretch_limit"))
      mat.stretchLimit = static_cast<Real>(m.number("stretch_limit", 0, 0, 1000));
    mat.selfCollision = m.boolean("self_collision", mat.selfCollision);
    mat.friction = static_cast<Real>(m.number("friction", mat.friction, 0, 1e3));
    // μ_s defaults to at least μ_k, as for colliders.
    mat.staticFriction = static_cast<Real>(
        m.number("static_friction", std::max(mat.staticFriction, mat.friction), 0, 1e3));
    mat.restitution = static_cast<Real>(m.number("restitution", mat.restitution, 0, 1));
    mat.stickiness = static_cast<Real>(m.number("stickiness", mat.stickiness, 0, 1e3));
    mat.rigidity = static_cast<Real>(m.number("rigidity", mat.rigidity, 0, 1));
    if (mat.rigidity > 0 && out.kind == ObjectKind::Collider)
      m.fail(m.at("rigidity"), "a collider is moved by its motion, not by rigidity");
    if (m.has("pressure")) {
      if (out.kind != ObjectKind::Cloth)
        m.fail(m.at("pressure"), "only a cloth (a closed surface) can have pressure");
      const Reader p = m.child("pressure");
      p.allowOnly({"mode", "ambient", "start_pressure", "pump_rate", "pump_stop", "leak_rate",
                   "leak_start", "volume_scale", "compliance"});
      Pressure& pressure = mat.pressure;
      const std::string mode = p.string("mode", "gas");
      if (mode == "gas")
        pressure.mode = PressureMode::Gas;
      else if (mode == "keep_volume")
        pressure.mode = PressureMode::KeepVolume;
      else
        p.fail(p.at("mode"), "expected gas or keep_volume, got '" + mode + "'");
      pressure.ambient = static_cast<Real>(p.number("ambient", pressure.ambient, 1, 1e9));
      pressure.startPressure =
          static_cast<Real>(p.number("start_pressure", 0, -0.99 * double(pressure.ambient), 1e9));
      pressure.pumpRate = static_cast<Real>(p.number("pump_rate", 0, 0, 1e6));
      pressure.pumpStop = p.number("pump_stop", pressure.pumpStop, 0, 1e30);
      pressure.leakRate = static_cast<Real>(p.number("leak_rate", 0, 0, 1e6));
      pressure.leakStart = p.number("leak_start", 0, 0, 1e30);
      pressure.volumeScale = static_cast<Real>(p.number("volume_scale", 1, 1e-3, 1e3));
      pressure.compliance = static_cast<Real>(p.number("compliance", 0, 0, 1e6));
      if (pressure.mode == PressureMode::KeepVolume)
        for (const char* key :
             {"start_pressure", "pump_rate", "pump_stop", "leak_rate", "leak_start"})
          if (p.has(key)) p.fail(p.at(key), "a gas setting; mode keep_volume holds the volume");
      if (pressure.mode == PressureMode::Gas)
        for (const char* key : {"volume_scale", "compliance"})
          if (p.has(key)) p.fail(p.at(key), "a keep_volume setting; mode gas follows P·V = c·M");
    }
    if (m.has("liquid")) {
      if (out.kind != ObjectKind::Particles)
        m.fail(m.at("liquid"), "only a particle cloud can be a liquid");
      const Reader q = m.child("liquid");
      q.allowOnly({"rest_density", "kernel_scale", "relaxation", "tensile_strength",
                   "tensile_distance", "tensile_exponent", "viscosity", "vorticity",
                   "surface_tension", "adhesion"});
      Liquid& liquid = mat.liquid;
      liquid.enabled = true;
      liquid.restDensity =
          static_cast<Real>(q.number("rest_density", liquid.restDensity, 1e-3, 1e6));
      liquid.kernelScale = static_cast<Real>(q.number("kernel_scale", liquid.kernelScale, 1.5, 3));
      liquid.relaxation = static_cast<Real>(q.number("relaxation", liquid.relaxation, 1e-6, 10));
      liquid.tensileStrength =
          static_cast<Real>(q.number("tensile_strength", liquid.tensileStrength, 0, 1));
      liquid.tensileDistance =
          static_cast<Real>(q.number("tensile_distance", liquid.tensileDistance, 0.01, 0.9));
      liquid.tensileExponent = q.integer("tensile_exponent", liquid.tensileExponent, 1, 8);
      liquid.viscosity = static_cast<Real>(q.number("viscosity", liquid.viscosity, 0, 1));
      liquid.vorticity = static_cast<Real>(q.number("vorticity", liquid.vorticity, 0, 100));
      liquid.surfaceTension =
          static_cast<Real>(q.number("surface_tension", liquid.surfaceTension, 0, 1));
      liquid.adhesion = static_cast<Real>(q.number("adhesion", liquid.adhesion, 0, 1e3));
    }
    if (m.has("tear")) {
      if (out.kind != ObjectKind::Cloth) m.fail(m.at("tear"), "only a cloth can tear");
      if (m.has("pressure"))
        m.fail(m.at("tear"), "a tearable cloth can have no pressure (a torn surface holds no gas)");
      if (mat.rigidity > 0) m.fail(m.at("tear"), "a tearable cloth can have no rigidity");
      const Reader t = m.child("tear");
      t.allowOnly({"strain", "time", "max_new_vertices"});
      if (!t.has("strain")) t.fail("missing 'strain'");
      Tear& tear = mat.tear;
      tear.strain = static_cast<Real>(t.number("strain", 0, 1e-6, 1e3));
      tear.time = static_cast<Real>(t.number("time", 0, 0, 1e3));
      tear.maxNewVertices = t.integer("max_new_vertices", -1, 0, 10000000);
    }
    if (m.has("collide")) {
      // Which primitives collide: a list of "vertices", "edges", "faces" (empty: none).
      const Json& list = m.raw("collide");
      if (!list.is_array()) m.fail(m.at("collide"), "expected a list of vertices, edges, faces");
      mat.collideVertices = mat.collideEdges = mat.collideFaces = false;
      for (const Json& item : list) {
        const std::string name = item.is_string() ? item.get<std::string>() : "";
        if (name == "vertices")
          mat.collideVertices = true;
        else if (name == "edges")
          mat.collideEdges = true;
        else if (name == "faces")
          mat.collideFaces = true;
        else
          m.fail(m.at("collide"), "expected vertices, edges or faces, got " + item.dump());
      }
    }
  }
  if (o.has("schedule")) out.def.schedule = o.schedule("schedule");
  if (o.has("pins")) {
    const Json& pins = o.raw("pins");
    if (!pins.is_array()) o.fail(o.at("pins"), "expected a list of vertex indices");
    for (std::size_t i = 0; i < pins.size(); ++i) {
      const Index pin = o.toIndex(pins[i], o.at("pins"));
      if (pin >= out.def.vertices.size())
        o.fail(o.at("pins"), "vertex " + std::to_string(pin) + " is out of range (the shape has " +
                                 std::to_string(out.def.vertices.size()) + " vertices)");
      out.def.pins.push_back(pin);
    }
  }
  if (o.has("pin_groups")) readPinGroups(o, out.kind, rings, earlier, out.def);
  return out;
}

// An object of the scene by name: its index in `objects`.
std::size_t objectNamed(const Reader& r, const char* key, const std::vector<SceneObject>& objects) {
  const std::string name = r.string(key, "");
  if (!r.has(key)) r.fail("needs '" + std::string(key) + "', the name of an object");
  for (std::size_t i = 0; i < objects.size(); ++i)
    if (objects[i].def.name == name) return i;
  r.fail(r.at(key), "no object is named '" + name + "'");
}

Index vertexOf(const Reader& r, const Json& v, const std::string& where,
               const SceneObject& object) {
  const Index vertex = r.toIndex(v, where);
  if (vertex >= object.def.vertices.size())
    r.fail(where, "vertex " + std::to_string(vertex) + " is out of range ('" + object.def.name +
                      "' has " + std::to_string(object.def.vertices.size()) + ")");
  return vertex;
}

SceneAttachment readAttachment(const Reader& r, const std::vector<SceneObject>& objects) {
  r.allowOnly({"kind", "object", "vertex", "vertices", "target", "target_vertex", "triangle",
               "weights", "motion", "distance", "compliance", "strength", "within"});
  SceneAttachment out;
  Attachment& a = out.attachment;
  const std::string kind = r.string("kind", "");
  out.object = objectNamed(r, "object", objects);
  const SceneObject& object = objects[out.object];
  a.distance = static_cast<Real>(r.number("distance", 0, kind == "slide" ? -1e6 : 0, 1e6));
  a.compliance = static_cast<Real>(r.number("compliance", 0, 0, 1e6));
  a.strength = static_cast<Real>(r.number("strength", 0, 0, 1e12));
  auto needTarget = [&] {
    out.target = objectNamed(r, "target", objects);
    return &objects[out.target];
  };
  auto oneVertex = [&] {
    if (!r.has("vertex")) r.fail("needs 'vertex', a vertex index of the object");
    a.vertex = vertexOf(r, r.raw("vertex"), r.at("vertex"), object);
  };
  // "vertex": one; or "vertices": a list, or "all", each attached alike.
  auto vertexOrList = [&] {
    if (!r.has("vertices")) return oneVertex();
    if (r.has("vertex")) r.fail(r.at("vertices"), "give either vertex or vertices");
    const Json& v = r.raw("vertices");
    if (v.is_string() && v.get<std::string>() == "all") {
      for (Index i = 0; i < object.def.vertices.size(); ++i) out.vertices.push_back(i);
      return;
    }
    if (!v.is_array() || v.empty())
      r.fail(r.at("vertices"), "expected a list of vertex indices or \"all\"");
    for (const Json& x : v) out.vertices.push_back(vertexOf(r, x, r.at("vertices"), object));
  };
  if (kind == "weld") {
    needTarget();
    out.weld = true;
    if (!r.has("within")) r.fail("needs 'within', the largest distance (m) of a welded pair");
    out.within = static_cast<Real>(r.number("within", 0, 0, 1e3));
  } else if (kind == "point") {
    a.kind = AttachmentKind::PointToPoint;
    oneVertex();
    const SceneObject* target = needTarget();
    if (!r.has("target_vertex")) r.fail("needs 'target_vertex'");
    a.targetVertex = vertexOf(r, r.raw("target_vertex"), r.at("target_vertex"), *target);
  } else if (kind == "surface" || kind == "slide") {
    a.kind = kind == "surface" ? AttachmentKind::PointToSurface : AttachmentKind::SlideOnSurface;
    vertexOrList();
    const SceneObject* target = needTarget();
    if (!r.has("triangle") || !r.raw("triangle").is_array() || r.raw("triangle").size() != 3)
      r.fail(r.at("triangle"), "expected three vertex indices of the target");
    for (int k = 0; k < 3; ++k)
      a.triangle[k] = vertexOf(r, r.raw("triangle")[k], r.at("triangle"), *target);
    const auto w = r.numbers<3>("weights", {1.0 / 3, 1.0 / 3, 1.0 / 3}, -1e3, 1e3);
    if (std::abs(w[0] + w[1] + w[2] - 1) > 1e-4) r.fail(r.at("weights"), "must sum to 1");
    a.weights = Vec3(static_cast<Real>(w[0]), static_cast<Real>(w[1]), static_cast<Real>(w[2]));
  } else if (kind == "transform") {
    a.kind = AttachmentKind::PointToTransform;
    vertexOrList();
    if (!r.has("motion")) r.fail("needs 'motion', the handle's keyframes");
    a.motion = readMotion(r.child("motion"));
  } else {
    r.fail(r.at("kind"), "expected point, surface, slide, transform or weld, got '" + kind + "'");
  }
  return out;
}

}  // namespace

std::string assetsFolder() {
  if (const char* env = std::getenv("NUCLEON_ASSETS"); env && *env) return env;
#ifdef NUCLEON_SOURCE_ASSETS
  if (fs::is_directory(NUCLEON_SOURCE_ASSETS)) return NUCLEON_SOURCE_ASSETS;
#endif
#ifdef NUCLEON_INSTALL_ASSETS
  return NUCLEON_INSTALL_ASSETS;
#else
  return "assets";
#endif
}

Scene parseScene(const std::string& text, const std::string& label, const std::string& folder) {
  Json j;
  try {
    j = Json::parse(text);
  } catch (const Json::exception& e) {  // syntax errors, and numbers out of double's range
    std::string what = e.what();
    // nlohmann prefixes "[json.exception.parse_error.101] parse error at line L, column C: ..."
    if (auto pos = what.find("] "); pos != std::string::npos) what = what.substr(pos + 2);
    throw SceneError(label + ": malformed JSON: " + what);
  }
  const Reader top(j, "", label);
  top.allowOnly({"name", "description", "frames", "fps", "threads", "gravity", "ground", "planes",
                 "spheres", "solver", "objects", "attachments", "exclude_collisions"});
  Scene scene;
  scene.path = label;
  scene.name = top.string("name", fs::path(label).stem().string());
  scene.description = top.string("description", "");
  scene.frames = top.integer("frames", scene.frames, 1, 1000000);
  scene.fps = top.number("fps", scene.fps, 1, 100000);
  scene.threads = top.integer("threads", 0, 0, 4096);
  scene.gravity = top.vec3("gravity", scene.gravity);
  if (top.has("ground")) {
    const Reader g = top.child("ground");
    g.allowOnly({"height", "thickness", "friction", "static_friction"});
    scene.ground.enabled = true;
    scene.ground.height = static_cast<Real>(g.number("height", 0, -1e6, 1e6));
    readSurface(g, scene.ground.thickness, scene.ground.friction, scene.ground.staticFriction);
  }
  if (top.has("spheres")) {
    if (!j.at("spheres").is_array()) top.fail("spheres", "expected a list of spheres");
    for (std::size_t i = 0; i < j.at("spheres").size(); ++i) {
      const Reader r(j.at("spheres")[i], "spheres[" + std::to_string(i) + "]", label);
      r.allowOnly({"center", "radius", "thickness", "friction", "static_friction"});
      SphereCollider sphere;
      sphere.center = r.vec3("center", sphere.center);
      sphere.radius = static_cast<Real>(r.number("radius", sphere.radius, 1e-6, 1e6));
      readSurface(r, sphere.thickness, sphere.friction, sphere.staticFriction);
      scene.spheres.push_back(sphere);
    }
  }
  if (top.has("planes")) {
    if (!j.at("planes").is_array()) top.fail("planes", "expected a list of planes");
    for (std::size_t i = 0; i < j.at("planes").size(); ++i) {
      const Reader r(j.at("planes")[i], "planes[" + std::to_string(i) + "]", label);
      r.allowOnly({"point", "normal", "thickness", "friction", "static_friction"});
      PlaneCollider plane;
      plane.point = r.vec3("point", plane.point);
      plane.normal = r.vec3("normal", plane.normal);
      if (!(plane.normal.norm() > Real(1e-6))) r.fail(r.at("normal"), "normal must not be zero");
      readSurface(r, plane.thickness, plane.friction, plane.staticFriction);
      scene.planes.push_back(plane);
    }
  }
  if (top.has("solver")) {
    const Reader s = top.child("solver");
    s.allowOnly({"type", "iterations", "substeps", "relaxation", "sheet_relaxation",
                 "chebyshev_rho", "sweeps_per_level", "cascade_every", "cascade_relaxation",
                 "smoother", "schedule", "max_kinematic_travel", "max_impact_travel",
                 "max_substeps", "supported_inverse_mass_scale"});
    const std::string type = s.string("type", toString(scene.solver.kind));
    if (!parseSolverKind(type, scene.solver.kind))
      s.fail(s.at("type"), "unknown solver '" + type + "'");
    scene.solver.iterations = s.integer("iterations", scene.solver.iterations, 0, 100000);
    scene.solver.substeps = s.integer("substeps", scene.solver.substeps, 1, 10000);
    // Negative is the default (derived from the thicknesses), so a file gives 0 (off) or more.
    if (s.has("max_kinematic_travel"))
      scene.solver.maxKinematicTravel =
          static_cast<Real>(s.number("max_kinematic_travel", 0, 0, 1000));
    if (s.has("max_impact_travel"))
      scene.solver.maxImpactTravel = static_cast<Real>(s.number("max_impact_travel", 0, 0, 1000));
    scene.solver.maxSubsteps = s.integer("max_substeps", scene.solver.maxSubsteps, 0, 10000);
    scene.solver.relaxation =
        static_cast<Real>(s.number("relaxation", scene.solver.relaxation, 0.01, 1.99));
    scene.solver.sheetRelaxation =
        static_cast<Real>(s.number("sheet_relaxation", scene.solver.sheetRelaxation, 0.01, 1.99));
    scene.solver.chebyshevRho =
        static_cast<Real>(s.number("chebyshev_rho", scene.solver.chebyshevRho, 0, 0.9999));
    scene.solver.supportedInverseMassScale = static_cast<Real>(
        s.number("supported_inverse_mass_scale", scene.solver.supportedInverseMassScale, 0.001, 1));
    if (s.has("sweeps_per_level")) scene.solver.sweepsPerLevel = s.levelSweeps("sweeps_per_level");
    scene.solver.cascadeEvery = s.integer("cascade_every", scene.solver.cascadeEvery, 0, 100000);
    scene.solver.cascadeRelaxation =
        static_cast<Real>(s.number("cascade_relaxation", scene.solver.cascadeRelaxation, 1, 1.99));
    if (s.has("smoother")) {
      const std::string smoother = s.string("smoother", "");
      if (!parseSolverKind(smoother, scene.solver.smoother) ||
          scene.solver.smoother == SolverKind::Multigrid)
        s.fail(s.at("smoother"),
               "unknown smoother '" + smoother + "' (gauss-seidel, jacobi or colored-gs)");
    }
    if (s.has("schedule")) {
      if (s.has("iterations"))
        s.fail("give either 'iterations' (every family) or 'schedule' (per family), not both");
      scene.solver.schedule = s.schedule("schedule");
      scene.solver.iterations = 0;
      for (const ScheduleEntry& e : scene.solver.schedule)
        scene.solver.iterations = std::max(scene.solver.iterations, e.sweeps);
    }
  }
  if (!top.has("objects") || !j.at("objects").is_array() || j.at("objects").empty())
    top.fail("objects", "expected a non-empty list of objects");
  for (std::size_t i = 0; i < j.at("objects").size(); ++i)
    scene.objects.push_back(
        readObject(Reader(j.at("objects")[i], "objects[" + std::to_string(i) + "]", label), folder,
                   scene.objects));
  if (top.has("attachments")) {
    const Json& list = j.at("attachments");
    if (!list.is_array()) top.fail("attachments", "expected a list of attachments");
    for (std::size_t i = 0; i < list.size(); ++i)
      scene.attachments.push_back(readAttachment(
          Reader(list[i], "attachments[" + std::to_string(i) + "]", label), scene.objects));
  }
  if (top.has("exclude_collisions")) {
    // [["a", "b"], …]: pairs of object names.
    const Json& list = j.at("exclude_collisions");
    if (!list.is_array())
      top.fail("exclude_collisions", "expected a list of pairs of object names");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string where = "exclude_collisions[" + std::to_string(i) + "]";
      if (list[i].is_object()) {
        // {"object": "a", "vertices": […], "target": "b", "target_vertices": […]}
        const Reader r(list[i], where, label);
        r.allowOnly({"object", "vertices", "target", "target_vertices"});
        Scene::VertexSets sets;
        sets.object = objectNamed(r, "object", scene.objects);
        sets.target = objectNamed(r, "target", scene.objects);
        for (const char* key : {"vertices", "target_vertices"}) {
          const SceneObject& owner = scene.objects[key[0] == 'v' ? sets.object : sets.target];
          if (!r.has(key) || !r.raw(key).is_array() || r.raw(key).empty())
            r.fail(r.at(key), "expected a non-empty list of vertex indices");
          for (const Json& v : r.raw(key))
            (key[0] == 'v' ? sets.vertices : sets.targetVertices)
                .push_back(vertexOf(r, v, r.at(key), owner));
        }
        scene.excludedVertexSets.push_back(std::move(sets));
        continue;
      }
      if (!list[i].is_array() || list[i].size() != 2 || !list[i][0].is_string() ||
          !list[i][1].is_string())
        top.fail(where, "expected two object names");
      std::array<std::size_t, 2> pair{};
      for (int k = 0; k < 2; ++k) {
        const std::string name = list[i][k].get<std::string>();
        auto found = std::find_if(scene.objects.begin(), scene.objects.end(),
                                  [&](const SceneObject& o) { return o.def.name == name; });
        if (found == scene.objects.end()) top.fail(where, "no object is named '" + name + "'");
        pair[k] = static_cast<std::size_t>(found - scene.objects.begin());
      }
      scene.excludedCollisions.push_back(pair);
    }
  }
  return scene;
}

std::string readSceneFile(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw SceneError(path + ": no such scene file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot be read");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

Scene loadScene(const std::string& path) {
  return parseScene(readSceneFile(path), path, fs::path(path).parent_path().string());
}

World buildWorld(const Scene& scene) {
  World world;
  try {
    world.setGravity(scene.gravity);
    world.setGround(scene.ground);
    for (const PlaneCollider& plane : scene.planes) world.addPlaneCollider(plane);
    for (const SphereCollider& sphere : scene.spheres) world.addSphereCollider(sphere);
    world.setSolver(scene.solver);
    world.setThreads(scene.threads);
    for (const SceneObject& o : scene.objects) {
      switch (o.kind) {
        case ObjectKind::Cloth:
          world.addCloth(o.def);
          break;
        case ObjectKind::Rope:
          world.addRope(o.def);
          break;
        case ObjectKind::Solid:
          world.addSolid(o.def);
          break;
        case ObjectKind::Particles:
          world.addParticles(o.def);
          break;
        case ObjectKind::Collider:
          world.addCollider(o.def);
          break;
      }
    }
    for (const auto& [a, b] : scene.excludedCollisions)
      world.excludeCollisions(world.objectAt(a), world.objectAt(b));
    for (const Scene::VertexSets& sets : scene.excludedVertexSets)
      world.excludeCollisions(world.objectAt(sets.object), sets.vertices,
                              world.objectAt(sets.target), sets.targetVertices);
    for (const SceneAttachment& entry : scene.attachments) {
      Attachment a = entry.attachment;
      a.object = world.objectAt(entry.object);
      a.target = world.objectAt(entry.target);
      if (entry.weld)
        world.weld(a.object, a.target, entry.within, a.compliance, a.strength, a.distance);
      else if (entry.vertices.empty())
        world.addAttachment(a);
      else
        for (Index v : entry.vertices) {
          a.vertex = v;
          world.addAttachment(a);
        }
    }
  } catch (const std::exception& e) {
    throw SceneError(scene.path + ": " + e.what());
  }
  return world;
}

}  // namespace nucleon
