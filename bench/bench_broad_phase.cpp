// Broad phase per substep on self-colliding cloth: swept boxes, tree refit and per-primitive
// queries (findCandidatePairs), for a 2 m cloth of n × n vertices folded into four layers, at 1
// and 2 threads; the first build of the trees; the brute force at 64² for scale.
//
// The cloth: edge l = 2 m / (n − 1), thickness (the primitives' radius) l/4, margin l/4, layers
// 3l/4 apart, so that neighbouring layers are within reach as in a resting stack. The substep
// motion is a falling cloth's at 60 Hz with 10 substeps: 2 m/s down with ±0.5 m/s of smooth
// flutter, plus 5% of an edge of noise.
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include "components/candidate_pairs.h"
#include "components/collision_primitives.h"
#include "components/primitive_bvh.h"
#include "nucleon/shapes.h"
#include "systems/collision/broad_phase.h"

namespace nucleon {
namespace {

struct FoldedCloth {
  CollisionPrimitives primitives;
  std::vector<Vec3> x, p;
  std::vector<Real> w;
  Real margin = 0;

  explicit FoldedCloth(int n) {
    GridSpec spec;
    spec.resolution = {n, n};
    spec.size = {2, 2};
    spec.center = Vec3(0, 0, 0);
    const ObjectDef cloth = gridCloth(spec);
    const Real edge = Real(2) / Real(n - 1);
    const Real thickness = edge / 4;
    const Real gap = 3 * thickness;
    const int layers = 4;
    const Real substep = Real(1.0 / 600.0);
    std::mt19937 random(1);
    std::uniform_real_distribution<double> noise(-0.05 * edge, 0.05 * edge);
    for (const Vec3& rest : cloth.vertices) {
      // Zig-zag along x: layer k holds the k-th strip of the cloth, every other one reversed.
      const Real along = (rest.x() + 1) / 2 * layers;
      const int layer = std::min(int(along), layers - 1);
      const Real t = along - Real(layer);
      const Real folded = layer % 2 == 0 ? t : 1 - t;
      const Vec3 position(folded * 2 / layers, Real(layer) * gap, rest.z());
      const Real flutter = Real(0.5 * std::sin(3 * rest.x()) * std::cos(2 * rest.z()));
      const Vec3 velocity(flutter, -2 + flutter, -flutter);
      x.push_back(position);
      p.push_back(position + substep * velocity +
                  Vec3(Real(noise(random)), Real(noise(random)), Real(noise(random))));
      w.push_back(1);
    }
    std::set<std::pair<Index, Index>> edges;
    for (const auto& t : cloth.triangles) {
      primitives.triangleParticles.push_back(t);
      primitives.triangleRadius.push_back(thickness);
      primitives.triangleObject.push_back(0);
      for (int k = 0; k < 3; ++k)
        edges.insert({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
    }
    for (const auto& [a, b] : edges) {
      primitives.edgeParticles.push_back({a, b});
      primitives.edgeRadius.push_back(thickness);
      primitives.edgeObject.push_back(0);
    }
    for (Index v = 0; v < cloth.vertices.size(); ++v) {
      primitives.pointParticle.push_back(v);
      primitives.pointRadius.push_back(thickness);
      primitives.pointObject.push_back(0);
      primitives.pointIsolated.push_back(0);
    }
    margin = thickness;
  }
};

void setCounters(benchmark::State& state, const BroadPhaseStats& stats) {
  state.counters["VF"] = double(stats.pairs[std::size_t(PairKind::VertexFace)]);
  state.counters["EE"] = double(stats.pairs[std::size_t(PairKind::EdgeEdge)]);
  state.counters["VE"] = double(stats.pairs[std::size_t(PairKind::VertexEdge)]);
  state.counters["VV"] = double(stats.pairs[std::size_t(PairKind::VertexVertex)]);
}

// One substep's broad phase in steady state: the trees exist and are refit.
void BM_BroadPhaseSubstep(benchmark::State& state) {
  const FoldedCloth cloth(int(state.range(0)));
  tbb::task_arena arena(int(state.range(1)));
  CandidatePairs pairs;
  PrimitiveBvh bvh;
  BroadPhaseStats stats;
  arena.execute([&] {
    findCandidatePairs(pairs, bvh, cloth.primitives, cloth.x, cloth.p, cloth.w, cloth.margin);
  });
  double boxes = 0, commit = 0, queries = 0;
  for (auto _ : state) {
    arena.execute([&] {
      stats =
          findCandidatePairs(pairs, bvh, cloth.primitives, cloth.x, cloth.p, cloth.w, cloth.margin);
    });
    boxes += stats.boxSeconds, commit += stats.commitSeconds, queries += stats.querySeconds;
    benchmark::DoNotOptimize(pairs.first.data());
  }
  setCounters(state, stats);
  const double perIteration = 1e3 / double(state.iterations());
  state.counters["boxes_ms"] = boxes * perIteration;
  state.counters["refit_ms"] = commit * perIteration;
  state.counters["query_ms"] = queries * perIteration;
}
BENCHMARK(BM_BroadPhaseSubstep)
    ->ArgNames({"n", "threads"})
    ->ArgsProduct({{64, 128, 256}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The first call on a fresh component: trees built from scratch, as when the counts change.
void BM_BroadPhaseFirstBuild(benchmark::State& state) {
  const FoldedCloth cloth(int(state.range(0)));
  tbb::task_arena arena(int(state.range(1)));
  CandidatePairs pairs;
  BroadPhaseStats stats;
  double commit = 0;
  for (auto _ : state) {
    PrimitiveBvh bvh;
    arena.execute([&] {
      stats =
          findCandidatePairs(pairs, bvh, cloth.primitives, cloth.x, cloth.p, cloth.w, cloth.margin);
    });
    commit += stats.commitSeconds;
  }
  setCounters(state, stats);
  state.counters["build_ms"] = commit * 1e3 / double(state.iterations());
}
BENCHMARK(BM_BroadPhaseFirstBuild)
    ->ArgNames({"n", "threads"})
    ->ArgsProduct({{128}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Every pair of boxes tested: the reference, for scale.
void BM_BroadPhaseBruteForce(benchmark::State& state) {
  const FoldedCloth cloth(int(state.range(0)));
  CandidatePairs pairs;
  BroadPhaseStats stats;
  for (auto _ : state)
    stats = findCandidatePairsBruteForce(pairs, cloth.primitives, cloth.x, cloth.p, cloth.w,
                                         cloth.margin);
  setCounters(state, stats);
}
BENCHMARK(BM_BroadPhaseBruteForce)->ArgNames({"n"})->Arg(64)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace nucleon
