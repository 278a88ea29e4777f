#include "nucleon/world.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>

#include <tbb/info.h>

#include "engine/src/step_graph.h"
#include "engine/src/world_state.h"
#include "systems/collision/particle_contacts.h"
#include "systems/diagnostics/measures.h"
#include "systems/diagnostics/triangle_intersections.h"
#include "systems/dynamics/impact_travel.h"
#include "systems/dynamics/kinematic_motion.h"
#include "systems/liquid/density_constraints.h"
#include "systems/setup/build_collision_primitives.h"
#include "systems/setup/build_constraints.h"
#include "systems/setup/build_derived_tables.h"
#include "systems/setup/build_hierarchy.h"
#include "systems/setup/sweep_schedule.h"
#include "systems/solver/attachments.h"
#include "systems/solver/pressure.h"
#include "systems/solver/shape_matching.h"
#include "systems/topology/remove_object.h"
#include "systems/topology/tear_cloth.h"

namespace nucleon {

World::Impl::~Impl() = default;

namespace {

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

bool finite(const Vec3& v) {
  return v.allFinite();
}

void validateCommon(const ObjectDef& def, const std::string& what, std::size_t familyCount) {
  require(!def.vertices.empty(), what + ": no vertices");
  for (std::size_t i = 0; i < def.vertices.size(); ++i)
    require(finite(def.vertices[i]),
            what + ": vertex " + std::to_string(i) + " has a non-finite coordinate");
  const Material& m = def.material;
  require(std::isfinite(m.mass) && m.mass > 0, what + ": mass must be positive and finite");
  require(std::isfinite(m.stretchCompliance) && m.stretchCompliance >= 0,
          what + ": stretch compliance must be finite and non-negative");
  require(std::isfinite(m.compressionCompliance) && m.compressionCompliance >= 0,
          what + ": compression compliance must be finite and non-negative");
  require(std::isfinite(m.bendCompliance) && m.bendCompliance >= 0,
          what + ": bend compliance must be finite and non-negative");
  require(std::isfinite(m.volumeCompliance) && m.volumeCompliance >= 0,
          what + ": volume compliance must be finite and non-negative");
  require(std::isfinite(m.shearCompliance) && m.shearCompliance >= 0,
          what + ": shear compliance must be finite and non-negative");
  require(std::isfinite(m.twistCompliance) && m.twistCompliance >= 0,
          what + ": twist compliance must be finite and non-negative");
  require(std::isfinite(m.stretchLimit) && m.stretchLimit <= 1000,
          what + ": stretch limit must be finite and at most 1000 (negative: the default)");
  require(std::isfinite(m.damping) && m.damping >= 0,
          what + ": damping must be finite and non-negative");
  validateSchedule(def.schedule, what + " schedule", familyCount);
  require(std::isfinite(m.thickness) && m.thickness >= 0 && m.thickness < 1e3,
          what + ": thickness must be finite and non-negative");
  require(std::isfinite(m.friction) && m.friction >= 0 && std::isfinite(m.staticFriction) &&
              m.staticFriction >= 0,
          what + ": friction must be finite and non-negative");
  require(std::isfinite(m.restitution) && m.restitution >= 0 && m.restitution <= 1,
          what + ": restitution must be in [0, 1]");
  require(std::isfinite(m.stickiness) && m.stickiness >= 0 && m.stickiness < 1e3,
          what + ": stickiness must be finite and non-negative");
  require(finite(def.velocity), what + ": velocity must be finite");
  require(std::isfinite(m.rigidity) && m.rigidity >= 0 && m.rigidity <= 1,
          what + ": rigidity must be in [0, 1]");
  require(m.rigidity == 0 || (def.pins.empty() && def.pinGroups.empty()),
          what + ": an object with rigidity can have no pins (a pinned rigid body is a collider)");
  const Pressure& pressure = m.pressure;
  if (pressure.mode != PressureMode::Off) {
    require(std::isfinite(pressure.ambient) && pressure.ambient > 0 && pressure.ambient <= 1e9,
            what + ": pressure ambient must be in (0, 1e9] Pa");
    require(std::isfinite(pressure.startPressure) && pressure.startPressure > -pressure.ambient &&
                pressure.startPressure <= 1e9,
            what + ": pressure start_pressure must be above −ambient and at most 1e9 Pa");
    require(std::isfinite(pressure.pumpRate) && pressure.pumpRate >= 0 && pressure.pumpRate <= 1e6,
            what + ": pressure pump_rate must be in [0, 1e6] m³/s");
    require(std::isfinite(pressure.leakRate) && pressure.leakRate >= 0 && pressure.leakRate <= 1e6,
            what + ": pressure leak_rate must be in [0, 1e6] 1/s");
    require(!std::isnan(pressure.pumpStop) && !std::isnan(pressure.leakStart),
            what + ": pressure pump_stop and leak_start must be numbers");
    require(std::isfinite(pressure.volumeScale) && pressure.volumeScale > 0 &&
                pressure.volumeScale <= 1e3,
            what + ": pressure volume_scale must be in (0, 1e3]");
    require(std::isfinite(pressure.compliance) && pressure.compliance >= 0,
            what + ": pressure compliance must be finite and non-negative");
  }
  const Liquid& liquid = m.liquid;
  if (liquid.enabled) {
    auto within = [](Real v, double lo, double hi) {
      return std::isfinite(v) && v >= lo && v <= hi;
    };
    require(within(liquid.restDensity, 1e-3, 1e6),
            what + ": liquid rest_density must be in [1e-3, 1e6] kg/m³");
    require(within(liquid.kernelScale, 1.5, 3), what + ": liquid kernel_scale must be in [1.5, 3]");
    require(within(liquid.relaxation, 1e-6, 10),
            what + ": liquid relaxation must be in [1e-6, 10]");
    require(within(liquid.tensileStrength, 0, 1),
            what + ": liquid tensile_strength must be in [0, 1]");
    require(within(liquid.tensileDistance, 0.01, 0.9),
            what + ": liquid tensile_distance must be in [0.01, 0.9]");
    require(liquid.tensileExponent >= 1 && liquid.tensileExponent <= 8,
            what + ": liquid tensile_exponent must be a whole number in [1, 8]");
    require(within(liquid.viscosity, 0, 1), what + ": liquid viscosity must be in [0, 1]");
    require(within(liquid.vorticity, 0, 100), what + ": liquid vorticity must be in [0, 100] m/s");
    require(within(liquid.surfaceTension, 0, 1),
            what + ": liquid surface_tension must be in [0, 1]");
    require(within(liquid.adhesion, 0, 1e3), what + ": liquid adhesion must be in [0, 1e3] m");
    require(m.rigidity == 0, what + ": a liquid cannot have rigidity");
  }
  for (Index pin : def.pins)
    require(pin < def.vertices.size(), what + ": pin " + std::to_string(pin) +
                                           " is out of range (the object has " +
                                           std::to_string(def.vertices.size()) + " vertices)");
}

// A unit axis, or a zero vector if `axis` has no usable direction.
Vec3d direction(const Vec3d& axis) {
  const double length = axis.norm();
  return length > 1e-12 && std::isfinite(length) ? Vec3d(axis / length) : Vec3d::Zero();
}

// The fields of an animated motion (a collider's or a pin group's); `what` names its owner.
void validateMotionFields(const ColliderMotion& m, const std::string& what) {
  // Bounded like the other colliders' coordinates, so that posed positions stay finite in Real.
  require(m.pivot.allFinite() && m.pivot.cwiseAbs().maxCoeff() < 1e9,
          what + ": motion pivot must be finite and within 1e9 m");
  require(!m.loop || m.keyframes.size() >= 2, what + ": a looping motion needs two keyframes");
  for (std::size_t k = 0; k < m.keyframes.size(); ++k) {
    const Keyframe& f = m.keyframes[k];
    const std::string key = what + ": keyframe " + std::to_string(k);
    require(std::isfinite(f.time), key + " time must be finite");
    require(f.translation.allFinite() && f.translation.cwiseAbs().maxCoeff() < 1e9,
            key + " translation must be finite and within 1e9 m");
    require(std::isfinite(f.angle), key + " angle must be finite");
    require(f.axis.allFinite() && direction(f.axis) != Vec3d::Zero(),
            key + " axis must be finite and not zero");
    if (k == 0) continue;
    const Keyframe& e = m.keyframes[k - 1];
    if (!(f.time > e.time)) {
      std::ostringstream message;
      message << key << " time " << f.time << " must be later than keyframe " << k - 1 << "'s time "
              << e.time;
      throw std::invalid_argument(message.str());
    }
    // Slerp takes the shorter way round; at half a turn both ways are equally short.
    const Eigen::Quaterniond a(Eigen::AngleAxisd(e.angle, direction(e.axis)));
    const Eigen::Quaterniond b(Eigen::AngleAxisd(f.angle, direction(f.axis)));
    require(std::abs(a.dot(b)) > 1e-6, key + " is half a turn from keyframe " +
                                           std::to_string(k - 1) +
                                           ": the way round is ambiguous; add a keyframe between");
  }
  const BendMotion& bend = m.bend;
  if (bend.curvature == 0) return;
  require(std::isfinite(bend.curvature), what + ": bend curvature must be finite");
  require(std::isfinite(bend.frequency) && bend.frequency > 0,
          what + ": bend frequency must be positive and finite");
  const Vec3d axis = bend.axis.allFinite() ? direction(bend.axis) : Vec3d::Zero();
  const Vec3d along = bend.along.allFinite() ? direction(bend.along) : Vec3d::Zero();
  require(axis != Vec3d::Zero() && along != Vec3d::Zero(),
          what + ": bend axis and along must be finite and not zero");
  require(std::abs(axis.dot(along)) < 1e-6, what + ": bend axis and along must be perpendicular");
}

void validateMotion(const ObjectDef& def, ObjectKind kind, const std::string& what) {
  const ColliderMotion& m = def.motion;
  if (!m.animated()) return;
  require(kind == ObjectKind::Collider, what + ": only colliders can have a motion");
  require(def.velocity == Vec3::Zero(),
          what + ": a collider with a motion takes no velocity (the motion sets it)");
  validateMotionFields(m, what);
}

// Animated pins (ARCHITECTURE.md §4): each group non-empty, its vertices in range and in no other
// group nor among the still pins, its motion animated and valid.
void validatePinGroups(const ObjectDef& def, ObjectKind kind, const std::string& what) {
  if (def.pinGroups.empty()) return;
  require(kind != ObjectKind::Collider,
          what + ": a collider takes no pin groups (its motion moves all of it)");
  constexpr int kStill = -1, kFree = -2;
  std::vector<int> owner(def.vertices.size(), kFree);  // per vertex: its group, kStill, kFree
  for (Index pin : def.pins) owner[pin] = kStill;
  for (std::size_t g = 0; g < def.pinGroups.size(); ++g) {
    const PinGroup& group = def.pinGroups[g];
    const std::string name = what + ": pin group " + std::to_string(g);
    require(!group.vertices.empty(), name + " has no vertices");
    for (Index v : group.vertices) {
      require(v < def.vertices.size(), name + ": vertex " + std::to_string(v) +
                                           " is out of range (the object has " +
                                           std::to_string(def.vertices.size()) + " vertices)");
      require(owner[v] != kStill, name + ": vertex " + std::to_string(v) + " is also a still pin");
      require(owner[v] == kFree, name + ": vertex " + std::to_string(v) + " is also in pin group " +
                                     std::to_string(owner[v]));
      owner[v] = static_cast<int>(g);
    }
    require(group.motion.animated(),
            name + " has no motion: give keyframes or a bend (still vertices are pins)");
    validateMotionFields(group.motion, name);
  }
}

KinematicTrack makeTrack(const ColliderMotion& m, Index object, Index first, Index count) {
  KinematicTrack track;
  track.object = object;
  track.firstParticle = first;
  track.particleCount = count;
  track.pivot = m.pivot;
  for (const Keyframe& f : m.keyframes) {
    track.times.push_back(f.time);
    track.translations.push_back(f.translation);
    track.rotations.emplace_back(Eigen::AngleAxisd(f.angle, direction(f.axis)));
  }
  track.loop = m.loop;
  track.bend = m.bend;
  track.bend.axis = direction(m.bend.axis);
  track.bend.along = direction(m.bend.along);
  return track;
}

// The track of a pin group of the object whose particles start at `first`.
KinematicTrack makePinTrack(const PinGroup& group, Index object, Index first) {
  KinematicTrack track =
      makeTrack(group.motion, object, first, static_cast<Index>(group.vertices.size()));
  for (Index v : group.vertices) track.particles.push_back(first + v);
  return track;
}

void appendTrack(KinematicTracks& kinematics, KinematicTrack track) {
  track.firstTarget = static_cast<Index>(kinematics.target.size());
  kinematics.target.resize(kinematics.target.size() + track.particleCount, Vec3::Zero());
  kinematics.tracks.push_back(std::move(track));
}

// Lumped mass: each top simplex gives its measure (length, area, volume) equally to its vertices.
// Vertices no simplex uses get the mean share so that they stay ordinary free particles.
std::vector<double> lumpedMeasure(const SimplicialComplex& c, std::span<const Vec3> x) {
  std::vector<double> share(c.vertexCount(), 0.0);
  auto at = [&](Index i) { return x[i].cast<double>().eval(); };
  switch (c.dimension) {
    case 0:
      std::fill(share.begin(), share.end(), 1.0);
      break;
    case 1:
      for (const auto& e : c.edges.vertices) {
        const double l = (at(e[1]) - at(e[0])).norm() / 2;
        share[e[0]] += l;
        share[e[1]] += l;
      }
      break;
    case 2:
      for (const auto& t : c.triangles.vertices) {
        const double a = (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0])).norm() / 6;
        for (Index v : t) share[v] += a;
      }
      break;
    case 3:
      for (const auto& t : c.tets.vertices) {
        const double v =
            std::abs((at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0])).dot(at(t[3]) - at(t[0]))) /
            24;
        for (Index i : t) share[i] += v;
      }
      break;
  }
  double total = 0;
  std::size_t used = 0;
  for (double s : share)
    if (s > 0) total += s, ++used;
  if (total <= 0 || !std::isfinite(total))
    throw MeshError("every simplex is degenerate (zero length, area or volume)");
  for (double& s : share)
    if (s <= 0) s = total / static_cast<double>(used);
  return share;
}

}  // namespace

// The solver's collider list from the API's colliders, in a fixed order (ground, planes, spheres)
// so that contacts come out in the same order on every run.
static void rebuildColliders(WorldState& s) {
  ColliderPool& pool = s.colliders;
  pool.clear();
  const GroundPlane& g = s.ground;
  if (g.enabled)
    pool.append(ColliderShape::Plane, Vec3(0, g.height, 0), Vec3(0, 1, 0), 0, g.thickness,
                g.friction, g.staticFriction);
  for (const PlaneCollider& plane : s.planes)
    pool.append(ColliderShape::Plane, plane.point, plane.normal.normalized(), 0, plane.thickness,
                plane.friction, plane.staticFriction);
  for (const SphereCollider& sphere : s.spheres)
    pool.append(ColliderShape::Sphere, sphere.center, Vec3::Zero(), sphere.radius, sphere.thickness,
                sphere.friction, sphere.staticFriction);
}

World::World() : impl_(std::make_unique<Impl>()) {}
World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

static ObjectId addObject(World::Impl& impl, const ObjectDef& def, ObjectKind kind) {
  WorldState& s = impl.state;
  const std::string what =
      std::string(toString(kind)) + " '" +
      (def.name.empty() ? "object" + std::to_string(s.objects.size()) : def.name) + "'";
  validateCommon(def, what, s.constraints.familyCount());
  require(def.material.pressure.mode == PressureMode::Off || kind == ObjectKind::Cloth,
          what + ": only a cloth can have pressure");
  require(def.material.rigidity == 0 || kind != ObjectKind::Collider,
          what + ": a collider is moved by its motion, not by rigidity");
  const Tear& tear = def.material.tear;
  require(std::isfinite(tear.strain) && tear.strain >= 0 && tear.strain <= 1000,
          what + ": tear strain must be in [0, 1000] (0: no tearing)");
  require(std::isfinite(tear.time) && tear.time >= 0 && tear.time <= 1000,
          what + ": tear time must be in [0, 1000] s");
  require(tear.maxNewVertices >= -1 && tear.maxNewVertices <= 10000000,
          what + ": tear max_new_vertices must be in [0, 1e7] (−1: derived)");
  if (tear.enabled()) {
    require(kind == ObjectKind::Cloth, what + ": only a cloth can tear");
    require(def.material.pressure.mode == PressureMode::Off,
            what + ": a tearable cloth can have no pressure (a torn surface holds no gas)");
    require(def.material.rigidity == 0, what + ": a tearable cloth can have no rigidity");
  }
  validateMotion(def, kind, what);
  validatePinGroups(def, kind, what);
  const std::size_t n = def.vertices.size();
  if (def.material.liquid.enabled) {
    require(kind == ObjectKind::Particles, what + ": only a particle cloud can be a liquid");
    // One hash grid serves every liquid, its cells the kernel radius.
    const LiquidPool& liquids = s.constraints.liquid;
    const Real radius = liquidKernelRadius(def.material.liquid, def.material.mass, n);
    require(liquids.objects.empty() ||
                std::abs(radius - liquids.kernels.radius) <= 1e-4 * liquids.kernels.radius,
            what + ": its kernel radius " + std::to_string(radius) +
                " m differs from the other liquids' (" + std::to_string(liquids.kernels.radius) +
                " m): liquids of one world share their particle size and kernel scale");
  }

  ObjectRecord record;
  record.kind = kind;
  record.name = def.name.empty() ? "object" + std::to_string(s.objects.size()) : def.name;
  record.material = def.material;
  try {
    switch (kind) {
      case ObjectKind::Cloth:
      case ObjectKind::Collider:
        require(def.edges.empty() && def.tets.empty(), what + " takes triangles only");
        record.complex = buildFromTriangles(n, def.triangles);
        break;
      case ObjectKind::Rope:
        require(def.triangles.empty() && def.tets.empty(), what + " takes edges only");
        record.complex = buildFromEdges(n, def.edges);
        break;
      case ObjectKind::Solid:
        require(def.edges.empty() && def.triangles.empty(), what + " takes tetrahedra only");
        record.complex = buildFromTets(n, def.tets);
        break;
      case ObjectKind::Particles:
        require(def.edges.empty() && def.triangles.empty() && def.tets.empty(),
                what + " takes points only");
        record.complex = buildFromPoints(n);
        break;
    }
    auditGeometry(record.complex, def.vertices);
  } catch (const MeshError& e) {
    throw MeshError(what + ": " + e.what());
  }
  const SimplicialComplex& c = record.complex;
  if (c.dimension == 2) {
    record.surface.assign(c.triangles.vertices.begin(), c.triangles.vertices.end());
    const std::size_t boundary = c.boundaryEdges().size();
    record.closed =
        boundary == 0 && c.report.nonManifoldFaces == 0 && c.report.inconsistentOrientation == 0;
    if (def.material.pressure.mode != PressureMode::Off && !record.closed)
      throw MeshError(what +
                      ": pressure needs a closed, consistently oriented surface, and it has " +
                      std::to_string(boundary) + " boundary edges, " +
                      std::to_string(c.report.nonManifoldFaces) + " non-manifold faces and " +
                      std::to_string(c.report.inconsistentOrientation) +
                      " edges whose triangles disagree on the orientation");
    // A surface facing inwards encloses a negative volume, a flat one none.
    if (def.material.pressure.mode != PressureMode::Off) {
      const double rest = enclosedVolume(record.surface, def.vertices, 0);
      if (!(rest > 0))
        throw MeshError(what + ": pressure needs a surface that encloses a volume with its " +
                        "triangles facing outwards (its rest volume is " + std::to_string(rest) +
                        " m³)");
    }
  } else if (c.dimension == 3) {
    record.surface = c.boundaryTriangles();
    record.closed = c.report.nonManifoldFaces == 0;
  }
  std::vector<double> share;
  try {
    share = lumpedMeasure(c, def.vertices);
  } catch (const MeshError& e) {
    throw MeshError(what + ": " + e.what());
  }
  double shareTotal = 0;
  for (double v : share) shareTotal += v;

  // Everything validated: from here on the world changes.
  ParticlePool& particles = s.particles;
  // A tearable cloth's spare particles follow its own, inert (inverse mass 0, in no constraint
  // or primitive) until a split takes one: the object's range stays contiguous.
  const Index spare = tearSpareParticles(def.material.tear, n);
  const Index first = particles.append(n + spare);
  for (Index i = 0; i < spare; ++i) {
    particles.x[first + n + i] = particles.restPosition[first + n + i] = def.vertices[0];
    particles.phase[first + n + i] = static_cast<std::uint32_t>(s.objects.size());
  }
  record.tear.spareParticles = spare;
  s.tearReport.spareParticles += spare;
  const bool kinematic = kind == ObjectKind::Collider;
  for (std::size_t i = 0; i < n; ++i) {
    particles.x[first + i] = def.vertices[i];
    particles.restPosition[first + i] = def.vertices[i];
    particles.v[first + i] = def.velocity;
    particles.w[first + i] =
        kinematic ? Real(0) : static_cast<Real>(shareTotal / (def.material.mass * share[i]));
    particles.phase[first + i] = static_cast<std::uint32_t>(s.objects.size());
  }
  for (Index pin : def.pins) {
    particles.w[first + pin] = 0;
    particles.v[first + pin].setZero();
  }
  if (def.motion.animated()) {  // starts where its motion is now, so the first substep is smooth
    KinematicTrack track =
        makeTrack(def.motion, static_cast<Index>(s.objects.size()), first, static_cast<Index>(n));
    posePositions(track, std::span<const Vec3>(particles.restPosition).subspan(first, n), s.time,
                  std::span<Vec3>(particles.x).subspan(first, n));
    appendTrack(s.kinematics, std::move(track));
  }
  // Animated pins: held like pins, moved by their group's track, and posed now like a collider.
  std::vector<Index> held = def.pins;
  for (const PinGroup& group : def.pinGroups) {
    KinematicTrack track = makePinTrack(group, static_cast<Index>(s.objects.size()), first);
    std::vector<Vec3> rest, posed(group.vertices.size());
    for (Index v : group.vertices) {
      particles.w[first + v] = 0;
      particles.v[first + v].setZero();
      rest.push_back(def.vertices[v]);
      held.push_back(v);
    }
    posePositions(track, rest, s.time, posed);
    for (std::size_t i = 0; i < posed.size(); ++i) particles.x[track.particle(i)] = posed[i];
    appendTrack(s.kinematics, std::move(track));
  }
  particles.p.assign(particles.x.begin(), particles.x.end());
  record.firstParticle = first;
  record.particleCount = static_cast<Index>(n);
  if (record.closed)
    record.restVolume = enclosedVolume(record.surface, particles.x, record.firstParticle);
  if (def.material.pressure.mode != PressureMode::Off) {
    appendPressureSurface(s.constraints.pressure, record,
                          static_cast<std::uint32_t>(s.objects.size()));
  }
  if (def.material.liquid.enabled)
    appendLiquidObject(s.constraints.liquid, static_cast<std::uint32_t>(s.objects.size()), first, n,
                       def.material.liquid, def.material.mass);
  if (def.material.rigidity > 0)
    appendShapeMatchCluster(s.constraints.shapeMatching, record,
                            static_cast<std::uint32_t>(s.objects.size()), particles);

  // Tethers hold free vertices to animated pins too: a tether only bounds the distance to its pin
  // by the rest path length along the mesh, which an inextensible cloth keeps wherever the pin is.
  appendObjectConstraints(s.constraints, kind, c, def.vertices, held, first, def.material);
  record.schedule = def.schedule;

  // A slot freed by a removal is reused (its generation already counted up), else a new one.
  if (s.freeObjectSlots.empty()) {
    record.slot = static_cast<Index>(s.objectSlots.size());
    s.objectSlots.emplace_back();
  } else {
    record.slot = s.freeObjectSlots.back();
    s.freeObjectSlots.pop_back();
  }
  ObjectSlot& slot = s.objectSlots[record.slot];
  slot.object = static_cast<Index>(s.objects.size());
  s.objects.push_back(std::move(record));
  s.topologyDirty = true;
  return ObjectId{s.objects.back().slot + 1, slot.generation};
}

ObjectId World::addCloth(const ObjectDef& def) {
  return addObject(*impl_, def, ObjectKind::Cloth);
}
ObjectId World::addRope(const ObjectDef& def) {
  return addObject(*impl_, def, ObjectKind::Rope);
}
ObjectId World::addSolid(const ObjectDef& def) {
  return addObject(*impl_, def, ObjectKind::Solid);
}
ObjectId World::addParticles(const ObjectDef& def) {
  return addObject(*impl_, def, ObjectKind::Particles);
}
ObjectId World::addCollider(const ObjectDef& def) {
  return addObject(*impl_, def, ObjectKind::Collider);
}

void World::setGravity(const Vec3& g) {
  require(finite(g), "gravity must be finite");
  impl_->state.gravity = g;
}
Vec3 World::gravity() const {
  return impl_->state.gravity;
}

void World::setGround(const GroundPlane& ground) {
  require(std::isfinite(ground.height) && std::abs(ground.height) < 1e9,
          "ground height must be finite");
  require(std::isfinite(ground.thickness) && ground.thickness >= 0,
          "ground thickness must be finite and non-negative");
  require(std::isfinite(ground.friction) && ground.friction >= 0 &&
              std::isfinite(ground.staticFriction) && ground.staticFriction >= 0,
          "ground friction must be finite and non-negative");
  impl_->state.ground = ground;
  rebuildColliders(impl_->state);
}
const GroundPlane& World::ground() const {
  return impl_->state.ground;
}

// Thickness and Coulomb coefficients every collider has.
static void validateSurface(Real thickness, Real friction, Real staticFriction,
                            const std::string& what) {
  require(std::isfinite(thickness) && thickness >= 0,
          what + " thickness must be finite and non-negative");
  require(std::isfinite(friction) && friction >= 0 && std::isfinite(staticFriction) &&
              staticFriction >= 0,
          what + " friction must be finite and non-negative");
}

void World::addSphereCollider(const SphereCollider& sphere) {
  require(finite(sphere.center) && std::abs(sphere.center.maxCoeff()) < 1e9 &&
              std::abs(sphere.center.minCoeff()) < 1e9,
          "sphere centre must be finite");
  require(std::isfinite(sphere.radius) && sphere.radius > 0 && sphere.radius < 1e9,
          "sphere radius must be positive and finite");
  validateSurface(sphere.thickness, sphere.friction, sphere.staticFriction, "sphere");
  impl_->state.spheres.push_back(sphere);
  rebuildColliders(impl_->state);
}
void World::addPlaneCollider(const PlaneCollider& plane) {
  require(finite(plane.point) && plane.point.cwiseAbs().maxCoeff() < 1e9,
          "plane point must be finite");
  require(finite(plane.normal) && plane.normal.norm() > Real(1e-6) &&
              plane.normal.cwiseAbs().maxCoeff() < 1e9,
          "plane normal must be finite and not zero");
  validateSurface(plane.thickness, plane.friction, plane.staticFriction, "plane");
  impl_->state.planes.push_back(plane);
  rebuildColliders(impl_->state);
}
std::span<const PlaneCollider> World::planeColliders() const {
  return impl_->state.planes;
}
std::span<const SphereCollider> World::sphereColliders() const {
  return impl_->state.spheres;
}

void World::setSolver(const SolverSettings& settings) {
  require(settings.iterations >= 0 && settings.iterations <= 100000,
          "iterations must be in [0, 100000]");
  require(settings.substeps >= 1 && settings.substeps <= 10000, "substeps must be in [1, 10000]");
  require(std::isfinite(settings.relaxation) && settings.relaxation > 0 && settings.relaxation < 2,
          "relaxation must be in (0, 2)");
  require(std::isfinite(settings.sheetRelaxation) && settings.sheetRelaxation > 0 &&
              settings.sheetRelaxation < 2,
          "sheet_relaxation must be in (0, 2)");
  require(std::isfinite(settings.chebyshevRho) && settings.chebyshevRho >= 0 &&
              settings.chebyshevRho <= Real(0.9999),
          "chebyshev_rho must be in [0, 0.9999]");
  require(std::isfinite(settings.supportedInverseMassScale) &&
              settings.supportedInverseMassScale >= Real(0.001) &&
              settings.supportedInverseMassScale <= 1,
          "supported_inverse_mass_scale must be in [0.001, 1]");
  validateSchedule(settings.schedule, "solver schedule", impl_->state.constraints.familyCount());
  require(settings.sweepsPerLevel.size() <= 64, "at most 64 sweeps-per-level values");
  for (int sweeps : settings.sweepsPerLevel)
    require(sweeps >= 0 && sweeps <= 1000, "sweeps per level must be in [0, 1000]");
  require(settings.cascadeEvery >= 0 && settings.cascadeEvery <= 100000,
          "cascade_every must be in [0, 100000]");
  require(std::isfinite(settings.cascadeRelaxation) && settings.cascadeRelaxation >= 1 &&
              settings.cascadeRelaxation < 2,
          "cascade_relaxation must be in [1, 2)");
  require(settings.smoother == SolverKind::GaussSeidel || settings.smoother == SolverKind::Jacobi ||
              settings.smoother == SolverKind::ColoredGaussSeidel,
          "the multigrid smoother must be gauss-seidel, jacobi or colored-gs");
  require(std::isfinite(settings.maxKinematicTravel) && settings.maxKinematicTravel < 1e9,
          "max_kinematic_travel must be finite (negative: derived from the thicknesses; 0: off)");
  require(std::isfinite(settings.maxImpactTravel) && settings.maxImpactTravel < 1e9,
          "max_impact_travel must be finite (negative: derived from the edge lengths; 0: off)");
  require(settings.maxSubsteps >= 0 && settings.maxSubsteps <= 10000,
          "max_substeps must be in [0, 10000] (0: 8 × substeps, at least 16)");
  impl_->state.solver = settings;
  impl_->state.topologyDirty = true;  // the sweep plan follows the schedule
}
const SolverSettings& World::solver() const {
  return impl_->state.solver;
}

void World::setThreads(int threads) {
  require(threads >= 0 && threads <= 4096, "threads must be in [0, 4096] (0 = all cores)");
  if (threads == impl_->threads && impl_->arena) return;
  impl_->graph.reset();
  impl_->arena.reset();
  impl_->threads = threads;
}
int World::threads() const {
  return impl_->threads > 0 ? impl_->threads : tbb::info::default_concurrency();
}

int substepsForTravel(const SolverSettings& settings, double travel, double limit, bool& capped) {
  capped = false;
  const int least = settings.substeps;
  // Written so that a NaN travel raises nothing.
  if (!(limit > 0) || !(travel > limit * least)) return least;
  const int most =
      settings.maxSubsteps > 0 ? settings.maxSubsteps : std::min(10000, std::max(16, 8 * least));
  const double needed = std::ceil(travel / limit);
  if (needed > double(most)) {
    capped = true;
    return std::max(most, least);
  }
  return std::max(least, static_cast<int>(needed));
}

namespace {

// The farthest a collider moving at a constant velocity goes in dt seconds.
double constantVelocityTravel(const std::vector<ObjectRecord>& objects,
                              const KinematicTracks& kinematics, const ParticlePool& particles,
                              double dt) {
  double farthest = 0;
  for (std::size_t o = 0; o < objects.size(); ++o) {
    if (objects[o].kind != ObjectKind::Collider) continue;
    const bool tracked =
        std::any_of(kinematics.tracks.begin(), kinematics.tracks.end(),
                    [&](const KinematicTrack& track) { return track.object == o; });
    if (tracked) continue;
    // Every particle of it has the collider's velocity (up to the rounding of the update).
    if (objects[o].particleCount > 0)
      farthest = std::max(farthest, double(particles.v[objects[o].firstParticle].norm()) * dt);
  }
  return farthest;
}

// The smallest contact distance (summed radii) between a primitive of an object that may be
// animated (a collider, or an object with animated pins) and a primitive of an object that
// moves; 0 when there is no such pair.
double smallestKinematicContact(const CollisionPrimitives& primitives,
                                const std::vector<ObjectRecord>& objects,
                                const KinematicTracks& kinematics) {
  // Every collider counts (one still now may be given a velocity's worth of targets later, and
  // targets add no track until then), and every object with animated pins.
  std::vector<std::uint8_t> animated(objects.size(), 0);
  for (const KinematicTrack& track : kinematics.tracks)
    if (track.object < animated.size()) animated[track.object] = 1;
  for (std::size_t o = 0; o < objects.size(); ++o)
    animated[o] |= objects[o].kind == ObjectKind::Collider;
  constexpr double kNone = std::numeric_limits<double>::infinity();
  double kinematic = kNone, moving = kNone;
  const auto visit = [&](const std::vector<Real>& radius,
                         const std::vector<std::uint32_t>& object) {
    for (std::size_t i = 0; i < radius.size() && i < object.size(); ++i) {
      if (object[i] >= objects.size()) continue;
      if (animated[object[i]]) kinematic = std::min(kinematic, double(radius[i]));
      if (objects[object[i]].kind != ObjectKind::Collider)
        moving = std::min(moving, double(radius[i]));
    }
  };
  visit(primitives.pointRadius, primitives.pointObject);
  visit(primitives.edgeRadius, primitives.edgeObject);
  visit(primitives.triangleRadius, primitives.triangleObject);
  return kinematic < kNone && moving < kNone ? kinematic + moving : 0;
}

// The substeps of the coming step of dt seconds (SolverSettings::maxKinematicTravel), counted in
// the collision report when raised.
int substepsOfStep(WorldState& s, double dt) {
  const SolverSettings& settings = s.solver;
  const double limit = settings.maxKinematicTravel < 0
                           ? kKinematicTravelShare * s.kinematicContactDistance
                           : double(settings.maxKinematicTravel);
  const double travel = std::max(kinematicTravel(s.kinematics, s.particles, s.time, s.time + dt),
                                 constantVelocityTravel(s.objects, s.kinematics, s.particles, dt));
  bool capped = false;
  int substeps = substepsForTravel(settings, travel, limit, capped);
  // The free particles' travel in units of their limits: at most 1 per substep.
  bool impactCapped = false;
  const int forImpact =
      settings.maxImpactTravel == 0
          ? settings.substeps
          : substepsForTravel(
                settings,
                impactTravelRatio(s.objects, s.objectEdgeLength, s.particles, s.colliders,
                                  double(settings.maxImpactTravel), kImpactTravelShare, dt, travel,
                                  double(settings.substeps), s.impactScratch),
                1.0, impactCapped);
  CollisionReport& report = s.collisionReport;
  // A strike's raised count is held while the world is still stretched after it
  // (ImpactHold; holdImpactSubsteps below): its crumple goes on folding after the bulk of the
  // object has slowed down.
  ImpactHold& hold = s.impactHold;
  hold.travelRaised = forImpact > settings.substeps;
  const bool held = hold.substeps > std::max({substeps, forImpact, settings.substeps});
  const int wanted = held ? hold.substeps : forImpact;
  if (wanted > substeps) {
    substeps = wanted, capped = held ? capped : impactCapped;
    ++report.impactRaisedSteps;
    report.impactHeldSteps += held;
  }
  hold.substeps = hold.travelRaised || held ? wanted : 0;
  report.raisedSubstepSteps += substeps > settings.substeps;
  report.cappedSubstepSteps += capped;
  report.mostSubsteps = std::max<std::uint64_t>(report.mostSubsteps, std::uint64_t(substeps));
  return substeps;
}

// After a step the impact rule raised: whether the next may hold its count. Within
// kImpactHoldSteps steps of the last raise for travel, and while the largest stretch strain is
// above kImpactHoldStrain: measured on a sheet slammed edge-first into a wall at 10 m/s, whose
// count fell back to 2 while its crumple still folded (edges at 4 times their length), and held
// at 0.3 is clean (torture.md). The bound keeps a cloth left stretched at rest from holding for
// ever.
void holdImpactSubsteps(WorldState& s) {
  ImpactHold& hold = s.impactHold;
  if (hold.travelRaised) hold.stepsLeft = kImpactHoldSteps;
  if (hold.substeps == 0) return;
  if (hold.stepsLeft <= 0 ||
      !(measureStrain(s.constraints.stretch, s.particles.x).max > kImpactHoldStrain)) {
    hold.substeps = 0;
    return;
  }
  --hold.stepsLeft;
}

}  // namespace

// The tables derived from the objects' topology (incidence, colouring, levels, collision
// primitives, the sweep plan), rebuilt outside the step so that a step never allocates.
void buildDerivedTablesIfDirty(WorldState& s) {
  if (!s.topologyDirty) return;
  const auto tablesStart = std::chrono::steady_clock::now();
  buildDerivedTables(s.constraints, s.particles, fineSweepKind(s.solver));
  buildCollisionPrimitives(s.primitives, s.objects, s.excludedObjectPairs, s.excludedVertexSets,
                           s.particles.size());
  // Pair indices name the new primitives: nothing the narrow phase kept of the old ones holds.
  s.primitiveContacts.boundVersion = 0;
  if (s.solver.kind == SolverKind::Multigrid) {
    buildLevelHierarchies(s.hierarchies, s.objects, s.particles);
    attachLevelTethers(s.hierarchies, s.constraints.tether, s.particles.size());
    s.cascade.start.resize(s.particles.size());
    s.cascade.limit.resize(s.hierarchies.coarseEdges);
    s.cascade.held.resize(s.particles.size());
  } else
    s.hierarchies.objects.clear();
  s.plan = buildSweepPlan(s.solver, s.objects, s.constraints, s.particles);
  const LiquidPool& liquids = s.constraints.liquid;
  s.contacts.extraReach.assign(liquids.size() > 0 ? s.particles.size() : 0, Real(0));
  for (Index particle : liquids.particle)
    s.contacts.extraReach[particle] = kLiquidContactReach * liquids.kernels.radius;
  s.primitiveContacts.splitParticle.assign(liquids.size() > 0 ? s.particles.size() : 0, 0);
  for (Index particle : liquids.particle) s.primitiveContacts.splitParticle[particle] = 1;
  s.kinematicContactDistance = smallestKinematicContact(s.primitives, s.objects, s.kinematics);
  s.objectEdgeLength = medianEdgeLengths(s.objects, s.particles);
  s.topologyDirty = false;
  s.profile.derivedTables +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - tablesStart).count();
}

void World::step(double dt) {
  require(std::isfinite(dt) && dt > 0 && dt <= 1,
          "time step must be finite and in (0, 1] seconds, got " + std::to_string(dt));
  Impl& impl = *impl_;
  WorldState& s = impl.state;
  buildDerivedTablesIfDirty(s);
  if (!impl.arena) {
    const int concurrency = impl.threads > 0 ? impl.threads : int{tbb::task_arena::automatic};
    impl.arena = std::make_unique<tbb::task_arena>(concurrency);
    impl.arena->initialize();
  }
  impl.arena->execute([&] {
    // The graph is made inside the arena so that its tasks run on the arena's threads.
    if (!impl.graph) impl.graph = std::make_unique<StepGraph>(impl.state);
    SubstepContext context;
    context.substeps = substepsOfStep(s, dt);
    context.h = static_cast<Real>(dt / context.substeps);
    context.inverseH = 1 / context.h;
    s.lastSubstep = context.h;
    context.step = ++impl.state.stepCount;
    const double stepStart = impl.state.time;
    for (int i = 0; i < context.substeps; ++i) {
      context.substep = i;
      context.time = impl.state.time;
      // From the step's start rather than summed substep by substep, so that the step ends
      // exactly at start + dt.
      context.endTime =
          i + 1 == context.substeps ? stepStart + dt : stepStart + dt * (i + 1) / context.substeps;
      impl.graph->runSubstep(context);
      impl.state.time = context.endTime;
    }
  });
  holdImpactSubsteps(s);
  // Tearing, between steps (systems/topology/tear_cloth.h). The broad phase's carried pairs name
  // the old primitives: a torn world searches again.
  const auto tearStart = std::chrono::steady_clock::now();
  if (tearCloths(s.objects, s.particles, s.constraints, dt, s.tearReport)) {
    s.topologyDirty = true;
    s.candidates.pathStart.clear();
  }
  openTornLips(s.objects, s.particles, s.primitives);
  s.profile.tear +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - tearStart).count();
  s.collisionReport.broadPhaseTreeErrors = s.bvh.embreeErrors();
  ++impl.state.profile.steps;
}

double World::time() const {
  return impl_->state.time;
}

std::uint64_t World::steps() const {
  return impl_->state.stepCount;
}

std::size_t World::particleCount() const {
  return impl_->state.particles.size();
}
std::size_t World::objectCount() const {
  return impl_->state.objects.size();
}
std::span<const Vec3> World::positions() const {
  return impl_->state.particles.x;
}
std::span<const Vec3> World::velocities() const {
  return impl_->state.particles.v;
}
std::span<const Real> World::inverseMasses() const {
  return impl_->state.particles.w;
}

// The object table's index of the object `id` names; throws for a null id, one this world never
// gave, and one of a removed object.
static Index objectIndex(const World::Impl& impl, ObjectId id) {
  const std::vector<ObjectSlot>& slots = impl.state.objectSlots;
  if (!id.valid() || id.index1 > slots.size() || slots[id.index1 - 1].generation != id.generation ||
      slots[id.index1 - 1].object == ObjectSlot::kNoObject)
    throw std::invalid_argument("invalid object id");
  return slots[id.index1 - 1].object;
}

static const ObjectRecord& lookup(const World::Impl& impl, ObjectId id) {
  return impl.state.objects[objectIndex(impl, id)];
}

void World::setColliderTargets(ObjectId id, std::span<const Vec3> positions) {
  const ObjectRecord& o = lookup(*impl_, id);
  const std::string what = std::string(toString(o.kind)) + " '" + o.name + "'";
  require(o.kind == ObjectKind::Collider, "setColliderTargets: " + what + " is not a collider");
  require(positions.size() == o.particleCount,
          "setColliderTargets: " + what + " has " + std::to_string(o.particleCount) +
              " vertices, got " + std::to_string(positions.size()) + " positions");
  for (std::size_t i = 0; i < positions.size(); ++i)
    require(finite(positions[i]) && positions[i].cwiseAbs().maxCoeff() < 1e9,
            "setColliderTargets: " + what + ": position " + std::to_string(i) + " is not finite");
  KinematicTracks& kinematics = impl_->state.kinematics;
  const Index object = objectIndex(*impl_, id);
  auto track = std::find_if(kinematics.tracks.begin(), kinematics.tracks.end(),
                            [&](const KinematicTrack& t) { return t.object == object; });
  if (track == kinematics.tracks.end()) {
    KinematicTrack driven;
    driven.object = object;
    driven.firstParticle = o.firstParticle;
    driven.particleCount = o.particleCount;
    driven.drivenByTargets = true;
    driven.goal.resize(o.particleCount);
    driven.stepStart.resize(o.particleCount);
    appendTrack(kinematics, std::move(driven));
    track = kinematics.tracks.end() - 1;
  }
  require(track->drivenByTargets,
          "setColliderTargets: " + what + " is animated by its motion and takes no targets");
  std::copy(positions.begin(), positions.end(), track->goal.begin());
  track->targetsPending = true;
}

std::span<const Vec3> World::positions(ObjectId id) const {
  const ObjectRecord& o = lookup(*impl_, id);
  return std::span<const Vec3>(impl_->state.particles.x).subspan(o.firstParticle, o.particleCount);
}
std::string World::name(ObjectId id) const {
  return lookup(*impl_, id).name;
}
ObjectKind World::kind(ObjectId id) const {
  return lookup(*impl_, id).kind;
}
ObjectId World::objectAt(std::size_t index) const {
  if (index >= impl_->state.objects.size()) throw std::out_of_range("object index out of range");
  const Index slot = impl_->state.objects[index].slot;
  return ObjectId{slot + 1, impl_->state.objectSlots[slot].generation};
}
std::span<const std::array<Index, 3>> World::surfaceTriangles(ObjectId id) const {
  return lookup(*impl_, id).surface;
}
std::span<const std::array<Index, 2>> World::curveEdges(ObjectId id) const {
  const ObjectRecord& o = lookup(*impl_, id);
  if (o.kind != ObjectKind::Rope) return {};
  return o.complex.edges.vertices;
}
Real World::thickness(ObjectId id) const {
  return lookup(*impl_, id).material.thickness;
}

std::vector<std::string> World::warnings() const {
  const WorldState& s = impl_->state;
  Real thickestCollider = 0;
  for (const ObjectRecord& o : s.objects)
    if (o.kind == ObjectKind::Collider)
      thickestCollider = std::max(thickestCollider, o.material.thickness);
  std::vector<std::string> lines;
  const std::vector<double> medianEdge = medianEdgeLengths(s.objects, s.particles);
  for (std::size_t index = 0; index < s.objects.size(); ++index) {
    const ObjectRecord& o = s.objects[index];
    if (o.kind != ObjectKind::Cloth || o.surface.empty()) continue;
    const Real r = o.material.thickness;
    const Real contact = std::max(o.material.selfCollision ? 2 * r : Real(0),
                                  thickestCollider > 0 ? r + thickestCollider : Real(0));
    if (!(contact > 0)) continue;
    if (!(double(contact) > medianEdge[index])) continue;
    std::ostringstream line;
    line << std::setprecision(3) << o.name << ": contact distance " << contact * 1000
         << " mm exceeds the median edge length " << medianEdge[index] * 1000
         << " mm: over a collider's sharp edges the edges that straddle them stretch (a smaller "
            "thickness or a coarser mesh avoids it)";
    lines.push_back(line.str());
  }
  // Multigrid's coarse levels do not see registered families: a hard one (a point held on a
  // plane) is pulled off by the cascade every substep for the fine sweeps to put back, and the
  // cloth around it stretches (examples/user_constraint.cpp: its worst edge at 26 times its
  // length).
  if (s.solver.kind == SolverKind::Multigrid)
    for (const UserConstraintPool& pool : s.constraints.user)
      if (pool.size() > 0)
        lines.push_back(pool.family.name +
                        ": registered families are not seen by multigrid's coarse levels, which "
                        "pull their particles away every substep (gauss-seidel, jacobi or "
                        "colored-gs solve them)");
  return lines;
}

std::size_t World::constraintCount(ConstraintFamily family) const {
  return impl_->state.constraints.count(family);
}

int World::sweepsPerSubstep(ConstraintFamily family) const {
  const WorldState& s = impl_->state;
  const SweepPlan plan =
      s.topologyDirty ? planSweeps(s.solver, s.objects, s.constraints.familyCount()) : s.plan;
  const std::size_t f = familyIndex(family);
  return f < plan.sweepsOfFamily.size() ? plan.sweepsOfFamily[f] : 0;
}

std::size_t World::familyCount() const {
  return impl_->state.constraints.familyCount();
}

std::string World::familyName(ConstraintFamily family) const {
  const ConstraintPools& pools = impl_->state.constraints;
  if (isBuiltin(family)) return toString(family);
  const std::size_t u = familyIndex(family) - kBuiltinFamilyCount;
  require(u < pools.user.size(), "familyName: no family with id " +
                                     std::to_string(familyIndex(family)) + " in this world");
  return pools.user[u].family.name;
}

bool World::findConstraintFamily(const std::string& name, ConstraintFamily& out) const {
  if (parseConstraintFamily(name, out)) return true;
  const ConstraintPools& pools = impl_->state.constraints;
  for (std::size_t u = 0; u < pools.user.size(); ++u)
    if (pools.user[u].family.name == name) {
      out = static_cast<ConstraintFamily>(kBuiltinFamilyCount + u);
      return true;
    }
  return false;
}

ConstraintFamily World::registerConstraintFamily(const UserConstraintFamilyDef& def) {
  ConstraintPools& pools = impl_->state.constraints;
  const std::string what = "constraint family '" + def.name + "'";
  require(!def.name.empty(), "constraint family: the name is empty");
  ConstraintFamily existing{};
  require(!findConstraintFamily(def.name, existing), what + ": the name is taken");
  require(def.arity >= 1 && def.arity <= kMaxUserConstraintArity,
          what + ": arity must be in [1, " + std::to_string(kMaxUserConstraintArity) + "]");
  require(def.restSize <= 64, what + ": at most 64 rest values per constraint");
  require(def.evaluate != nullptr, what + ": no evaluate function");
  require(pools.familyCount() < 0xffff, what + ": too many families");
  UserConstraintPool pool;
  pool.family = def;
  pools.user.push_back(std::move(pool));
  impl_->state.topologyDirty = true;
  return static_cast<ConstraintFamily>(pools.familyCount() - 1);
}

void World::addConstraint(ObjectId object, ConstraintFamily family,
                          std::span<const Index> particles, std::span<const Real> rest,
                          const ConstraintCompliance& compliance) {
  WorldState& s = impl_->state;
  const ObjectRecord& o = lookup(*impl_, object);
  const std::size_t u = familyIndex(family) - kBuiltinFamilyCount;
  require(!isBuiltin(family) && u < s.constraints.user.size(),
          "addConstraint: the family is not one registered with this world");
  UserConstraintPool& pool = s.constraints.user[u];
  const std::string what = "addConstraint: " + pool.family.name;
  require(particles.size() == pool.family.arity,
          what + " takes " + std::to_string(pool.family.arity) + " particles, got " +
              std::to_string(particles.size()));
  require(rest.size() == pool.family.restSize,
          what + " takes " + std::to_string(pool.family.restSize) + " rest values, got " +
              std::to_string(rest.size()));
  for (Index v : particles)
    require(v < o.particleCount,
            what + ": particle " + std::to_string(v) + " is not a vertex of '" + o.name + "'");
  for (Real r : rest) require(std::isfinite(r), what + ": a rest value is not finite");
  const Real below = compliance.compressionCompliance < 0 ? compliance.compliance
                                                          : compliance.compressionCompliance;
  require(std::isfinite(compliance.compliance) && compliance.compliance >= 0 &&
              std::isfinite(below) && std::isfinite(compliance.damping) && compliance.damping >= 0,
          what + ": compliance and damping must be finite and non-negative");
  for (Index v : particles) pool.particles.push_back(o.firstParticle + v);
  pool.rest.insert(pool.rest.end(), rest.begin(), rest.end());
  pool.compliance.push_back(compliance.compliance);
  pool.compressionCompliance.push_back(below);
  pool.damping.push_back(compliance.damping);
  pool.lambda.push_back(0);
  s.topologyDirty = true;  // the derived tables color the pool anew
}

Measures World::measure() const {
  const WorldState& s = impl_->state;
  Measures m;
  const StrainDistribution strain = measureStrainDistribution(s.constraints.stretch, s.particles.x);
  m.maxStrain = strain.max;
  m.meanStrain = strain.mean;
  m.strainP99 = strain.p99;
  m.maxStretch = strain.maxStretch;
  m.maxCompression = strain.maxCompression;
  m.maxTetherViolation = maxTetherViolation(s.constraints.tether, s.particles.x);
  m.kineticEnergy = kineticEnergy(s.particles);
  m.potentialEnergy = potentialEnergy(s.particles, s.gravity);
  m.nanCount = countNonFinite(s.particles);
  const Vec3d up =
      s.gravity.norm() > 0 ? Vec3d(-s.gravity.cast<double>().normalized()) : Vec3d(0, 1, 0);
  m.minHeight = s.particles.size() ? std::numeric_limits<double>::infinity() : 0.0;
  // Over the objects' ranges: a tearable cloth's unused spare particles are not part of it.
  for (const ObjectRecord& o : s.objects)
    for (Index i = o.firstParticle; i < o.firstParticle + o.particleCount; ++i)
      m.minHeight = std::min(m.minHeight, up.dot(s.particles.x[i].cast<double>()));
  double rest = 0, now = 0;
  for (const ObjectRecord& o : s.objects)
    if (o.closed && o.kind != ObjectKind::Collider) {
      rest += o.restVolume;
      now += enclosedVolume(o.surface, s.particles.x, o.firstParticle);
    }
  m.volumeRatio = rest != 0 ? now / rest : -1.0;
  // Touching: within 1 mm of a contact surface.
  m.contacts = countTouchingParticles(s.colliders, s.particles, Real(1e-3));
  m.insideColliders = countParticlesInsideColliders(s.colliders, s.particles, Real(1e-6));
  // Every object's surface in global particle indices, all objects together: pairs within one
  // object (self-intersection) and across objects count alike. Counted in the world's arena when
  // it has one, so that setThreads bounds the measure too.
  std::vector<std::array<Index, 3>> surfaces;
  for (const ObjectRecord& o : s.objects)
    for (const auto& t : o.surface)
      surfaces.push_back({o.firstParticle + t[0], o.firstParticle + t[1], o.firstParticle + t[2]});
  auto countIntersections = [&] { return countTriangleIntersections(surfaces, s.particles.x); };
  m.intersections = impl_->arena ? impl_->arena->execute(countIntersections) : countIntersections();
  return m;
}

bool World::hasPressure(ObjectId id) const {
  return lookup(*impl_, id).material.pressure.mode != PressureMode::Off;
}

std::size_t World::addAttachment(const Attachment& a) {
  WorldState& s = impl_->state;
  const ObjectRecord& object = lookup(*impl_, a.object);
  const std::string what =
      std::string("attachment (") + toString(a.kind) + ") of '" + object.name + "'";
  require(a.vertex < object.particleCount, what + ": vertex " + std::to_string(a.vertex) +
                                               " is out of range (the object has " +
                                               std::to_string(object.particleCount) + ")");
  require(std::isfinite(a.distance) &&
              (a.distance >= 0 || a.kind == AttachmentKind::SlideOnSurface) &&
              std::isfinite(a.compliance) && a.compliance >= 0 && std::isfinite(a.strength) &&
              a.strength >= 0,
          what + ": distance (but a slide's), compliance and strength must be finite and " +
              "non-negative");
  std::array<Index, 4> ids;
  ids.fill(object.firstParticle + a.vertex);
  if (a.kind == AttachmentKind::PointToPoint) {
    const ObjectRecord& target = lookup(*impl_, a.target);
    require(a.targetVertex < target.particleCount,
            what + ": target vertex " + std::to_string(a.targetVertex) + " is out of range");
    ids[1] = target.firstParticle + a.targetVertex;
    require(ids[1] != ids[0], what + ": a particle cannot be attached to itself");
  } else if (a.kind == AttachmentKind::PointToSurface || a.kind == AttachmentKind::SlideOnSurface) {
    const ObjectRecord& target = lookup(*impl_, a.target);
    for (int k = 0; k < 3; ++k) {
      require(a.triangle[k] < target.particleCount,
              what + ": triangle vertex " + std::to_string(a.triangle[k]) + " is out of range");
      ids[k + 1] = target.firstParticle + a.triangle[k];
      require(ids[k + 1] != ids[0], what + ": a particle cannot be attached to its own triangle");
    }
    require(a.weights.allFinite() && std::abs(double(a.weights.sum()) - 1) < 1e-4,
            what + ": the weights must be finite and sum to 1");
  } else {
    validateMotionFields(a.motion, what + " motion");
  }
  AttachmentPool& pool = s.constraints.attachments;
  pool.kind.push_back(a.kind);
  pool.particles.push_back(ids);
  pool.weights.push_back(a.weights);
  pool.distance.push_back(a.distance);
  pool.compliance.push_back(a.compliance);
  pool.strength.push_back(a.strength);
  pool.lambda.push_back(0);
  pool.broken.push_back(0);
  pool.removed.push_back(0);
  pool.drag.push_back(0);
  pool.rest.push_back(s.particles.restPosition[ids[0]]);
  pool.target.push_back(s.particles.x[ids[0]]);
  if (a.kind == AttachmentKind::PointToTransform) {
    pool.track.push_back(static_cast<Index>(pool.tracks.size()));
    pool.tracks.push_back(makeTrack(a.motion, objectIndex(*impl_, a.object), ids[0], 1));
  } else {
    pool.track.push_back(0);
  }
  return pool.size() - 1;
}

std::size_t World::weld(ObjectId a, ObjectId b, Real within, Real compliance, Real strength,
                        Real distance) {
  const ObjectRecord& first = lookup(*impl_, a);
  const ObjectRecord& second = lookup(*impl_, b);
  require(std::isfinite(within) && within >= 0, "weld: `within` must be finite and non-negative");
  const auto& x = impl_->state.particles.x;
  std::size_t made = 0;
  for (Index i = 0; i < first.particleCount; ++i) {
    const Vec3& p = x[first.firstParticle + i];
    Index nearest = 0;
    Real best = std::numeric_limits<Real>::infinity();
    for (Index j = 0; j < second.particleCount; ++j) {
      const Real d = (x[second.firstParticle + j] - p).norm();
      if (d < best && second.firstParticle + j != first.firstParticle + i) best = d, nearest = j;
    }
    if (!(best <= within)) continue;
    Attachment weld;
    weld.object = a;
    weld.vertex = i;
    weld.target = b;
    weld.targetVertex = nearest;
    weld.compliance = compliance;
    weld.strength = strength;
    weld.distance = distance;
    addAttachment(weld);
    ++made;
  }
  return made;
}

std::size_t World::attachmentCount() const {
  return impl_->state.constraints.attachments.size();
}
void World::removeAttachment(std::size_t index) {
  AttachmentPool& pool = impl_->state.constraints.attachments;
  require(index < pool.size(), "removeAttachment: attachment index out of range");
  pool.removed[index] = 1;
}

std::size_t World::beginDrag(ObjectId id, Index vertex, const Vec3& point, Real compliance) {
  const ObjectRecord& o = lookup(*impl_, id);
  require(o.kind != ObjectKind::Collider, "beginDrag: '" + o.name + "' is a collider");
  require(vertex < o.particleCount, "beginDrag: vertex " + std::to_string(vertex) +
                                        " is out of range (the object has " +
                                        std::to_string(o.particleCount) + ")");
  require(point.allFinite(), "beginDrag: the point must be finite");
  Attachment a;
  a.kind = AttachmentKind::PointToTransform;
  a.object = id;
  a.vertex = vertex;
  a.compliance = compliance;
  // One keyframe: the rest position moved onto the point, held until moveDrag moves it.
  const Vec3 rest = impl_->state.particles.restPosition[o.firstParticle + vertex];
  Keyframe key;
  key.translation = (point - rest).cast<double>();
  a.motion.keyframes.push_back(key);
  const std::size_t index = addAttachment(a);
  impl_->state.constraints.attachments.drag[index] = 1;
  return index;
}

void World::moveDrag(std::size_t drag, const Vec3& point) {
  AttachmentPool& pool = impl_->state.constraints.attachments;
  require(drag < pool.size() && pool.drag[drag] && !pool.removed[drag],
          "moveDrag: not a drag in progress");
  require(point.allFinite(), "moveDrag: the point must be finite");
  pool.tracks[pool.track[drag]].translations[0] = (point - pool.rest[drag]).cast<double>();
}

void World::endDrag(std::size_t drag) {
  AttachmentPool& pool = impl_->state.constraints.attachments;
  require(drag < pool.size() && pool.drag[drag] && !pool.removed[drag],
          "endDrag: not a drag in progress");
  pool.removed[drag] = 1;
}

// A moved particle can leave the bounds the carried pairs were found for: the next step
// searches afresh, as after a tear.
static void dropCollisionCaches(WorldState& s) {
  s.candidates.pathStart.clear();
  s.primitiveContacts.boundVersion = 0;
}

void World::setPositions(ObjectId id, std::span<const Vec3> positions) {
  const ObjectRecord& o = lookup(*impl_, id);
  require(o.kind != ObjectKind::Collider,
          "setPositions: '" + o.name + "' is a collider (setColliderTargets moves one)");
  require(positions.size() == o.particleCount, "setPositions: " + std::to_string(positions.size()) +
                                                   " positions for '" + o.name + "', which has " +
                                                   std::to_string(o.particleCount) + " particles");
  for (const Vec3& p : positions) require(p.allFinite(), "setPositions: a position is not finite");
  ParticlePool& particles = impl_->state.particles;
  std::copy(positions.begin(), positions.end(), particles.x.begin() + o.firstParticle);
  std::copy(positions.begin(), positions.end(), particles.p.begin() + o.firstParticle);
  dropCollisionCaches(impl_->state);
}

void World::setVelocities(ObjectId id, std::span<const Vec3> velocities) {
  const ObjectRecord& o = lookup(*impl_, id);
  require(o.kind != ObjectKind::Collider, "setVelocities: '" + o.name + "' is a collider");
  require(velocities.size() == o.particleCount,
          "setVelocities: " + std::to_string(velocities.size()) + " velocities for '" + o.name +
              "', which has " + std::to_string(o.particleCount) + " particles");
  for (const Vec3& v : velocities)
    require(v.allFinite(), "setVelocities: a velocity is not finite");
  std::copy(velocities.begin(), velocities.end(),
            impl_->state.particles.v.begin() + o.firstParticle);
  dropCollisionCaches(impl_->state);
}

void World::applyImpulse(ObjectId id, Index vertex, const Vec3& impulse) {
  const ObjectRecord& o = lookup(*impl_, id);
  require(vertex < o.particleCount, "applyImpulse: vertex " + std::to_string(vertex) +
                                        " is out of range (the object has " +
                                        std::to_string(o.particleCount) + ")");
  require(impulse.allFinite(), "applyImpulse: the impulse must be finite");
  ParticlePool& particles = impl_->state.particles;
  const Index i = o.firstParticle + vertex;
  particles.v[i] += particles.w[i] * impulse;  // Δv = J / m; nothing for a pinned particle
  dropCollisionCaches(impl_->state);
}

void World::applyImpulse(ObjectId id, const Vec3& impulse) {
  const ObjectRecord& o = lookup(*impl_, id);
  require(impulse.allFinite(), "applyImpulse: the impulse must be finite");
  ParticlePool& particles = impl_->state.particles;
  // Spread over the free particles in proportion to their mass: every one gains J / M, so the
  // object's momentum grows by J and it does not deform.
  double mass = 0;
  for (Index k = 0; k < o.particleCount; ++k)
    if (const Real w = particles.w[o.firstParticle + k]; w > 0) mass += 1 / double(w);
  if (!(mass > 0)) return;
  const Vec3 dv = (impulse.cast<double>() / mass).cast<Real>();
  for (Index k = 0; k < o.particleCount; ++k)
    if (particles.w[o.firstParticle + k] > 0) particles.v[o.firstParticle + k] += dv;
  dropCollisionCaches(impl_->state);
}

std::size_t World::removeObject(ObjectId id) {
  WorldState& s = impl_->state;
  const Index object = objectIndex(*impl_, id);
  const ObjectRecord& record = s.objects[object];
  const ObjectRemoval removal{object, record.firstParticle,
                              record.particleCount + record.tear.spareParticles};
  s.tearReport.spareParticles -= record.tear.spareParticles;
  ObjectSlot& slot = s.objectSlots[record.slot];
  slot.object = ObjectSlot::kNoObject;
  ++slot.generation;
  s.freeObjectSlots.push_back(record.slot);
  s.objects.erase(s.objects.begin() + object);
  for (Index o = object; o < s.objects.size(); ++o) {
    s.objects[o].firstParticle -= removal.particleCount;
    s.objectSlots[s.objects[o].slot].object = o;
  }
  removeParticles(s.particles, removal);
  const std::size_t detached = removeObjectConstraints(s.constraints, s.objects, removal);
  removeObjectTracks(s.kinematics, removal);
  removeObjectExclusions(s.excludedObjectPairs, s.excludedVertexSets, removal);
  // The contacts and the broad phase's pairs name particles and primitives by their old indices.
  s.contacts.resize(0);
  s.primitiveContacts.resize(0);
  s.candidates.clear();
  dropCollisionCaches(s);
  s.topologyDirty = true;
  return detached;
}

bool World::attachmentBroken(std::size_t index) const {
  require(index < impl_->state.constraints.attachments.size(), "attachment index out of range");
  return impl_->state.constraints.attachments.broken[index] != 0;
}
std::size_t World::brokenAttachments() const {
  return impl_->state.constraints.attachments.brokenCount;
}

PressureReading World::pressure(ObjectId id) const {
  const WorldState& s = impl_->state;
  const Index object = objectIndex(*impl_, id);
  const PressurePool& pool = s.constraints.pressure;
  for (std::size_t k = 0; k < pool.size(); ++k) {
    if (pool.object[k] != object) continue;
    PressureReading reading;
    reading.volume = pressureVolume(pool, k, s.particles.x);
    reading.restVolume = pool.restVolume[k];
    const Pressure& settings = pool.settings[k];
    // The multiplier of the last substep's solve over h²: the pressure difference it applied.
    const double h = s.lastSubstep;
    reading.appliedPressure = double(settings.ambient) + (h > 0 ? pool.lambda[k] / (h * h) : 0.0);
    if (settings.mode == PressureMode::Gas) {
      reading.gas = pool.gas[k];
      reading.pressure =
          pool.gas[k] / std::max(reading.volume, kMinPressureVolume * reading.restVolume);
    } else {
      reading.pressure = reading.appliedPressure;
    }
    return reading;
  }
  throw std::invalid_argument("object '" + s.objects[object].name + "' has no pressure");
}

bool World::isLiquid(ObjectId id) const {
  return lookup(*impl_, id).material.liquid.enabled;
}

LiquidReading World::liquid(ObjectId id) const {
  const WorldState& s = impl_->state;
  const ObjectRecord& record = lookup(*impl_, id);
  const LiquidPool& pool = s.constraints.liquid;
  const auto entry = std::find_if(pool.objects.begin(), pool.objects.end(), [&](const auto& o) {
    return o.object == objectIndex(*impl_, id);
  });
  if (!record.material.liquid.enabled || entry == pool.objects.end())
    throw std::invalid_argument("object '" + record.name + "' is not a liquid");
  LiquidReading out;
  out.restDensity = record.material.liquid.restDensity;
  out.droppedNeighbours = pool.droppedNeighbours;
  const std::vector<Real> density = liquidDensities(pool, s.particles.x);
  const double h2 = s.lastSubstep * s.lastSubstep;
  std::vector<double> compression;
  for (Index i = entry->begin; i < entry->end; ++i) {
    out.density.push_back(density[i]);
    out.pressure.push_back(h2 > 0 && i < pool.lambdaTotal.size()
                               ? -out.restDensity * pool.lambdaTotal[i] / (entry->particleMass * h2)
                               : 0.0);
    compression.push_back(std::max(0.0, density[i] / out.restDensity - 1));
  }
  if (!compression.empty()) {
    for (double c : compression) out.meanCompression += c / double(compression.size());
    std::sort(compression.begin(), compression.end());
    out.maxCompression = compression.back();
    const std::size_t rank = static_cast<std::size_t>(std::ceil(0.99 * double(compression.size())));
    out.compressionP99 = compression[std::max<std::size_t>(rank, 1) - 1];
  }
  return out;
}

const Recoveries& World::recoveries() const {
  return impl_->state.recoveries;
}

const TearReport& World::tearReport() const {
  return impl_->state.tearReport;
}
const CollisionReport& World::collisionReport() const {
  return impl_->state.collisionReport;
}

void World::excludeCollisions(ObjectId a, ObjectId b) {
  impl_->state.excludedObjectPairs.push_back(
      CollisionPrimitives::pairKey(objectIndex(*impl_, a), objectIndex(*impl_, b)));
  impl_->state.topologyDirty = true;
}

void World::excludeCollisions(ObjectId a, std::span<const Index> verticesA, ObjectId b,
                              std::span<const Index> verticesB) {
  const ObjectRecord& first = lookup(*impl_, a);
  const ObjectRecord& second = lookup(*impl_, b);
  WorldState& s = impl_->state;
  require(s.excludedVertexSets.size() < 16, "at most 16 pairs of vertex sets can be excluded");
  VertexSetExclusion rule;
  for (Index v : verticesA) {
    require(v < first.particleCount, "excluded vertex " + std::to_string(v) + " is out of range");
    rule.a.push_back(first.firstParticle + v);
  }
  for (Index v : verticesB) {
    require(v < second.particleCount, "excluded vertex " + std::to_string(v) + " is out of range");
    rule.b.push_back(second.firstParticle + v);
  }
  s.excludedVertexSets.push_back(std::move(rule));
  s.topologyDirty = true;
}

void World::contactPoints(std::vector<Vec3>& out) const {
  const WorldState& s = impl_->state;
  out.clear();
  for (std::size_t c = 0; c < s.contacts.size(); ++c)
    if (s.contacts.lambda[c] > 0) out.push_back(s.particles.x[s.contacts.particle[c]]);
  const PrimitiveContactPool& primitive = s.primitiveContacts;
  for (std::size_t c = 0; c < primitive.size(); ++c) {
    if (!(primitive.lambda[c] > 0)) continue;
    Vec3 point = Vec3::Zero();
    for (int k = 0; k < 4; ++k)
      if (primitive.coefficient[c][k] > 0)
        point += primitive.coefficient[c][k] * s.particles.x[primitive.particles[c][k]];
    out.push_back(point);
  }
}

const StepProfile& World::profile() const {
  return impl_->state.profile;
}
void World::resetProfile() {
  impl_->state.profile = StepProfile{};
}

std::uint64_t World::stateHash() const {
  return hashState(impl_->state.particles);
}

}  // namespace nucleon
