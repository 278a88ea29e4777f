// Checkpoints (nucleon/checkpoint.h): a little-endian binary file of the state that outlives a
// step, behind a header that says which format, library, precision and world wrote it.
#include "nucleon/checkpoint.h"

#include <algorithm>
#include <cstring>
#include <istream>
#include <ostream>
#include <type_traits>
#include <vector>

#include "engine/src/world_state.h"
#include "nucleon/hash.h"
#include "systems/topology/tear_cloth.h"

namespace nucleon {
namespace {

constexpr char kMagic[] = "nucleon checkpoint\n";
constexpr std::uint64_t kLongestString = 1 << 20;

// Types written as their bytes: plain structs and Eigen's fixed vectors (which declare copy
// constructors, so the standard trait does not count them, but hold nothing but their scalars).
template <class T>
constexpr bool kPlainBytes =
    std::is_trivially_copyable_v<T> || std::is_same_v<T, Vec3> || std::is_same_v<T, Vec3d>;

// The structure's fingerprint: FNV-1a, as World::stateHash, of plain values.
struct Fingerprint : Fnv1a {
  using Fnv1a::add;
  template <class T>
  void add(const T& pod) {
    static_assert(kPlainBytes<T>);
    Fnv1a::add(&pod, sizeof(T));
  }
};

// What the world was built from, as far as a checkpoint depends on it: the objects (names, kinds,
// particle ranges), the rest position of every vertex an object was made with and the
// constraint count of every pool. A checkpoint read into a world whose fingerprint differs would
// put its state on other particles. A tear changes none of it: a tearable cloth's range counts
// its spare particles, its copies' rest positions and its constraints (rebuilt at every tear, and
// from the checkpoint) are left out.
std::uint64_t structureOf(const World& world) {
  const WorldState& s = world.impl().state;
  Fingerprint f;
  f.add(std::uint64_t(s.particles.size()));
  f.add(std::uint64_t(s.objects.size()));
  for (const ObjectRecord& o : s.objects) {
    f.add(o.name.data(), o.name.size());
    f.add(o.kind);
    f.add(o.firstParticle);
    f.add(o.particleCount + o.tear.spareParticles);
    for (Index v = 0; v < o.particleCount; ++v)
      if (o.tear.origin.empty() || o.tear.origin[v] == v)
        f.add(s.particles.restPosition[o.firstParticle + v]);
  }
  const auto tearable = [&](Index particle) {
    return s.objects[s.particles.phase[particle]].material.tear.enabled();
  };
  s.constraints.forEach([&](const auto& pool) {
    std::uint64_t count = 0;
    for (std::size_t c = 0; c < pool.size(); ++c) count += !tearable(pool.particle(c, 0));
    f.add(count);
  });
  for (const auto family : {ConstraintFamily::Pressure, ConstraintFamily::Attachment,
                            ConstraintFamily::Rigidity, ConstraintFamily::Density})
    f.add(std::uint64_t(world.constraintCount(family)));
  return f.value;
}

class Writer {
 public:
  explicit Writer(std::ostream& out) : out_(out) {}
  template <class T>
  void pod(const T& value) {
    static_assert(kPlainBytes<T>);
    out_.write(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  template <class T>
  void array(const std::vector<T>& values) {
    static_assert(kPlainBytes<T>);
    pod(std::uint64_t(values.size()));
    out_.write(reinterpret_cast<const char*>(values.data()),
               static_cast<std::streamsize>(values.size() * sizeof(T)));
  }
  void string(const std::string& text) {
    pod(std::uint64_t(text.size()));
    out_.write(text.data(), static_cast<std::streamsize>(text.size()));
  }

 private:
  std::ostream& out_;
};

class Reader {
 public:
  explicit Reader(std::istream& in) : in_(in) {}
  template <class T>
  T pod() {
    static_assert(kPlainBytes<T>);
    T value;
    bytes(&value, sizeof(T));
    return value;
  }
  // An array whose length must be `expected` (the world's own), else the checkpoint is for
  // another world.
  template <class T>
  std::vector<T> array(std::size_t expected, const char* what) {
    static_assert(kPlainBytes<T>);
    const auto count = pod<std::uint64_t>();
    if (count != expected)
      throw CheckpointError(std::string("checkpoint: ") + what + " has " + std::to_string(count) +
                            " entries where this world has " + std::to_string(expected));
    std::vector<T> values(count);
    bytes(values.data(), count * sizeof(T));
    return values;
  }
  // An array of a cache whose length the world does not fix (at most `most` entries).
  template <class T>
  std::vector<T> cache(std::size_t most) {
    static_assert(kPlainBytes<T>);
    const auto count = pod<std::uint64_t>();
    if (count > most) throw CheckpointError("checkpoint: corrupt collision caches");
    std::vector<T> values(count);
    bytes(values.data(), count * sizeof(T));
    return values;
  }
  std::string string() {
    const auto size = pod<std::uint64_t>();
    if (size > kLongestString) throw CheckpointError("checkpoint: corrupt header");
    std::string text(size, '\0');
    bytes(text.data(), size);
    return text;
  }

 private:
  void bytes(void* to, std::size_t count) {
    in_.read(static_cast<char*>(to), static_cast<std::streamsize>(count));
    if (static_cast<std::size_t>(in_.gcount()) != count)
      throw CheckpointError("checkpoint: the file ends early (truncated?)");
  }
  std::istream& in_;
};

bool anyTorn(const WorldState& s) {
  for (const ObjectRecord& o : s.objects)
    if (!o.tear.origin.empty()) return true;
  return false;
}

// The header's fields, in order: magic, format, library version, sizeof(Real), label, structure.
struct Header {
  std::uint32_t format = 0;
  std::string version;
  std::uint32_t realSize = 0;
  std::string label;
};

Header readHeader(Reader& read, std::istream& in) {
  char magic[sizeof kMagic - 1];
  in.read(magic, sizeof magic);
  if (in.gcount() != std::streamsize(sizeof magic) || std::memcmp(magic, kMagic, sizeof magic) != 0)
    throw CheckpointError("checkpoint: not a nucleon checkpoint");
  Header h;
  h.format = read.pod<std::uint32_t>();
  if (h.format != kCheckpointFormat)
    throw CheckpointError("checkpoint: format " + std::to_string(h.format) + ", this build reads " +
                          std::to_string(kCheckpointFormat));
  h.version = read.string();
  h.realSize = read.pod<std::uint32_t>();
  h.label = read.string();
  return h;
}

// Everything a checkpoint restores, read in full before any of it is applied.
struct Snapshot {
  double time = 0, lastSubstep = 0;
  std::uint64_t stepCount = 0;
  Vec3 gravity = Vec3::Zero();
  ImpactHold impactHold;
  Recoveries recoveries;
  TearReport tearReport;
  CollisionReport collisionReport;
  std::vector<Vec3> x, v, p;
  std::vector<Real> w;
  std::vector<std::vector<double>> tearTimers;  // per object
  // A torn cloth's mesh as the tears left it (TearState; the object's record and rest shape).
  struct TornCloth {
    std::uint32_t object = 0;
    Index particleCount = 0, spareParticles = 0;
    std::vector<std::array<Index, 3>> triangles;
    std::vector<Index> origin;
    std::vector<std::uint8_t> opened;
    std::vector<Vec3> rest;
    SimplicialComplex complex;
  };
  std::vector<TornCloth> torn;
  bool tablesDirty = false;  // the writer's tables were to be rebuilt at its next step
  struct Track {
    std::uint8_t pending = 0;
    std::vector<Vec3> goal, stepStart;
  };
  std::vector<Track> tracks;
  std::vector<Vec3> kinematicTargets;
  std::vector<std::uint8_t> broken, removed;
  std::vector<double> attachmentLambda;
  std::uint64_t brokenCount = 0;
  std::vector<double> gas, pressureLambda;
  // The collision stages' caches carried from step to step (collisionCaches).
  CandidatePairs pairs;
  struct {
    std::array<std::vector<PrimitiveBox>, kBvhTreeCount> boxes;
    std::array<std::vector<BoxEnds>, kBvhTreeCount> boxEnds;
    std::array<std::vector<std::uint32_t>, kBvhTreeCount> tags;
    std::vector<Index> isolatedPoints;
  } bvh;
  struct {
    std::vector<double> startDistance, lowerBound;
    std::vector<std::uint8_t> suspect;
    std::vector<Vec3> predicted;
    std::uint64_t boundVersion = 0;
  } contacts;
};

// The collision caches a step hands to the next (components/candidate_pairs.h, the broad phase's
// boxes, the narrow phase's per-pair bounds): a step that starts from them finds other bounds and
// clamps particles differently from one that searches afresh, so a resumed run needs them to go
// on bit for bit. visit(a, b) is called with each array of the first set and the same array of
// the second, in one order for writing, reading and applying.
template <class PairsA, class BvhA, class ContactsA, class PairsB, class BvhB, class ContactsB,
          class Visit>
void collisionCaches(PairsA& pa, BvhA& ba, ContactsA& ca, PairsB& pb, BvhB& bb, ContactsB& cb,
                     Visit&& visit) {
  visit(pa.kind, pb.kind), visit(pa.first, pb.first), visit(pa.second, pb.second);
  visit(pa.pathStart, pb.pathStart), visit(pa.pathEnd, pb.pathEnd);
  visit(pa.pathReach, pb.pathReach), visit(pa.motionLower, pb.motionLower);
  visit(pa.motionUpper, pb.motionUpper), visit(pa.frameOrigin, pb.frameOrigin);
  visit(pa.formerIndex, pb.formerIndex);
  for (std::size_t t = 0; t < kBvhTreeCount; ++t) {
    visit(ba.boxes[t], bb.boxes[t]), visit(ba.boxEnds[t], bb.boxEnds[t]);
    visit(ba.tags[t], bb.tags[t]);
  }
  visit(ba.isolatedPoints, bb.isolatedPoints);
  visit(ca.startDistance, cb.startDistance), visit(ca.lowerBound, cb.lowerBound);
  visit(ca.suspect, cb.suspect), visit(ca.predicted, cb.predicted);
}

}  // namespace

void saveCheckpoint(const World& world, std::ostream& out, const std::string& label) {
  const WorldState& s = world.impl().state;
  static_assert(
      std::is_trivially_copyable_v<ImpactHold> && std::is_trivially_copyable_v<Recoveries> &&
      std::is_trivially_copyable_v<TearReport> && std::is_trivially_copyable_v<CollisionReport>);
  Writer write(out);
  out.write(kMagic, sizeof kMagic - 1);
  write.pod(kCheckpointFormat);
  write.string(NUCLEON_VERSION);
  write.pod(std::uint32_t(sizeof(Real)));
  write.string(label);
  write.pod(structureOf(world));

  write.pod(s.time);
  write.pod(s.lastSubstep);
  write.pod(s.stepCount);
  write.pod(s.gravity);
  write.pod(s.impactHold);
  write.pod(s.recoveries);
  write.pod(s.tearReport);
  write.pod(s.collisionReport);
  write.array(s.particles.x);
  write.array(s.particles.v);
  write.array(s.particles.p);
  write.array(s.particles.w);
  // Torn cloths: the mesh the tears left, from which the loader rebuilds its constraints.
  for (const ObjectRecord& o : s.objects) {
    const bool torn = !o.tear.origin.empty();
    write.pod(std::uint8_t(torn));
    if (!torn) continue;
    write.pod(o.particleCount);
    write.pod(o.tear.spareParticles);
    write.array(o.surface);
    write.array(o.tear.origin);
    write.array(o.tear.opened);
    write.array(
        std::vector<Vec3>(s.particles.restPosition.begin() + o.firstParticle,
                          s.particles.restPosition.begin() + o.firstParticle + o.particleCount));
  }
  for (const ObjectRecord& o : s.objects) write.array(o.tear.overTime);
  for (const KinematicTrack& track : s.kinematics.tracks) {
    write.pod(std::uint8_t(track.targetsPending));
    write.array(track.goal);
    write.array(track.stepStart);
  }
  write.array(s.kinematics.target);
  const AttachmentPool& attachments = s.constraints.attachments;
  write.array(attachments.broken);
  write.array(attachments.removed);
  write.array(attachments.lambda);
  write.pod(attachments.brokenCount);
  write.array(s.constraints.pressure.gas);
  write.array(s.constraints.pressure.lambda);
  const CandidatePairs& pairs = s.candidates;
  write.pod(pairs.pathFrom), write.pod(pairs.pathTo), write.pod(std::uint8_t(pairs.pathsHeld));
  write.pod(pairs.boundSlack), write.pod(pairs.frameSubstep), write.pod(pairs.version);
  write.pod(s.primitiveContacts.boundVersion);
  // A tear at the end of the last step leaves the tables to rebuild at the next one's start, which
  // drops the narrow phase's bounds: the resumed world must do the same.
  write.pod(std::uint8_t(s.topologyDirty));
  collisionCaches(pairs, s.bvh, s.primitiveContacts, pairs, s.bvh, s.primitiveContacts,
                  [&](const auto& values, const auto&) { write.array(values); });
  if (!out) throw std::runtime_error("checkpoint: cannot write");
}

std::string checkpointLabel(std::istream& in) {
  Reader read(in);
  return readHeader(read, in).label;
}

void loadCheckpoint(World& world, std::istream& in, const std::string& label) {
  WorldState& s = world.impl().state;
  Reader read(in);
  const Header header = readHeader(read, in);
  if (header.version != NUCLEON_VERSION)
    throw CheckpointError("checkpoint: written by nucleon " + header.version + ", this is " +
                          NUCLEON_VERSION);
  if (header.realSize != sizeof(Real))
    throw CheckpointError(
        std::string("checkpoint: written by a ") + (header.realSize == 8 ? "double" : "float") +
        "-precision build, this one is " + (sizeof(Real) == 8 ? "double" : "float"));
  if (header.label != label)
    throw CheckpointError("checkpoint: written for another scene or settings ('" + header.label +
                          "', this run is '" + label + "')");
  if (read.pod<std::uint64_t>() != structureOf(world))
    throw CheckpointError("checkpoint: written for a world with other objects or particles");
  if (anyTorn(s))
    throw CheckpointError("checkpoint: this world has a torn cloth (load into a world as built)");

  Snapshot snap;
  snap.time = read.pod<double>();
  snap.lastSubstep = read.pod<double>();
  snap.stepCount = read.pod<std::uint64_t>();
  snap.gravity = read.pod<Vec3>();
  snap.impactHold = read.pod<ImpactHold>();
  snap.recoveries = read.pod<Recoveries>();
  snap.tearReport = read.pod<TearReport>();
  snap.collisionReport = read.pod<CollisionReport>();
  const std::size_t n = s.particles.size();
  snap.x = read.array<Vec3>(n, "positions");
  snap.v = read.array<Vec3>(n, "velocities");
  snap.p = read.array<Vec3>(n, "predictions");
  snap.w = read.array<Real>(n, "inverse masses");
  for (std::uint32_t object = 0; object < s.objects.size(); ++object) {
    if (read.pod<std::uint8_t>() == 0) continue;
    const ObjectRecord& o = s.objects[object];
    const std::string what = "checkpoint: the torn mesh of '" + o.name + "'";
    if (!o.material.tear.enabled()) throw CheckpointError(what + ": it cannot tear");
    Snapshot::TornCloth& t = snap.torn.emplace_back();
    t.object = object;
    t.particleCount = read.pod<Index>();
    t.spareParticles = read.pod<Index>();
    const Index range = o.particleCount + o.tear.spareParticles;
    if (t.particleCount < o.particleCount || t.particleCount > range ||
        t.particleCount + t.spareParticles != range)
      throw CheckpointError(what + " has another particle count");
    t.triangles = read.cache<std::array<Index, 3>>(8 * std::size_t(range));
    t.origin = read.array<Index>(t.particleCount, "torn vertices");
    t.opened = read.array<std::uint8_t>(t.particleCount, "torn vertices");
    t.rest = read.array<Vec3>(t.particleCount, "torn vertices");
    for (const auto& triangle : t.triangles)
      for (Index v : triangle)
        if (v >= t.particleCount) throw CheckpointError(what + ": a vertex is out of range");
    for (Index v : t.origin)
      if (v >= o.particleCount) throw CheckpointError(what + ": an origin is out of range");
    for (const Vec3& r : t.rest)
      if (!r.allFinite()) throw CheckpointError(what + ": a rest position is not finite");
    try {
      t.complex = buildFromTriangles(t.particleCount, t.triangles);
    } catch (const MeshError& e) {
      throw CheckpointError(what + ": " + e.what());
    }
  }
  // A tearable cloth's timers are sized at its first step: a new world has none yet.
  for (std::uint32_t object = 0; object < s.objects.size(); ++object) {
    const ObjectRecord& o = s.objects[object];
    const auto torn = std::find_if(snap.torn.begin(), snap.torn.end(),
                                   [&](const auto& t) { return t.object == object; });
    const std::size_t edges =
        torn != snap.torn.end() ? torn->complex.edges.size() : o.complex.edges.size();
    snap.tearTimers.push_back(read.cache<double>(edges));
    if (!snap.tearTimers.back().empty() && snap.tearTimers.back().size() != edges)
      throw CheckpointError("checkpoint: tear timers for another mesh of '" + o.name + "'");
  }
  for (const KinematicTrack& track : s.kinematics.tracks) {
    Snapshot::Track& t = snap.tracks.emplace_back();
    t.pending = read.pod<std::uint8_t>();
    t.goal = read.array<Vec3>(track.goal.size(), "collider targets");
    t.stepStart = read.array<Vec3>(track.stepStart.size(), "collider targets");
  }
  snap.kinematicTargets = read.array<Vec3>(s.kinematics.target.size(), "kinematic targets");
  AttachmentPool& attachments = s.constraints.attachments;
  snap.broken = read.array<std::uint8_t>(attachments.broken.size(), "attachments");
  snap.removed = read.array<std::uint8_t>(attachments.removed.size(), "attachments");
  snap.attachmentLambda = read.array<double>(attachments.lambda.size(), "attachments");
  snap.brokenCount = read.pod<std::uint64_t>();
  PressurePool& pressure = s.constraints.pressure;
  snap.gas = read.array<double>(pressure.gas.size(), "pressured surfaces");
  snap.pressureLambda = read.array<double>(pressure.lambda.size(), "pressured surfaces");
  {
    CandidatePairs& pairs = snap.pairs;
    pairs.pathFrom = read.pod<int>(), pairs.pathTo = read.pod<int>();
    pairs.pathsHeld = read.pod<std::uint8_t>() != 0;
    pairs.boundSlack = read.pod<Real>(), pairs.frameSubstep = read.pod<int>();
    pairs.version = read.pod<std::uint64_t>();
    snap.contacts.boundVersion = read.pod<std::uint64_t>();
    snap.tablesDirty = read.pod<std::uint8_t>() != 0;
    // No cache holds more entries than this (a corrupt length fails here, not in an allocation).
    const std::size_t most = std::size_t{1} << 34;
    collisionCaches(pairs, snap.bvh, snap.contacts, pairs, snap.bvh, snap.contacts,
                    [&](auto& values, auto&) {
                      using T = typename std::decay_t<decltype(values)>::value_type;
                      values = read.cache<T>(most);
                    });
  }
  for (const Vec3& value : snap.x)
    if (!value.allFinite()) throw CheckpointError("checkpoint: a position is not finite");
  for (const Vec3& value : snap.v)
    if (!value.allFinite()) throw CheckpointError("checkpoint: a velocity is not finite");

  // Everything matched: apply it.
  s.time = snap.time;
  s.lastSubstep = snap.lastSubstep;
  s.stepCount = snap.stepCount;
  s.gravity = snap.gravity;
  s.impactHold = snap.impactHold;
  s.recoveries = snap.recoveries;
  s.tearReport = snap.tearReport;
  s.collisionReport = snap.collisionReport;
  s.particles.x = std::move(snap.x);
  s.particles.v = std::move(snap.v);
  s.particles.p = std::move(snap.p);
  s.particles.w = std::move(snap.w);
  for (Snapshot::TornCloth& t : snap.torn) {
    ObjectRecord& o = s.objects[t.object];
    o.particleCount = t.particleCount;
    o.tear.spareParticles = t.spareParticles;
    o.surface = std::move(t.triangles);
    o.complex = std::move(t.complex);
    o.closed = false;
    o.tear.origin = std::move(t.origin);
    o.tear.opened = std::move(t.opened);
    std::copy(t.rest.begin(), t.rest.end(), s.particles.restPosition.begin() + o.firstParticle);
    rebuildTornConstraints(o, t.object, s.particles, s.constraints);
    s.topologyDirty = true;
  }
  for (std::size_t o = 0; o < s.objects.size(); ++o)
    s.objects[o].tear.overTime = std::move(snap.tearTimers[o]);
  for (std::size_t t = 0; t < s.kinematics.tracks.size(); ++t) {
    KinematicTrack& track = s.kinematics.tracks[t];
    track.targetsPending = snap.tracks[t].pending != 0;
    track.goal = std::move(snap.tracks[t].goal);
    track.stepStart = std::move(snap.tracks[t].stepStart);
  }
  s.kinematics.target = std::move(snap.kinematicTargets);
  attachments.broken = std::move(snap.broken);
  attachments.removed = std::move(snap.removed);
  attachments.lambda = std::move(snap.attachmentLambda);
  attachments.brokenCount = snap.brokenCount;
  pressure.gas = std::move(snap.gas);
  pressure.lambda = std::move(snap.pressureLambda);
  // The collision caches, on the tables the first step would otherwise build (which would drop
  // the narrow phase's bounds), and trees made to bound the restored boxes.
  buildDerivedTablesIfDirty(s);
  CandidatePairs& pairs = s.candidates;
  pairs.pathFrom = snap.pairs.pathFrom, pairs.pathTo = snap.pairs.pathTo;
  pairs.pathsHeld = snap.pairs.pathsHeld, pairs.boundSlack = snap.pairs.boundSlack;
  pairs.frameSubstep = snap.pairs.frameSubstep, pairs.version = snap.pairs.version;
  s.primitiveContacts.boundVersion = snap.contacts.boundVersion;
  collisionCaches(pairs, s.bvh, s.primitiveContacts, snap.pairs, snap.bvh, snap.contacts,
                  [](auto& to, auto& from) { to = std::move(from); });
  s.bvh.commit();
  s.topologyDirty = snap.tablesDirty;
}

}  // namespace nucleon
