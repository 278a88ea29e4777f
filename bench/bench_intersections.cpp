// The exact self-intersection count that `nucleon run` reports every frame
// (countTriangleIntersections), on the surface of an n × n cloth, 2 m square: flat (every
// triangle coplanar, as a cloth's first frames) and wavy (a draped cloth's smooth folds, 5 cm
// high), at 1 and 2 threads. Neither shape intersects itself: the count is 0 and all of the time
// is the check.
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include "nucleon/shapes.h"
#include "systems/diagnostics/triangle_intersections.h"

namespace nucleon {
namespace {

void BM_CountIntersections(benchmark::State& state) {
  GridSpec spec;
  spec.resolution = {int(state.range(0)), int(state.range(0))};
  spec.size = {2, 2};
  spec.center = Vec3(0, 1, 0);
  const ObjectDef cloth = gridCloth(spec);
  std::vector<Vec3> x = cloth.vertices;
  if (state.range(1) != 0)
    for (Vec3& v : x) v.y() += Real(0.05 * std::sin(4 * v.x()) * std::cos(3 * v.z()));
  tbb::task_arena arena(int(state.range(2)));
  std::size_t count = 0;
  for (auto _ : state) {
    arena.execute([&] { count = countTriangleIntersections(cloth.triangles, x); });
    benchmark::DoNotOptimize(count);
  }
  if (count != 0) state.SkipWithError("the cloth should not intersect itself");
  state.counters["triangles"] = double(cloth.triangles.size());
}
BENCHMARK(BM_CountIntersections)
    ->ArgNames({"n", "wavy", "threads"})
    ->ArgsProduct({{128, 256}, {0, 1}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace nucleon
