#include "systems/collision/broad_phase.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <mutex>
#include <tuple>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include "systems/collision/pair_distance_lanes.h"

namespace nucleon {
namespace {

// Embree rejects bounds beyond ±1.844e18 (FLT_LARGE); a box must stay inside to be stored.
constexpr double kMaxCoordinate = 1e18;
constexpr std::size_t kBoxGrain = 2048;
constexpr std::size_t kPairGrain = 4096;
constexpr auto kTriangleTree = static_cast<std::size_t>(BvhTree::Triangles);
constexpr auto kEdgeTree = static_cast<std::size_t>(BvhTree::Edges);
constexpr auto kIsolatedTree = static_cast<std::size_t>(BvhTree::IsolatedPoints);
constexpr auto kPointTree = static_cast<std::size_t>(BvhTree::Points);

// The float next to finite f toward +∞ (up) or −∞: std::nextafter's result, without its call
// (moving away from zero adds one to the magnitude's bits, moving toward it takes one off).
inline float nextFloat(float f, bool up) {
  if (f == 0)
    return up ? std::numeric_limits<float>::denorm_min()
              : -std::numeric_limits<float>::denorm_min();
  auto bits = std::bit_cast<std::uint32_t>(f);
  bits = (f > 0) == up ? bits + 1 : bits - 1;
  return std::bit_cast<float>(bits);
}

// The double box lower … upper grown by `grow`, rounded to the nearest float and then one float
// further out: the float box contains the double one whatever the rounding of the conversion and
// of the double arithmetic before it. Empty if a coordinate is not finite or beyond ±1e18.
PrimitiveBox outwardBox(const double (&lower)[3], const double (&upper)[3], double grow) {
  if (!(std::abs(grow) <= kMaxCoordinate)) return PrimitiveBox::empty();
  PrimitiveBox box;
  for (int k = 0; k < 3; ++k) {
    const double lo = lower[k] - grow, hi = upper[k] + grow;
    if (!(std::abs(lo) <= kMaxCoordinate && std::abs(hi) <= kMaxCoordinate))
      return PrimitiveBox::empty();
    box.lower[k] = nextFloat(static_cast<float>(lo), false);
    box.upper[k] = nextFloat(static_cast<float>(hi), true);
  }
  return box;
}

// The box a fraction t of the way from `a` to `b`, rounded outward to float.
PrimitiveBox boxBetween(const PrimitiveBox& a, const PrimitiveBox& b, double t) {
  if (a.isEmpty() || b.isEmpty()) return PrimitiveBox::empty();
  double lower[3], upper[3];
  for (int k = 0; k < 3; ++k) {
    lower[k] = (1 - t) * a.lower[k] + t * b.lower[k];
    upper[k] = (1 - t) * a.upper[k] + t * b.upper[k];
  }
  return outwardBox(lower, upper, 0);
}

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::span<const Index> pointParticles(const CollisionPrimitives& primitives, std::size_t i) {
  return {&primitives.pointParticle[i], 1};
}
std::span<const Index> edgeParticles(const CollisionPrimitives& primitives, std::size_t i) {
  return primitives.edgeParticles[i];
}
std::span<const Index> triangleParticles(const CollisionPrimitives& primitives, std::size_t i) {
  return primitives.triangleParticles[i];
}

// The box of two boxes; empty if either is (a primitive skipped at one end is skipped).
PrimitiveBox hullOf(const PrimitiveBox& a, const PrimitiveBox& b) {
  if (a.isEmpty() || b.isEmpty()) return PrimitiveBox::empty();
  PrimitiveBox box;
  for (int k = 0; k < 3; ++k) {
    box.lower[k] = std::min(a.lower[k], b.lower[k]);
    box.upper[k] = std::max(a.upper[k], b.upper[k]);
  }
  return box;
}

// A primitive's moving box over its particles' paths start → end: the box at each end, and the
// box of both, which its tree holds.
struct MovingBox {
  PrimitiveBox start, end, swept;
};
// The box of the particles' boxes centre ± reach (reach empty: zero), grown by `inflation`,
// rounded outward to float; empty as sweptBox.
PrimitiveBox reachBox(std::span<const Index> ids, std::span<const Vec3> centre,
                      std::span<const Vec3> reach, Real inflation) {
  if (reach.empty()) return sweptBox(ids, centre, centre, inflation);
  double lower[3] = {kMaxCoordinate, kMaxCoordinate, kMaxCoordinate};
  double upper[3] = {-kMaxCoordinate, -kMaxCoordinate, -kMaxCoordinate};
  for (Index i : ids)
    for (int k = 0; k < 3; ++k) {
      const double c = centre[i][k], r = reach[i][k];
      // Written so that a NaN fails the test too.
      if (!(std::abs(c) <= kMaxCoordinate && std::abs(r) <= kMaxCoordinate))
        return PrimitiveBox::empty();
      lower[k] = std::min(lower[k], c - r);
      upper[k] = std::max(upper[k], c + r);
    }
  return outwardBox(lower, upper, inflation);
}

MovingBox movingBoxOf(std::span<const Index> ids, std::span<const Vec3> start,
                      std::span<const Vec3> end, std::span<const Vec3> reach, Real inflation) {
  MovingBox box;
  box.start = reachBox(ids, start, reach, inflation);
  box.end = reachBox(ids, end, reach, inflation);
  box.swept = hullOf(box.start, box.end);
  return box;
}

// The moving box of each primitive of one kind into the tree's boxes; returns how many are empty.
template <class Particles>
std::size_t computeBoxes(PrimitiveBvh& bvh, BvhTree tree, std::size_t count,
                         const CollisionPrimitives& primitives, const std::vector<Real>& radius,
                         Particles particlesOf, std::span<const Vec3> x, std::span<const Vec3> p,
                         std::span<const Vec3> reach, Real margin) {
  const auto t = static_cast<std::size_t>(tree);
  bvh.boxes[t].resize(count);
  bvh.boxEnds[t].resize(count);
  // Integer sums: the same total for any partitioning.
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, count, kBoxGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t empty) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const MovingBox box =
              movingBoxOf(particlesOf(primitives, i), x, p, reach, radius[i] + margin / 2);
          bvh.boxes[t][i] = box.swept;
          bvh.boxEnds[t][i] = {box.start, box.end};
          empty += box.swept.isEmpty();
        }
        return empty;
      },
      std::plus<>());
}

// Each tree primitive's tag (components/primitive_bvh.h): its object, and whether one of its
// particles can move; and the excluded object pairs tabulated, so that the traversals pass over
// subtrees that hold no pair the filters below would keep. Called before each commit.
constexpr std::size_t kPrunableShare = 16;
void computeTags(PrimitiveBvh& bvh, const CollisionPrimitives& primitives,
                 std::span<const Real> w) {
  bvh.setExclusions(primitives.excludedPairs);
  // Where few points are fixed or of an object named in an exclusion (pins, a small collider
  // mesh that does not collide with itself), passing over subtrees would save less than the tag
  // lookups cost: no tags, and the traversals prune nothing.
  const std::size_t prunable = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, primitives.points(), kBoxGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t count) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
          count += w[primitives.pointParticle[i]] == 0 ||
                   bvh.exclusions.names(primitives.pointObject[i]);
        return count;
      },
      std::plus<>());
  if (prunable * kPrunableShare < primitives.points()) {
    for (std::vector<std::uint32_t>& tags : bvh.tags) tags.clear();
    return;
  }
  const auto tagTree = [&](std::size_t tree, const std::vector<std::uint32_t>& object,
                           auto particlesOf, const Index* map) {
    std::vector<std::uint32_t>& tags = bvh.tags[tree];
    tags.resize(bvh.boxes[tree].size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tags.size(), kBoxGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t k = r.begin(); k != r.end(); ++k) {
                          const std::size_t i = map ? map[k] : k;
                          bool free = false;
                          for (const Index particle : particlesOf(primitives, i))
                            free |= w[particle] != 0;
                          tags[k] = primitiveTag(object[i], free);
                        }
                      });
  };
  tagTree(kTriangleTree, primitives.triangleObject, triangleParticles, nullptr);
  tagTree(kEdgeTree, primitives.edgeObject, edgeParticles, nullptr);
  tagTree(kPointTree, primitives.pointObject, pointParticles, nullptr);
  tagTree(kIsolatedTree, primitives.pointObject, pointParticles, bvh.isolatedPoints.data());
}

// Pair lists per thread: one for each thread of the arena (by its index in it), and a last one,
// shared under a lock, for a thread outside the arena (a caller that runs a traversal on threads
// of its own).
struct ThreadPairs {
  std::vector<std::vector<std::uint64_t>>* lists;
  std::mutex* overflowLock;

  void append(const std::uint64_t* keys, std::size_t count) const {
    if (count == 0) return;
    const int slot = tbb::this_task_arena::current_thread_index();
    if (slot >= 0 && static_cast<std::size_t>(slot) + 1 < lists->size()) {
      (*lists)[static_cast<std::size_t>(slot)].insert(
          (*lists)[static_cast<std::size_t>(slot)].end(), keys, keys + count);
      return;
    }
    const std::lock_guard<std::mutex> lock(*overflowLock);
    lists->back().insert(lists->back().end(), keys, keys + count);
  }
};

// Sized for the current arena's threads plus the shared list, emptied.
void prepareThreadPairs(std::vector<std::vector<std::uint64_t>>& lists) {
  lists.resize(std::max<std::size_t>(
      lists.size(), static_cast<std::size_t>(tbb::this_task_arena::max_concurrency()) + 1));
  for (std::vector<std::uint64_t>& list : lists) list.clear();
}

// What the pair callbacks need to filter a pair and keep it. The traversal reports pairs in
// batches of up to a few hundred, so each arena thread gathers the pairs it keeps in a staging
// buffer of its own and moves them to its list a few thousand at a time (flushStaging).
struct PairFilter {
  const CollisionPrimitives* primitives;
  const Real* w;
  const Index* isolatedPoints;  // tree primitive → point, for the IsolatedPoints tree
  ThreadPairs found;
  std::vector<PrimitiveBvh::StagedPairs>* staging;  // per arena thread, as found.lists
  // The two trees' moving boxes, by tree primitive.
  const BoxEnds *endsA, *endsB;
  // The particles' straight paths, for the distance filter (ReachLanes).
  const Vec3 *x, *p;
  Real margin;
};

constexpr std::size_t kStagedPairs = 4096;

// Sized like the thread lists, emptied, each with room for kStagedPairs.
void prepareStaging(std::vector<PrimitiveBvh::StagedPairs>& staging, std::size_t slots) {
  staging.resize(std::max(staging.size(), slots));
  for (PrimitiveBvh::StagedPairs& stage : staging)
    stage.keys.clear(), stage.keys.reserve(kStagedPairs);
}

// Moves every staged pair to its thread's list.
void flushStaging(std::vector<PrimitiveBvh::StagedPairs>& staging,
                  std::vector<std::vector<std::uint64_t>>& lists) {
  for (std::size_t slot = 0; slot < staging.size() && slot < lists.size(); ++slot) {
    std::vector<std::uint64_t>& keys = staging[slot].keys;
    lists[slot].insert(lists[slot].end(), keys.begin(), keys.end());
    keys.clear();
  }
}

std::span<const Index> particlesOf(const CollisionPrimitives& prims, PairKind kind, bool first,
                                   Index i) {
  const bool point = first ? kind != PairKind::EdgeEdge : kind == PairKind::VertexVertex;
  if (point) return {&prims.pointParticle[i], 1};
  if (!first && kind == PairKind::VertexFace) return prims.triangleParticles[i];
  return prims.edgeParticles[i];
}

std::uint32_t objectOf(const CollisionPrimitives& prims, PairKind kind, bool first, Index i) {
  const bool point = first ? kind != PairKind::EdgeEdge : kind == PairKind::VertexVertex;
  if (point) return prims.pointObject[i];
  if (!first && kind == PairKind::VertexFace) return prims.triangleObject[i];
  return prims.edgeObject[i];
}

// Whether two primitives whose boxes overlap, the pair (first, second) of `kind` in the indices of
// components/candidate_pairs.h, are a pair: they share no particle, one of them can move, and
// their objects collide.
[[gnu::always_inline]] inline bool admissible(const CollisionPrimitives& prims, const Real* w,
                                              PairKind kind, Index first, Index second) {
  const std::span<const Index> particlesA = particlesOf(prims, kind, true, first),
                               particlesB = particlesOf(prims, kind, false, second);
  bool shared = false, free = false;
  for (Index i : particlesA) {
    for (Index j : particlesB) shared |= i == j;
    free |= w[i] != 0;
  }
  if (shared) return false;
  for (Index j : particlesB) free |= w[j] != 0;
  if (!free) return false;
  if (!prims.particleSets.empty() && prims.setsExcluded(particlesA, particlesB)) return false;
  return prims.excludedPairs.empty() ||
         !prims.excluded(objectOf(prims, kind, true, first), objectOf(prims, kind, false, second));
}

// admissible for a kind known when compiled: the same tests with the particle counts fixed, so
// that the full search's callbacks compare and load without loops.
template <PairKind kKind>
[[gnu::always_inline]] inline bool admissibleOf(const CollisionPrimitives& prims, const Real* w,
                                                Index first, Index second) {
  if constexpr (kKind == PairKind::VertexFace) {
    const Index i = prims.pointParticle[first];
    const auto& t = prims.triangleParticles[second];
    if (i == t[0] || i == t[1] || i == t[2]) return false;
    if (w[i] == 0 && w[t[0]] == 0 && w[t[1]] == 0 && w[t[2]] == 0) return false;
  } else if constexpr (kKind == PairKind::EdgeEdge) {
    const auto& e = prims.edgeParticles[first];
    const auto& f = prims.edgeParticles[second];
    if (e[0] == f[0] || e[0] == f[1] || e[1] == f[0] || e[1] == f[1]) return false;
    if (w[e[0]] == 0 && w[e[1]] == 0 && w[f[0]] == 0 && w[f[1]] == 0) return false;
  } else {
    return admissible(prims, w, kKind, first, second);
  }
  if (!prims.particleSets.empty() && prims.setsExcluded(particlesOf(prims, kKind, true, first),
                                                        particlesOf(prims, kKind, false, second)))
    return false;
  return prims.excludedPairs.empty() || !prims.excluded(objectOf(prims, kKind, true, first),
                                                        objectOf(prims, kKind, false, second));
}

// The distance filter after the moving boxes. A vertex–face or edge–edge pair whose particles
// move on straight paths, and whose distance, by the float lanes' bounds less their stated error
// (pair_distance_lanes.h), stays beyond its reach r_a + r_b + margin over the whole motion, is no
// pair: like two primitives whose moving boxes never meet, it stays at least that far apart along
// the paths, so its primitives cannot cross while their particles stay within the slack of their
// paths (boundSlack). Like them, it may come nearer than its reach by what its particles stray
// from their paths; its contact then waits for the next broad phase. The boxes are loose around a
// cloth's diagonal edges and triangles: where the thickness is near the edge length, most
// neighbours two rings apart overlap in their boxes and are farther apart than their reach.
bool staysOutOfReach(const PairLaneBounds& b, int lane, double reach) {
  const double error = double(kPairLaneTolerance) * double(b.extent[lane]);
  const double start = double(b.startDistance[lane]) - error,
               end = double(b.endDistance[lane]) - error, motion = double(b.motion[lane]) + error;
  // Along straight paths the distance is at least max(d0 − t M, d1 − (1 − t) M), whose least
  // value over the motion is (d0 + d1 − M) / 2 (as the narrow phase's bound). Comparisons with a
  // NaN are false: such a pair is kept.
  if (!(start > 0) || !(end > 0)) return false;
  return std::max(start - motion, (start + end - motion) / 2) > reach;
}

// Pairs of one kind gathered kPairLanes at a time for staysOutOfReach.
template <PairKind kKind>
struct ReachLanes {
  static_assert(kKind == PairKind::VertexFace || kKind == PairKind::EdgeEdge);
  PairLanes lanes{};  // unused lanes stay finite
  PairLaneBounds bounds;
  std::uint64_t key[kPairLanes];
  double reach[kPairLanes];
  int used = 0;

  static std::array<Index, 4> particlesOf(const CollisionPrimitives& prims, Index first,
                                          Index second) {
    if constexpr (kKind == PairKind::VertexFace) {
      const auto& t = prims.triangleParticles[second];
      return {prims.pointParticle[first], t[0], t[1], t[2]};
    } else {
      const auto& e = prims.edgeParticles[first];
      const auto& f = prims.edgeParticles[second];
      return {e[0], e[1], f[0], f[1]};
    }
  }
  static Real radiusOf(const CollisionPrimitives& prims, Index first, Index second) {
    if constexpr (kKind == PairKind::VertexFace)
      return prims.pointRadius[first] + prims.triangleRadius[second];
    else
      return prims.edgeRadius[first] + prims.edgeRadius[second];
  }

  // Adds pair (first, second), its particles moving from x to p; true when the lanes are full.
  bool add(const CollisionPrimitives& prims, const Vec3* x, const Vec3* p, Real margin, Index first,
           Index second) {
    const std::array<Index, 4> id = particlesOf(prims, first, second);
    const Vec3 x0 = x[id[0]], p0 = p[id[0]];
    for (int k = 1; k < 4; ++k) {
      const Vec3 start = x[id[k]] - x0, end = p[id[k]] - p0;
      for (int axis = 0; axis < 3; ++axis) {
        lanes.start[k][axis][used] = static_cast<float>(start[axis]);
        lanes.end[k][axis][used] = static_cast<float>(end[axis]);
      }
    }
    key[used] = std::uint64_t{first} << 32 | second;
    reach[used] = double(radiusOf(prims, first, second)) + double(margin);
    return ++used == kPairLanes;
  }

  // Calls keep(key) for every pair added that may come within reach, and empties the lanes.
  template <class Keep>
  void flush(Keep&& keep) {
    if (used == 0) return;
    if constexpr (kKind == PairKind::VertexFace)
      vertexFaceLaneBounds(lanes, bounds);
    else
      edgeEdgeLaneBounds(lanes, bounds);
    for (int lane = 0; lane < used; ++lane)
      if (!staysOutOfReach(bounds, lane, reach[lane])) keep(key[lane]);
    used = 0;
  }
};

// Whether pair (first, second) of `kind`, its particles moving on straight paths from x to p,
// stays out of reach over the motion (ReachLanes, one pair). Vertex–edge and vertex–vertex pairs
// (isolated points, few) are not filtered.
bool pairStaysOutOfReach(PairKind kind, const CollisionPrimitives& prims, const Vec3* x,
                         const Vec3* p, Real margin, Index first, Index second) {
  bool out = true;
  const auto keep = [&](std::uint64_t) { out = false; };
  if (kind == PairKind::VertexFace) {
    ReachLanes<PairKind::VertexFace> lanes;
    lanes.add(prims, x, p, margin, first, second);
    lanes.flush(keep);
  } else if (kind == PairKind::EdgeEdge) {
    ReachLanes<PairKind::EdgeEdge> lanes;
    lanes.add(prims, x, p, margin, first, second);
    lanes.flush(keep);
  } else {
    return false;
  }
  return out;
}

// The filters every pair of overlapping boxes goes through, in the order of their cost; a pair
// kept is stored as first << 32 | second in the running thread's list.
template <PairKind kKind>
void keepPairs(void* raw, const Index* a, const Index* b, std::size_t count) {
  const PairFilter& f = *static_cast<const PairFilter*>(raw);
  const CollisionPrimitives& prims = *f.primitives;
  const int slot = tbb::this_task_arena::current_thread_index();
  const bool staged = slot >= 0 && static_cast<std::size_t>(slot) + 1 < f.found.lists->size();
  // A thread outside the arena keeps its pairs in a batch of its own, appended under the lock.
  constexpr std::size_t kBatch = 256;
  std::uint64_t kept[kBatch];
  std::size_t keptCount = 0;
  const auto store = [&](std::uint64_t key) {
    if (staged) {
      std::vector<std::uint64_t>& stage = (*f.staging)[static_cast<std::size_t>(slot)].keys;
      stage.push_back(key);
      if (stage.size() == kStagedPairs) {
        std::vector<std::uint64_t>& list = (*f.found.lists)[static_cast<std::size_t>(slot)];
        list.insert(list.end(), stage.begin(), stage.end());
        stage.clear();
      }
      return;
    }
    kept[keptCount++] = key;
    if (keptCount == kBatch) f.found.append(kept, keptCount), keptCount = 0;
  };
  constexpr bool kMeasured = kKind == PairKind::VertexFace || kKind == PairKind::EdgeEdge;
  using Lanes = ReachLanes<kMeasured ? kKind : PairKind::VertexFace>;
  Lanes lanes;
  for (std::size_t k = 0; k < count; ++k) {
    Index first = a[k], second = b[k];
    // The IsolatedPoints tree's primitives map to points; they ascend, so first < second holds.
    if constexpr (kKind == PairKind::VertexEdge || kKind == PairKind::VertexVertex)
      first = f.isolatedPoints[first];
    if constexpr (kKind == PairKind::VertexVertex) second = f.isolatedPoints[second];
    // Neighbours that share a particle, a third of the overlaps on a cloth, always meet: the
    // cheaper test first.
    if (!admissibleOf<kKind>(prims, f.w, first, second)) continue;
    if (!meetInMotion(f.endsA[a[k]], f.endsB[b[k]])) continue;
    if constexpr (kMeasured) {
      if (lanes.add(prims, f.x, f.p, f.margin, first, second)) lanes.flush(store);
    } else {
      store(std::uint64_t{first} << 32 | second);
    }
  }
  if constexpr (kMeasured) lanes.flush(store);
  f.found.append(kept, keptCount);
}

// Appends the pairs the threads found, of one kind whose first index is below `firsts`, to `out`
// sorted by (first, second): a counting sort by first index, each thread's list counted and
// scattered by one task into places of its own (no atomics: the lists' pairs of one first index
// follow one another in list order), then each first index's few partners sorted, so that the
// result does not depend on which thread found which pair. Returns how many were appended.
std::size_t appendInOrder(CandidatePairs& out, PrimitiveBvh& bvh, PairKind kind,
                          std::size_t firsts) {
  const std::size_t lists = bvh.threadPairs.size(), stride = firsts + 1;
  // listPlace[l × stride + f]: first the count of list l's pairs with first index f, then where
  // the next of them goes.
  bvh.listPlace.assign(lists * stride, 0);
  tbb::parallel_for(std::size_t{0}, lists, [&](std::size_t l) {
    Index* count = bvh.listPlace.data() + l * stride;
    for (const std::uint64_t key : bvh.threadPairs[l]) ++count[key >> 32];
  });
  // Each first index's total, a prefix sum over the first indices, then each list's place within
  // its first index's run: the serial work is one pass over the first indices for any thread
  // count.
  bvh.pairOffset.assign(firsts + 1, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, firsts, kBoxGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t f = r.begin(); f != r.end(); ++f) {
                        Index total = 0;
                        for (std::size_t l = 0; l < lists; ++l)
                          total += bvh.listPlace[l * stride + f];
                        bvh.pairOffset[f + 1] = total;
                      }
                    });
  for (std::size_t f = 0; f < firsts; ++f) bvh.pairOffset[f + 1] += bvh.pairOffset[f];
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, firsts, kBoxGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t f = r.begin(); f != r.end(); ++f) {
                        Index running = bvh.pairOffset[f];
                        for (std::size_t l = 0; l < lists; ++l) {
                          Index& place = bvh.listPlace[l * stride + f];
                          const Index count = place;
                          place = running;
                          running += count;
                        }
                      }
                    });
  const std::size_t base = out.size();
  const std::size_t added = bvh.pairOffset[firsts];
  out.kind.resize(base + added, kind);
  out.first.resize(base + added);
  out.second.resize(base + added);
  tbb::parallel_for(std::size_t{0}, lists, [&](std::size_t l) {
    Index* place = bvh.listPlace.data() + l * stride;
    for (const std::uint64_t key : bvh.threadPairs[l])
      out.second[base + place[key >> 32]++] = static_cast<Index>(key & 0xffffffffu);
    bvh.threadPairs[l].clear();
  });
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, firsts, kBoxGrain),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const std::size_t begin = base + bvh.pairOffset[i], end = base + bvh.pairOffset[i + 1];
          std::sort(out.second.begin() + begin, out.second.begin() + end);
          std::fill(out.first.begin() + begin, out.first.begin() + end, static_cast<Index>(i));
        }
      });
  return added;
}

// The first index in [low, high) whose key is not below `key`, for keys ascending in the index.
template <class KeyOf, class Key>
std::size_t firstNotBelow(const KeyOf& keyOf, std::size_t low, std::size_t high, const Key& key) {
  while (low < high) {
    const std::size_t middle = low + (high - low) / 2;
    if (keyOf(middle) < key)
      low = middle + 1;
    else
      high = middle;
  }
  return low;
}

// formerIndex of a full broad phase: both sets are sorted by (kind, first, second), so each
// chunk of the new pairs finds where it starts among the former ones by bisection and then
// merges along them.
void matchFormerPairs(CandidatePairs& pairs) {
  const std::size_t n = pairs.size(), former = pairs.formerKind.size();
  pairs.formerIndex.resize(n);
  const auto formerKey = [&](std::size_t j) {
    return std::tuple(pairs.formerKind[j], pairs.formerFirst[j], pairs.formerSecond[j]);
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPairGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      const auto first = std::tuple(pairs.kind[r.begin()], pairs.first[r.begin()],
                                                    pairs.second[r.begin()]);
                      std::size_t j = firstNotBelow(formerKey, 0, former, first);
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        const auto key = std::tuple(pairs.kind[i], pairs.first[i], pairs.second[i]);
                        while (j < former && formerKey(j) < key) ++j;
                        pairs.formerIndex[i] = j < former && formerKey(j) == key
                                                   ? static_cast<Index>(j)
                                                   : CandidatePairs::kNewPair;
                      }
                    });
}

// Sorts pair keys first << 32 | second (first below `firsts`) and drops repeats: a counting sort
// on the first index, then each first index's few partners sorted in place. Linear in the keys
// and the first indices; `offset` and `scratch` keep their capacity between calls.
void sortUniqueByFirst(std::vector<std::uint64_t>& keys, std::size_t firsts,
                       std::vector<Index>& offset, std::vector<std::uint64_t>& scratch) {
  if (keys.size() < 2) return;
  offset.assign(firsts + 1, 0);
  for (const std::uint64_t key : keys) ++offset[(key >> 32) + 1];
  for (std::size_t f = 0; f < firsts; ++f) offset[f + 1] += offset[f];
  scratch.resize(keys.size());
  for (const std::uint64_t key : keys) scratch[offset[key >> 32]++] = key;
  // offset[f] is now where first index f's run ends.
  std::size_t out = 0, begin = 0;
  for (std::size_t f = 0; f < firsts; ++f) {
    const std::size_t end = offset[f];
    if (end - begin > 1) std::sort(scratch.begin() + begin, scratch.begin() + end);
    for (std::size_t k = begin; k < end; ++k)
      if (out == 0 || scratch[k] != keys[out - 1]) keys[out++] = scratch[k];
    begin = end;
  }
  keys.resize(out);
}

}  // namespace

PrimitiveBox sweptBox(std::span<const Index> particles, std::span<const Vec3> x,
                      std::span<const Vec3> p, Real inflation) {
  double lower[3] = {kMaxCoordinate, kMaxCoordinate, kMaxCoordinate};
  double upper[3] = {-kMaxCoordinate, -kMaxCoordinate, -kMaxCoordinate};
  for (Index i : particles)
    for (const Vec3* position : {&x[i], &p[i]})
      for (int k = 0; k < 3; ++k) {
        const double v = (*position)[k];
        // Written so that a NaN fails the test too.
        if (!(std::abs(v) <= kMaxCoordinate)) return PrimitiveBox::empty();
        lower[k] = std::min(lower[k], v);
        upper[k] = std::max(upper[k], v);
      }
  return outwardBox(lower, upper, inflation);
}

BroadPhaseStats findCandidatePairs(CandidatePairs& out, PrimitiveBvh& bvh,
                                   const CollisionPrimitives& primitives, std::span<const Vec3> x,
                                   std::span<const Vec3> p, std::span<const Real> w, Real margin) {
  BroadPhaseStats stats;
  const std::size_t points = primitives.points(), edges = primitives.edges(),
                    triangles = primitives.triangles();
  // Boxes.
  Clock::time_point start = Clock::now();
  stats.skippedPrimitives =
      computeBoxes(bvh, BvhTree::Points, points, primitives, primitives.pointRadius, pointParticles,
                   x, p, {}, margin) +
      computeBoxes(bvh, BvhTree::Edges, edges, primitives, primitives.edgeRadius, edgeParticles, x,
                   p, {}, margin) +
      computeBoxes(bvh, BvhTree::Triangles, triangles, primitives, primitives.triangleRadius,
                   triangleParticles, x, p, {}, margin);
  bvh.isolatedPoints.clear();
  for (std::size_t i = 0; i < points; ++i)
    if (primitives.pointIsolated[i]) bvh.isolatedPoints.push_back(static_cast<Index>(i));
  bvh.boxes[kIsolatedTree].resize(bvh.isolatedPoints.size());
  bvh.boxEnds[kIsolatedTree].resize(bvh.isolatedPoints.size());
  for (std::size_t k = 0; k < bvh.isolatedPoints.size(); ++k) {
    bvh.boxes[kIsolatedTree][k] = bvh.boxes[kPointTree][bvh.isolatedPoints[k]];
    bvh.boxEnds[kIsolatedTree][k] = bvh.boxEnds[kPointTree][bvh.isolatedPoints[k]];
  }
  // Every point's box is needed only against triangles.
  if (triangles == 0) bvh.boxes[kPointTree].clear(), bvh.boxEnds[kPointTree].clear();
  stats.boxSeconds = secondsSince(start);

  // Trees.
  start = Clock::now();
  computeTags(bvh, primitives, w);
  stats.rebuilt = bvh.commit();
  stats.commitSeconds = secondsSince(start);

  // Pairs, kind by kind, each found by one dual-tree traversal and then put in order.
  start = Clock::now();
  out.formerKind.swap(out.kind);
  out.formerFirst.swap(out.first);
  out.formerSecond.swap(out.second);
  out.clear();
  prepareThreadPairs(bvh.threadPairs);
  std::mutex overflowLock;
  prepareStaging(bvh.threadStaging, bvh.threadPairs.size());
  PairFilter filter{&primitives,
                    w.data(),
                    bvh.isolatedPoints.data(),
                    ThreadPairs{&bvh.threadPairs, &overflowLock},
                    &bvh.threadStaging,
                    nullptr,
                    nullptr,
                    x.data(),
                    p.data(),
                    margin};
  struct Traversal {
    PairKind kind;
    BvhTree a, b;
    PrimitiveBvh::PairVisitor keep;
  };
  constexpr std::array<Traversal, 4> traversals = {{
      {PairKind::VertexFace, BvhTree::Points, BvhTree::Triangles, &keepPairs<PairKind::VertexFace>},
      {PairKind::EdgeEdge, BvhTree::Edges, BvhTree::Edges, &keepPairs<PairKind::EdgeEdge>},
      {PairKind::VertexEdge, BvhTree::IsolatedPoints, BvhTree::Edges,
       &keepPairs<PairKind::VertexEdge>},
      {PairKind::VertexVertex, BvhTree::IsolatedPoints, BvhTree::IsolatedPoints,
       &keepPairs<PairKind::VertexVertex>},
  }};
  for (const Traversal& t : traversals) {
    filter.endsA = bvh.boxEnds[static_cast<std::size_t>(t.a)].data();
    filter.endsB = bvh.boxEnds[static_cast<std::size_t>(t.b)].data();
    bvh.forEachOverlappingPair(t.a, t.b, t.keep, &filter);
    flushStaging(bvh.threadStaging, bvh.threadPairs);
    const std::size_t firsts = t.kind == PairKind::EdgeEdge ? edges : points;
    stats.pairs[static_cast<std::size_t>(t.kind)] = appendInOrder(out, bvh, t.kind, firsts);
  }
  matchFormerPairs(out);
  stats.querySeconds = secondsSince(start);
  return stats;
}

void predictMotionEnd(std::vector<Vec3>& end, std::span<const Vec3> x, std::span<const Vec3> p,
                      std::span<const Real> w, const Vec3& g, Real h, int remaining) {
  end.resize(x.size());
  const Real steps = static_cast<Real>(remaining);
  const Vec3 fall = (steps * (steps - 1) / 2 * h * h) * g;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, x.size(), kBoxGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        end[i] = x[i] + steps * (p[i] - x[i]);
                        if (w[i] > 0) end[i] += fall;
                      }
                    });
}

void setMotionFrame(CandidatePairs& pairs, std::span<const Vec3> x, std::span<const Vec3> p,
                    std::span<const Real> w, const Vec3& g, Real h, int substep, int substeps,
                    const Vec3& base) {
  // The per-axis median of the free particles' finite motions: an nth_element over a copy, the
  // same whatever the thread count.
  Vec3 median = Vec3::Zero();
  std::vector<Real>& values = pairs.frameScratch;
  for (int axis = 0; axis < 3; ++axis) {
    values.clear();
    for (std::size_t i = 0; i < x.size(); ++i) {
      const Real u = p[i][axis] - x[i][axis];
      if (w[i] != 0 && std::isfinite(u)) values.push_back(u);
    }
    if (values.empty()) break;
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    median[axis] = *middle;
  }
  pairs.frameOrigin.assign(static_cast<std::size_t>(std::max(substeps, substep + 1)) + 1, base);
  for (std::size_t k = static_cast<std::size_t>(substep) + 1; k < pairs.frameOrigin.size(); ++k) {
    const Real j = static_cast<Real>(k - static_cast<std::size_t>(substep));
    pairs.frameOrigin[k] = base + (j * median + (j * (j - 1) / 2 * h * h) * g);
  }
  pairs.frameSubstep = substep;
}

namespace {

// Particle i's held path: the middle of the box of a → b, and the box's half extents.
void holdPath(CandidatePairs& pairs, std::size_t i, const Vec3& a, const Vec3& b) {
  const Vec3 lower = a.cwiseMin(b), upper = a.cwiseMax(b);
  pairs.pathStart[i] = pairs.pathEnd[i] = (lower + upper) / 2;
  // Rounded up so that the box around the middle holds both ends.
  pairs.pathReach[i] = ((upper - lower) / 2)
                           .cwiseMax(upper - pairs.pathStart[i])
                           .cwiseMax(pairs.pathStart[i] - lower);
  pairs.motionLower[i] = lower, pairs.motionUpper[i] = upper;
}

}  // namespace

void setMotionBounds(CandidatePairs& pairs, std::span<const Vec3> start, std::span<const Vec3> end,
                     const Vec3& startOffset, const Vec3& endOffset, int from, int to,
                     Real stretch) {
  const std::size_t n = start.size();
  pairs.pathStart.resize(n);
  pairs.pathEnd.resize(n);
  pairs.pathReach.assign(n, Vec3::Zero());
  pairs.motionLower.resize(n);
  pairs.motionUpper.resize(n);
  pairs.pathFrom = from;
  pairs.pathTo = to;
  pairs.pathsHeld = false;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kBoxGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        const Vec3 a = start[i] - startOffset;
                        const Vec3 b = a + stretch * (end[i] - endOffset - a);
                        pairs.pathStart[i] = a, pairs.pathEnd[i] = b;
                        pairs.motionLower[i] = a.cwiseMin(b);
                        pairs.motionUpper[i] = a.cwiseMax(b);
                      }
                    });
}

Real boundSlack(const CollisionPrimitives& primitives, Real margin) {
  return kBoundSlackFraction * (2 * primitives.smallestRadius + margin);
}

void growParticleBounds(CandidatePairs& pairs, Real slack) {
  pairs.boundSlack = slack;
}

namespace {

// Particle i's bounds at substep boundary k, in the frame.
void boundsAt(const CandidatePairs& pairs, std::size_t i, int boundary, Vec3& lower, Vec3& upper) {
  const Vec3 centre = pairs.pathPoint(i, boundary);
  const Vec3 reach = pairs.pathReach[i].array() + pairs.boundSlack;
  lower = centre - reach;
  upper = centre + reach;
}

// Whether `position`, at substep boundary k where the frame is offset by `offset`, is outside
// particle i's bounds. Written so that a non-finite coordinate does not count as outside.
bool outsideBounds(const CandidatePairs& pairs, const Vec3& position, const Vec3& offset,
                   int boundary, std::size_t i) {
  Vec3 lower, upper;
  boundsAt(pairs, i, boundary, lower, upper);
  const Vec3 inFrame = position - offset;
  return (inFrame.array() < lower.array()).any() || (inFrame.array() > upper.array()).any();
}

bool hasBounds(const CandidatePairs& pairs, std::size_t n) {
  return pairs.pathStart.size() == n && pairs.pathEnd.size() == n && pairs.pathReach.size() == n;
}

}  // namespace

std::size_t countOutsideParticleBounds(const CandidatePairs& pairs, std::span<const Vec3> p) {
  if (!hasBounds(pairs, p.size())) return p.size();
  const Vec3 offset = pairs.endOffset();
  const int boundary = pairs.frameSubstep + 1;
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, p.size(), kBoxGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t count) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
          count += outsideBounds(pairs, p[i], offset, boundary, i);
        return count;
      },
      std::plus<>());
}

bool withinParticleBounds(const CandidatePairs& pairs, std::span<const Vec3> p) {
  return hasBounds(pairs, p.size()) && countOutsideParticleBounds(pairs, p) == 0;
}

bool carryPairsIntoStep(CandidatePairs& pairs, PrimitiveBvh& bvh, std::span<const Vec3> x,
                        std::span<const Vec3> p, std::span<const Real> w, const Vec3& g, Real h,
                        int substeps, Real slack, std::size_t& outside) {
  outside = 0;
  const std::size_t n = x.size();
  if (!hasBounds(pairs, n) || pairs.motionLower.size() != n || n == 0) return false;
  // The frame goes on from where the last step's ended, with this step's median motion.
  const Vec3 held = pairs.frameOrigin.empty() ? Vec3::Zero() : pairs.frameOrigin.back();
  const int ended = pairs.pathTo;
  setMotionFrame(pairs, x, p, w, g, h, 0, std::max(substeps, 1), held);
  const Vec3 common = pairs.frameAt(1) - held;
  struct Tally {
    std::size_t outside = 0;
    double bounds = 0, needed = 0;
  };
  // Summed in fixed chunks, in order: the same decision whatever the thread count.
  const Tally tally = tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, n, kBoxGrain), Tally{},
      [&](const tbb::blocked_range<std::size_t>& r, Tally sum) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          // Held at the end of the last step's path.
          sum.outside += outsideBounds(pairs, x[i], held, ended, i);
          const Vec3 motion = (p[i] - x[i] - common).cwiseAbs() * static_cast<Real>(substeps);
          if (!motion.allFinite()) continue;  // left to the search and the update's repair
          sum.bounds += double((pairs.motionUpper[i] - pairs.motionLower[i]).sum()) + 6 * slack;
          sum.needed += double(motion.sum()) + 6 * double(slack);
        }
        return sum;
      },
      [](Tally a, const Tally& b) {
        a.outside += b.outside, a.bounds += b.bounds, a.needed += b.needed;
        return a;
      });
  // A few particles outside are found again by the caller's extension (it checks the start of
  // the motion too); many are a new search's.
  if (tally.outside * kExtendShare > n || tally.bounds > double(kLooseBounds) * tally.needed)
    return false;
  // The set holds over the rest of the last path's window and, each path held at its end, for
  // ever after: the paths become points at their ends, the primitives' boxes their end boxes.
  pairs.pathFrom = 0;
  pairs.pathTo = std::max(substeps, 1);
  pairs.boundSlack = slack;
  if (!pairs.pathsHeld) {
    pairs.pathStart = pairs.pathEnd;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kBoxGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i) {
                          pairs.motionLower[i] = pairs.pathEnd[i] - pairs.pathReach[i];
                          pairs.motionUpper[i] = pairs.pathEnd[i] + pairs.pathReach[i];
                        }
                      });
    for (std::size_t tree = 0; tree < kBvhTreeCount; ++tree)
      for (BoxEnds& ends : bvh.boxEnds[tree]) ends.start = ends.end;
    pairs.pathsHeld = true;
  }
  outside = tally.outside;
  return true;
}

Vec3 clampIntoBounds(const CandidatePairs& pairs, std::size_t i, const Vec3& p) {
  const Vec3 offset = pairs.endOffset();
  const int boundary = pairs.frameSubstep + 1;
  if (!outsideBounds(pairs, p, offset, boundary, i)) return p;
  Vec3 lower, upper;
  boundsAt(pairs, i, boundary, lower, upper);
  Vec3 inside = (p - offset).cwiseMax(lower).cwiseMin(upper) + offset;
  // Adding the offset back rounds: a coordinate that lands a float step outside is stepped in.
  constexpr Real kInfinite = std::numeric_limits<Real>::infinity();
  for (int k = 0; k < 3; ++k)
    for (int step = 0; step < 8; ++step) {
      const Real inFrame = inside[k] - offset[k];
      if (inFrame < lower[k])
        inside[k] = std::nextafter(inside[k], kInfinite);
      else if (inFrame > upper[k])
        inside[k] = std::nextafter(inside[k], -kInfinite);
      else
        break;
    }
  return inside;
}

namespace {

// One query of the incremental re-detection: a changed primitive (`self`) against a tree, each
// partner the tree reports made a pair (first, second) of the visitor's kind (keepExtension) and
// kept if admissible.
struct ExtensionQuery {
  const CollisionPrimitives* primitives;
  const Real* w;
  const Index* isolatedPoints;
  ThreadPairs found;
  std::array<std::uint64_t, 256> kept;  // pairs kept, appended to `found` when full and at the end
  std::size_t keptCount;
  Index self;
  bool selfFirst;        // the query primitive is the pair's first
  bool partnerIsolated;  // the tree is IsolatedPoints: its primitives map to points
  // The query primitive's moving box, and the tree's by tree primitive.
  BoxEnds selfEnds;
  const BoxEnds* partners;
  double since;  // the part of the window the pairs are for: from the extension's start on
  // A pair of two changed primitives is found by the queries of both: one of them keeps it. Per
  // partner primitive (after the isolated points' mapping): whether it is changed; `lowerKeeps`:
  // the two are of one list and the lower index keeps it, else the partner's own query does.
  const std::uint8_t* partnerChanged;
  bool lowerKeeps;
  // The particles' paths over the whole window, for the distance filter of pairs whose particles
  // all move on straight paths (no reach).
  const Vec3 *pathStart, *pathEnd, *pathReach;
  Real margin;
  bool selfStraight;  // the query primitive's particles all move on straight paths
};

// Whether every particle of pair (first, second) of `kind` moves on a straight path (no reach).
bool straightPaths(PairKind kind, const CollisionPrimitives& prims, const Vec3* reach, Index first,
                   Index second) {
  if (!reach) return true;
  bool straight = true;
  for (const Index i : particlesOf(prims, kind, true, first)) straight &= reach[i] == Vec3::Zero();
  for (const Index i : particlesOf(prims, kind, false, second))
    straight &= reach[i] == Vec3::Zero();
  return straight;
}

template <PairKind kKind>
void keepExtension(void* raw, Index partner) {
  ExtensionQuery& q = *static_cast<ExtensionQuery*>(raw);
  const BoxEnds& partnerEnds = q.partners[partner];
  if (q.partnerIsolated) partner = q.isolatedPoints[partner];
  if (q.partnerChanged && q.partnerChanged[partner] && (!q.lowerKeeps || partner < q.self)) return;
  Index first = q.selfFirst ? q.self : partner, second = q.selfFirst ? partner : q.self;
  if constexpr (kKind == PairKind::EdgeEdge || kKind == PairKind::VertexVertex) {
    if (first == second) return;
    if (first > second) std::swap(first, second);
  }
  if (!admissibleOf<kKind>(*q.primitives, q.w, first, second)) return;
  if (!meetInMotion(q.selfEnds, partnerEnds, q.since)) return;
  if (q.selfStraight && straightPaths(kKind, *q.primitives, q.pathReach, first, second) &&
      pairStaysOutOfReach(kKind, *q.primitives, q.pathStart, q.pathEnd, q.margin, first, second))
    return;
  q.kept[q.keptCount++] = std::uint64_t{first} << 32 | second;
  if (q.keptCount == q.kept.size()) q.found.append(q.kept.data(), q.keptCount), q.keptCount = 0;
}

// keepExtension for a search's kind.
PrimitiveBvh::Visitor extensionVisitor(PairKind kind) {
  switch (kind) {
    case PairKind::VertexFace:
      return &keepExtension<PairKind::VertexFace>;
    case PairKind::EdgeEdge:
      return &keepExtension<PairKind::EdgeEdge>;
    case PairKind::VertexEdge:
      return &keepExtension<PairKind::VertexEdge>;
    case PairKind::VertexVertex:
      break;
  }
  return &keepExtension<PairKind::VertexVertex>;
}

}  // namespace

bool extendCandidatePairs(CandidatePairs& pairs, PrimitiveBvh& bvh,
                          const CollisionPrimitives& primitives, std::span<const Vec3> position,
                          std::span<const Vec3> start, std::span<const Vec3> end,
                          std::span<const Real> w, Real margin, Real slack,
                          const FrameOffsets& offsets) {
  const std::size_t n = position.size();
  const std::size_t points = primitives.points(), edges = primitives.edges(),
                    triangles = primitives.triangles();
  // The trees and paths of the last findCandidatePairs must still fit the primitives.
  if (!hasBounds(pairs, n) || pairs.motionLower.size() != n ||
      bvh.boxes[kTriangleTree].size() != triangles || bvh.boxes[kEdgeTree].size() != edges ||
      bvh.boxes[kPointTree].size() != (triangles > 0 ? points : 0) ||
      bvh.boxes[kIsolatedTree].size() != bvh.isolatedPoints.size() ||
      bvh.builtCount(BvhTree::Triangles) != triangles || bvh.builtCount(BvhTree::Edges) != edges ||
      offsets.endAt <= offsets.startAt || offsets.startAt < pairs.pathFrom ||
      offsets.startAt >= pairs.pathTo)
    return false;
  for (std::size_t tree = 0; tree < kBvhTreeCount; ++tree)
    if (bvh.boxEnds[tree].size() != bvh.boxes[tree].size()) return false;

  std::vector<std::uint8_t>& grown = bvh.grownParticle;
  grown.resize(n);
  // Outside at the end of the motion or at its start (a step that starts from the last step's
  // pairs: the substeps after it start where the last one ended, inside).
  const std::size_t outside = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kBoxGrain), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t count) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          grown[i] = outsideBounds(pairs, position[i], offsets.position, offsets.positionAt, i) ||
                     outsideBounds(pairs, start[i], offsets.start, offsets.startAt, i);
          count += grown[i];
        }
        return count;
      },
      std::plus<>());
  if (outside == 0) return true;
  if (outside * kExtendShare > n) return false;
  pairs.pathsHeld = false;
  // A particle off its course once is likely to be bent again (a contact holds it, a fold turns
  // it): its new path is held over the box of its motion from `start` through `end` on to the
  // window's end, which any course inside that box keeps to, at any instant. The other paths do
  // not change, and the new pairs are tested over the window's part from `startAt` on, which is
  // all that is ahead.
  const Real stretch = Real(pairs.pathTo - offsets.startAt) / Real(offsets.endAt - offsets.startAt);
  const double since =
      double(offsets.startAt - pairs.pathFrom) / double(pairs.pathTo - pairs.pathFrom);
  for (std::size_t i = 0; i < n; ++i) {
    if (!grown[i]) continue;
    const Vec3 a = start[i] - offsets.start;
    holdPath(pairs, i, a, a + stretch * (end[i] - offsets.end - a));
  }
  pairs.boundSlack = slack;

  // The primitives with a grown particle, and their new boxes.
  auto& changedPoints = bvh.changedPrimitives[0];
  auto& changedEdges = bvh.changedPrimitives[1];
  auto& changedTriangles = bvh.changedPrimitives[2];
  for (auto& list : bvh.changedPrimitives) list.clear();
  bvh.changedPrimitive[0].assign(points, 0);
  bvh.changedPrimitive[1].assign(edges, 0);
  bvh.changedPrimitive[2].assign(triangles, 0);
  const std::span<const Vec3> pathStart = pairs.pathStart, pathEnd = pairs.pathEnd,
                              pathReach = pairs.pathReach;
  // A changed primitive's tree box holds its moving box over the part ahead only.
  const auto ahead = [&](MovingBox box) {
    box.swept = hullOf(boxBetween(box.start, box.end, since), box.end);
    return box;
  };
  const auto store = [&](std::size_t tree, std::size_t i, const MovingBox& box) {
    bvh.boxes[tree][i] = box.swept;
    bvh.boxEnds[tree][i] = {box.start, box.end};
  };
  // Listed in ascending order by one pass each, then their boxes in parallel.
  for (std::size_t i = 0; i < points; ++i)
    if (grown[primitives.pointParticle[i]]) {
      changedPoints.push_back(static_cast<Index>(i));
      bvh.changedPrimitive[0][i] = 1;
    }
  for (std::size_t e = 0; e < edges; ++e) {
    const auto& ends = primitives.edgeParticles[e];
    if (!grown[ends[0]] && !grown[ends[1]]) continue;
    changedEdges.push_back(static_cast<Index>(e));
    bvh.changedPrimitive[1][e] = 1;
  }
  for (std::size_t t = 0; t < triangles; ++t) {
    const auto& corners = primitives.triangleParticles[t];
    if (!grown[corners[0]] && !grown[corners[1]] && !grown[corners[2]]) continue;
    changedTriangles.push_back(static_cast<Index>(t));
    bvh.changedPrimitive[2][t] = 1;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, changedPoints.size(), 256),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k != r.end(); ++k) {
                        const Index i = changedPoints[k];
                        const MovingBox box =
                            ahead(movingBoxOf(pointParticles(primitives, i), pathStart, pathEnd,
                                              pathReach, primitives.pointRadius[i] + margin / 2));
                        if (triangles > 0) store(kPointTree, i, box);
                        if (primitives.pointIsolated[i]) {
                          const auto slot = std::lower_bound(bvh.isolatedPoints.begin(),
                                                             bvh.isolatedPoints.end(), i) -
                                            bvh.isolatedPoints.begin();
                          store(kIsolatedTree, static_cast<std::size_t>(slot), box);
                        }
                      }
                    });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, changedEdges.size(), 256),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k != r.end(); ++k) {
                        const Index e = changedEdges[k];
                        store(kEdgeTree, e,
                              ahead(movingBoxOf(edgeParticles(primitives, e), pathStart, pathEnd,
                                                pathReach, primitives.edgeRadius[e] + margin / 2)));
                      }
                    });
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, changedTriangles.size(), 256),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t k = r.begin(); k != r.end(); ++k) {
          const Index t = changedTriangles[k];
          store(kTriangleTree, t,
                ahead(movingBoxOf(triangleParticles(primitives, t), pathStart, pathEnd, pathReach,
                                  primitives.triangleRadius[t] + margin / 2)));
        }
      });
  computeTags(bvh, primitives, w);
  bvh.commit();

  // A primitive's tag by list (0 points, 1 edges, 2 triangles), as computeTags gives it.
  const auto tagOfPrimitive = [&](int list, Index i) {
    const std::span<const Index> ids = list == 0   ? pointParticles(primitives, i)
                                       : list == 1 ? edgeParticles(primitives, i)
                                                   : triangleParticles(primitives, i);
    bool free = false;
    for (const Index particle : ids) free |= w[particle] != 0;
    const std::uint32_t object = list == 0   ? primitives.pointObject[i]
                                 : list == 1 ? primitives.edgeObject[i]
                                             : primitives.triangleObject[i];
    return primitiveTag(object, free);
  };
  // A primitive's moving box by list (0 points, 1 edges, 2 triangles): stored with its tree, or
  // for a point without one (no triangles), computed.
  const auto movingBoxOfPrimitive = [&](int list, Index i) -> MovingBox {
    const auto read = [&](std::size_t tree) {
      return MovingBox{bvh.boxEnds[tree][i].start, bvh.boxEnds[tree][i].end, bvh.boxes[tree][i]};
    };
    if (list == 1) return read(kEdgeTree);
    if (list == 2) return read(kTriangleTree);
    if (triangles > 0) return read(kPointTree);
    return ahead(movingBoxOf(pointParticles(primitives, i), pathStart, pathEnd, pathReach,
                             primitives.pointRadius[i] + margin / 2));
  };

  // The changed primitives' queries, kind by kind: each partner a tree reports is a pair with
  // the query's primitive as its first or its second.
  struct Search {
    PairKind kind;
    const std::vector<Index>* queries;
    bool queryIsIsolated;  // queries are points, of which only the isolated ones take part
    BvhTree tree;
    bool selfFirst;
    // Which of the two queries that find a pair of changed primitives keeps it: none here (the
    // other query leaves it), the partner's (a changed point is queried against the tree this
    // search's primitives are in, with the same moving boxes), or the lower index's (both are of
    // one list).
    enum { kThisQuery, kPartnerQuery, kLowerIndex } keeper;
  };
  const std::array<Search, 6> searches = {{
      {PairKind::VertexFace, &changedPoints, false, BvhTree::Triangles, true, Search::kThisQuery},
      {PairKind::VertexFace, &changedTriangles, false, BvhTree::Points, false,
       Search::kPartnerQuery},
      {PairKind::EdgeEdge, &changedEdges, false, BvhTree::Edges, true, Search::kLowerIndex},
      {PairKind::VertexEdge, &changedPoints, true, BvhTree::Edges, true, Search::kThisQuery},
      {PairKind::VertexEdge, &changedEdges, false, BvhTree::IsolatedPoints, false,
       Search::kPartnerQuery},
      {PairKind::VertexVertex, &changedPoints, true, BvhTree::IsolatedPoints, true,
       Search::kLowerIndex},
  }};
  for (auto& list : bvh.newPairs) list.clear();
  std::mutex overflowLock;
  for (const Search& search : searches) {
    if (bvh.builtCount(search.tree) == 0) continue;
    const PrimitiveBvh::Visitor visitor = extensionVisitor(search.kind);
    prepareThreadPairs(bvh.threadPairs);
    const std::vector<Index>& queries = *search.queries;
    // The partners' list: edges in the edge tree, points in the others.
    const std::uint8_t* partnerChanged =
        search.keeper == Search::kThisQuery
            ? nullptr
            : bvh.changedPrimitive[search.tree == BvhTree::Edges ? 1 : 0].data();
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, queries.size(), 64),
        [&](const tbb::blocked_range<std::size_t>& r) {
          const auto tree = static_cast<std::size_t>(search.tree);
          ExtensionQuery query{&primitives,
                               w.data(),
                               bvh.isolatedPoints.data(),
                               ThreadPairs{&bvh.threadPairs, &overflowLock},
                               {},
                               0,
                               0,
                               search.selfFirst,
                               search.tree == BvhTree::IsolatedPoints,
                               {PrimitiveBox::empty(), PrimitiveBox::empty()},
                               bvh.boxEnds[tree].data(),
                               since,
                               partnerChanged,
                               search.keeper == Search::kLowerIndex,
                               pairs.pathStart.data(),
                               pairs.pathEnd.data(),
                               pairs.pathReach.data(),
                               margin,
                               false};
          for (std::size_t k = r.begin(); k != r.end(); ++k) {
            const Index self = queries[k];
            if (search.queries == &changedPoints && search.queryIsIsolated &&
                !primitives.pointIsolated[self])
              continue;
            const int list = search.queries == &changedEdges       ? 1
                             : search.queries == &changedTriangles ? 2
                                                                   : 0;
            const MovingBox box = movingBoxOfPrimitive(list, self);
            query.self = self;
            query.selfEnds = {box.start, box.end};
            query.selfStraight = true;
            if (!pairs.pathReach.empty())
              for (const Index particle : list == 0   ? pointParticles(primitives, self)
                                          : list == 1 ? edgeParticles(primitives, self)
                                                      : triangleParticles(primitives, self))
                query.selfStraight &= pairs.pathReach[particle] == Vec3::Zero();
            bvh.forEachOverlap(search.tree, box.swept, visitor, &query, tagOfPrimitive(list, self));
          }
          query.found.append(query.kept.data(), query.keptCount);
        });
    std::vector<std::uint64_t>& kindPairs = bvh.newPairs[static_cast<std::size_t>(search.kind)];
    for (const std::vector<std::uint64_t>& found : bvh.threadPairs)
      kindPairs.insert(kindPairs.end(), found.begin(), found.end());
  }
  const std::array<std::size_t, 4> firstsOf = {points, edges, points, points};
  tbb::parallel_for(std::size_t{0}, std::size_t{4}, [&](std::size_t kind) {
    sortUniqueByFirst(bvh.newPairs[kind], firstsOf[kind], bvh.newPairOffset[kind],
                      bvh.newPairScratch[kind]);
  });

  // Merged in (kind, first, second) order, so that the set stays the one a full broad phase over
  // these boxes would give: a pair already in the set is kept once, and an old pair of a changed
  // primitive is kept only if the queries found it again. They find every pair of a changed
  // primitive whose moving boxes meet (the tree boxes they search hold the moving boxes, and
  // keepExtension makes the same test), so one they did not find has come apart.
  // Kind by kind, both lists ascend in (first, second), one 64-bit key first << 32 | second, so
  // they merge in one pass: each chunk of a kind's old pairs takes that kind's new pairs from its
  // first old pair's key up to the next chunk's (one bisection per chunk, not per new pair),
  // counts what it keeps, and then writes its old pairs and new ones in order at its place. A new
  // pair equal to an old one is that pair (kept once, with its former index); the old ones are
  // unique, and so are the new ones. A kind with new pairs and no old ones is one chunk.
  using MergeChunk = PrimitiveBvh::MergeChunk;
  std::vector<MergeChunk>& chunks = bvh.mergeChunks;
  chunks.clear();
  for (std::size_t kind = 0, begin = 0; kind < 4; ++kind) {
    const std::size_t end = static_cast<std::size_t>(
        std::partition_point(pairs.kind.begin() + static_cast<std::ptrdiff_t>(begin),
                             pairs.kind.end(),
                             [&](PairKind k) { return static_cast<std::size_t>(k) <= kind; }) -
        pairs.kind.begin());
    if (begin == end) {
      if (!bvh.newPairs[kind].empty()) chunks.push_back({kind, begin, end, 0, 0, 0});
    } else {
      for (std::size_t from = begin; from < end; from += kPairGrain)
        chunks.push_back({kind, from, std::min(end, from + kPairGrain), 0, 0, 0});
    }
    begin = end;
  }
  const auto keyOf = [&](std::size_t i) {
    return std::uint64_t{pairs.first[i]} << 32 | pairs.second[i];
  };
  tbb::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t c) {
    MergeChunk& chunk = chunks[c];
    const std::vector<std::uint64_t>& found = bvh.newPairs[chunk.kind];
    const bool firstOfKind = c == 0 || chunks[c - 1].kind != chunk.kind;
    const bool lastOfKind = c + 1 == chunks.size() || chunks[c + 1].kind != chunk.kind;
    chunk.newBegin = firstOfKind
                         ? 0
                         : static_cast<std::size_t>(
                               std::lower_bound(found.begin(), found.end(), keyOf(chunk.oldBegin)) -
                               found.begin());
    chunk.newEnd = lastOfKind
                       ? found.size()
                       : static_cast<std::size_t>(
                             std::lower_bound(found.begin(), found.end(), keyOf(chunk.oldEnd)) -
                             found.begin());
  });
  // Visits a chunk's merged pairs in order: emit(old index or kNewPair, key).
  const auto mergeChunk = [&](const MergeChunk& chunk, auto&& emit) {
    const std::vector<std::uint64_t>& found = bvh.newPairs[chunk.kind];
    const auto kind = static_cast<PairKind>(chunk.kind);
    const std::uint8_t* changedFirst = bvh.changedPrimitive[primitiveListOf(kind, true)].data();
    const std::uint8_t* changedSecond = bvh.changedPrimitive[primitiveListOf(kind, false)].data();
    std::size_t i = chunk.oldBegin, k = chunk.newBegin;
    while (i < chunk.oldEnd || k < chunk.newEnd) {
      if (k < chunk.newEnd) {
        const std::uint64_t key = found[k];
        if (i == chunk.oldEnd || key < keyOf(i)) {
          emit(CandidatePairs::kNewPair, key);
          ++k;
          continue;
        }
        if (key == keyOf(i)) {  // found again
          emit(static_cast<Index>(i), key);
          ++k, ++i;
          continue;
        }
      }
      if (!changedFirst[pairs.first[i]] && !changedSecond[pairs.second[i]])
        emit(static_cast<Index>(i), keyOf(i));
      ++i;
    }
  };
  tbb::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t c) {
    std::size_t kept = 0;
    mergeChunk(chunks[c], [&](Index, std::uint64_t) { ++kept; });
    chunks[c].kept = kept;
  });
  std::size_t total = 0;
  for (MergeChunk& chunk : chunks) {
    const std::size_t kept = chunk.kept;
    chunk.kept = total;  // now where the chunk's pairs go
    total += kept;
  }
  bvh.mergedKind.resize(total), bvh.mergedFirst.resize(total), bvh.mergedSecond.resize(total);
  pairs.formerIndex.resize(total);
  tbb::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t c) {
    const MergeChunk& chunk = chunks[c];
    std::size_t out = chunk.kept;
    const auto kind = static_cast<PairKind>(chunk.kind);
    mergeChunk(chunk, [&](Index former, std::uint64_t key) {
      bvh.mergedKind[out] = kind;
      bvh.mergedFirst[out] = static_cast<Index>(key >> 32);
      bvh.mergedSecond[out] = static_cast<Index>(key & 0xffffffffu);
      pairs.formerIndex[out++] = former;
    });
  });
  pairs.kind.swap(bvh.mergedKind);
  pairs.first.swap(bvh.mergedFirst);
  pairs.second.swap(bvh.mergedSecond);
  ++pairs.version;
  return true;
}

BroadPhaseStats findCandidatePairsBruteForce(CandidatePairs& out,
                                             const CollisionPrimitives& primitives,
                                             std::span<const Vec3> x, std::span<const Vec3> p,
                                             std::span<const Real> w, Real margin,
                                             std::span<const Vec3> reach) {
  BroadPhaseStats stats;
  out.clear();
  std::vector<MovingBox> pointBoxes, edgeBoxes, triangleBoxes;
  for (std::size_t i = 0; i < primitives.points(); ++i)
    pointBoxes.push_back(movingBoxOf(pointParticles(primitives, i), x, p, reach,
                                     primitives.pointRadius[i] + margin / 2));
  for (std::size_t i = 0; i < primitives.edges(); ++i)
    edgeBoxes.push_back(movingBoxOf(edgeParticles(primitives, i), x, p, reach,
                                    primitives.edgeRadius[i] + margin / 2));
  for (std::size_t i = 0; i < primitives.triangles(); ++i)
    triangleBoxes.push_back(movingBoxOf(triangleParticles(primitives, i), x, p, reach,
                                        primitives.triangleRadius[i] + margin / 2));
  for (const auto* boxes : {&pointBoxes, &edgeBoxes, &triangleBoxes})
    for (const MovingBox& box : *boxes) stats.skippedPrimitives += box.swept.isEmpty();
  const auto meet = [](const MovingBox& a, const MovingBox& b) {
    return meetInMotion(a.start, a.end, b.start, b.end);
  };

  auto allowed = [&](std::span<const Index> a, std::uint32_t objectA, std::span<const Index> b,
                     std::uint32_t objectB) {
    bool free = false;
    for (Index i : a) {
      for (Index j : b)
        if (i == j) return false;
      free |= w[i] != 0;
    }
    for (Index j : b) free |= w[j] != 0;
    return free && !primitives.excluded(objectA, objectB) &&
           (primitives.particleSets.empty() || !primitives.setsExcluded(a, b));
  };
  auto add = [&](PairKind kind, std::size_t a, std::size_t b) {
    const auto first = static_cast<Index>(a), second = static_cast<Index>(b);
    if (straightPaths(kind, primitives, reach.empty() ? nullptr : reach.data(), first, second) &&
        pairStaysOutOfReach(kind, primitives, x.data(), p.data(), margin, first, second))
      return;
    out.push_back(kind, first, second);
    ++stats.pairs[static_cast<std::size_t>(kind)];
  };

  for (std::size_t i = 0; i < primitives.points(); ++i)
    for (std::size_t t = 0; t < primitives.triangles(); ++t)
      if (meet(pointBoxes[i], triangleBoxes[t]) &&
          allowed(pointParticles(primitives, i), primitives.pointObject[i],
                  triangleParticles(primitives, t), primitives.triangleObject[t]))
        add(PairKind::VertexFace, i, t);
  for (std::size_t a = 0; a < primitives.edges(); ++a)
    for (std::size_t b = a + 1; b < primitives.edges(); ++b)
      if (meet(edgeBoxes[a], edgeBoxes[b]) &&
          allowed(edgeParticles(primitives, a), primitives.edgeObject[a],
                  edgeParticles(primitives, b), primitives.edgeObject[b]))
        add(PairKind::EdgeEdge, a, b);
  for (std::size_t i = 0; i < primitives.points(); ++i) {
    if (!primitives.pointIsolated[i]) continue;
    for (std::size_t e = 0; e < primitives.edges(); ++e)
      if (meet(pointBoxes[i], edgeBoxes[e]) &&
          allowed(pointParticles(primitives, i), primitives.pointObject[i],
                  edgeParticles(primitives, e), primitives.edgeObject[e]))
        add(PairKind::VertexEdge, i, e);
  }
  for (std::size_t i = 0; i < primitives.points(); ++i) {
    if (!primitives.pointIsolated[i]) continue;
    for (std::size_t j = i + 1; j < primitives.points(); ++j)
      if (primitives.pointIsolated[j] && meet(pointBoxes[i], pointBoxes[j]) &&
          allowed(pointParticles(primitives, i), primitives.pointObject[i],
                  pointParticles(primitives, j), primitives.pointObject[j]))
        add(PairKind::VertexVertex, i, j);
  }
  return stats;
}

}  // namespace nucleon
