#include "systems/dynamics/impact_travel.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

namespace nucleon {

namespace {

constexpr std::size_t kParticleGrain = 1024;

double distanceToBox(const Vec3d& x, const ImpactTravelScratch::ColliderBox& box) {
  return (box.lower - x).cwiseMax(x - box.upper).cwiseMax(0.0).norm();
}

}  // namespace

std::vector<double> medianEdgeLengths(const std::vector<ObjectRecord>& objects,
                                      const ParticlePool& particles) {
  std::vector<double> median(objects.size(), 0.0);
  std::vector<double> lengths;
  for (std::size_t o = 0; o < objects.size(); ++o) {
    const ObjectRecord& object = objects[o];
    if (object.kind == ObjectKind::Collider) continue;
    const auto& edges = object.complex.edges.vertices;
    lengths.clear();
    for (const auto& e : edges) {
      const Index a = object.firstParticle + e[0], b = object.firstParticle + e[1];
      if (a >= particles.size() || b >= particles.size()) continue;
      const double length =
          (particles.restPosition[a] - particles.restPosition[b]).cast<double>().norm();
      if (std::isfinite(length)) lengths.push_back(length);
    }
    if (lengths.empty()) continue;
    const auto middle = lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2);
    std::nth_element(lengths.begin(), middle, lengths.end());
    median[o] = *middle;
  }
  return median;
}

double impactTravelRatio(const std::vector<ObjectRecord>& objects,
                         std::span<const double> edgeLength, const ParticlePool& particles,
                         const ColliderPool& colliders, double fixedLimit, double share, double dt,
                         double colliderTravel, double floor, ImpactTravelScratch& scratch) {
  using ColliderBox = ImpactTravelScratch::ColliderBox;
  std::vector<ColliderBox>& boxes = scratch.boxes;
  boxes.clear();
  for (const ObjectRecord& object : objects) {
    if (object.kind != ObjectKind::Collider || object.particleCount == 0) continue;
    ColliderBox box{Vec3d::Constant(std::numeric_limits<double>::infinity()),
                    Vec3d::Constant(-std::numeric_limits<double>::infinity()),
                    double(object.material.thickness)};
    for (Index i = object.firstParticle; i < object.firstParticle + object.particleCount; ++i) {
      const Vec3d x = particles.x[i].cast<double>();
      if (!x.allFinite()) continue;
      box.lower = box.lower.cwiseMin(x), box.upper = box.upper.cwiseMax(x);
    }
    if ((box.lower.array() <= box.upper.array()).all()) boxes.push_back(box);
  }
  double most = std::max(0.0, floor);
  if (boxes.empty() && colliders.size() == 0) return most;
  const double reachOfColliders = std::max(0.0, colliderTravel);
  for (std::size_t o = 0; o < objects.size(); ++o) {
    const ObjectRecord& object = objects[o];
    if (object.kind == ObjectKind::Collider || o >= edgeLength.size()) continue;
    const double limit = fixedLimit > 0 ? fixedLimit : share * edgeLength[o];
    if (!(limit > 0)) continue;
    const double contactReach = double(object.material.thickness) + reachOfColliders;
    const auto nearCollider = [&](const Vec3d& x, double travel) {
      for (std::size_t c = 0; c < colliders.size(); ++c) {
        const Vec3d point = colliders.point[c].cast<double>();
        const double distance = colliders.shape[c] == ColliderShape::Plane
                                    ? (x - point).dot(colliders.normal[c].cast<double>())
                                    : (x - point).norm() - double(colliders.radius[c]);
        if (distance - double(colliders.thickness[c]) - contactReach <= travel) return true;
      }
      for (const ColliderBox& box : boxes)
        if (distanceToBox(x, box) - box.thickness - contactReach <= travel) return true;
      return false;
    };
    // The farthest travel of a free particle, and whether any may reach a collider: a maximum
    // and an or, the same whatever the order.
    struct Reach {
      double farthest = 0;
      bool near = false;
    };
    const Reach reach = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(
            object.firstParticle, object.firstParticle + object.particleCount, kParticleGrain),
        Reach{},
        [&](const tbb::blocked_range<std::size_t>& r, Reach sum) {
          for (std::size_t i = r.begin(); i != r.end(); ++i) {
            if (particles.w[i] == 0) continue;
            const double go = double(particles.v[i].norm()) * dt;
            if (!std::isfinite(go)) continue;
            sum.farthest = std::max(sum.farthest, go);
            if (!sum.near) sum.near = nearCollider(particles.x[i].cast<double>(), go);
          }
          return sum;
        },
        [](Reach a, const Reach& b) {
          return Reach{std::max(a.farthest, b.farthest), a.near || b.near};
        });
    // The median is at most the farthest: where that cannot pass `most`, the serial median of
    // every particle is not needed (a slow or distant object, most steps of most scenes).
    if (!reach.near || !(reach.farthest / limit > most)) continue;
    // The median travel of its free particles: the bulk of the object, which a collider stops in
    // part. Not the fastest particle: a cloth draped over a sphere whips its free corners round
    // at several times the speed it fell at (15 m/s against 4 at 128², 15.7 mm edges), moving
    // with their neighbours, and its edges do not stretch for it.
    std::vector<double>& speeds = scratch.travels;
    speeds.clear();
    for (Index i = object.firstParticle; i < object.firstParticle + object.particleCount; ++i) {
      const double go = double(particles.v[i].norm()) * dt;
      if (particles.w[i] != 0 && std::isfinite(go)) speeds.push_back(go);
    }
    if (speeds.empty()) continue;
    const auto middle = speeds.begin() + static_cast<std::ptrdiff_t>(speeds.size() / 2);
    std::nth_element(speeds.begin(), middle, speeds.end());
    const double travel = *middle;
    most = std::max(most, travel / limit);
  }
  return most;
}

}  // namespace nucleon
