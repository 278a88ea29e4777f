// Per-system micro benchmarks on square cloths of 64², 128² and 256² vertices: one stretch sweep
// per backend (constraint projections per second) and a whole step.
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "systems/stretch_solve.h"

namespace {

nucleon::World hangingCloth(int n) {
  nucleon::GridSpec spec;
  spec.resolution = {n, n};
  nucleon::ObjectDef cloth = nucleon::gridCloth(spec);
  cloth.pins = {0, static_cast<nucleon::Index>(n - 1)};
  nucleon::World world;
  world.addCloth(cloth);
  return world;
}

void BM_StretchSweepGaussSeidel(benchmark::State& state) {
  nucleon::World world = hangingCloth(static_cast<int>(state.range(0)));
  auto& s = world.impl().state;
  for (int i = 0; i < 10; ++i) world.step(1.0 / 60);  // a deformed state, not the rest shape
  for (auto _ : state) nucleon::solveStretchGaussSeidel(s.stretch, s.particles, 1.0f / 60);
  state.counters["projections/s"] = benchmark::Counter(
      static_cast<double>(s.stretch.size()), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_StretchSweepGaussSeidel)->Arg(64)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

void BM_StretchSweepParallel(benchmark::State& state) {
  nucleon::World world = hangingCloth(static_cast<int>(state.range(0)));
  const auto kind = static_cast<nucleon::SolverKind>(state.range(1));
  world.setSolver({kind, 10, 1});
  world.setThreads(static_cast<int>(state.range(2)));
  for (int i = 0; i < 10; ++i) world.step(1.0 / 60);  // builds incidence and coloring
  auto& s = world.impl().state;
  tbb::task_arena arena(static_cast<int>(state.range(2)));
  for (auto _ : state)
    arena.execute([&] {
      if (kind == nucleon::SolverKind::Jacobi)
        nucleon::solveStretchJacobi(s.stretch, s.particles, 1.0f / 60, 1.0f);
      else
        nucleon::solveStretchColored(s.stretch, s.particles, 1.0f / 60);
    });
  state.SetLabel(nucleon::toString(kind));
  state.counters["projections/s"] = benchmark::Counter(
      static_cast<double>(s.stretch.size()), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_StretchSweepParallel)
    ->ArgsProduct({{64, 128, 256},
                   {static_cast<int>(nucleon::SolverKind::Jacobi),
                    static_cast<int>(nucleon::SolverKind::ColoredGaussSeidel)},
                   {1, 2}})
    ->ArgNames({"n", "solver", "threads"})
    ->Unit(benchmark::kMicrosecond);

void BM_ClothStep(benchmark::State& state) {
  nucleon::World world = hangingCloth(static_cast<int>(state.range(0)));
  world.setThreads(static_cast<int>(state.range(1)));
  world.step(1.0 / 60);  // warm-up: arena and graph creation
  for (auto _ : state) world.step(1.0 / 60);
}
BENCHMARK(BM_ClothStep)
    ->ArgsProduct({{64, 128, 256}, {1, 2}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
