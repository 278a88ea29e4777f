// The narrow phase on a settled cloth pile: detectPrimitiveContacts over the candidate pairs of
// the bundled scene cloth_self (a 40² cloth folded onto itself on the ground) after 60 of its
// frames, for the next substep's predicted motion, at 1 and 2 threads. `carried` 0: the pool
// has no bounds from an earlier substep, so every pair is measured (a step's first substep after
// a new search); 1: the bounds of a first call are carried, as in the substeps that follow. The
// pool is restored before every timed repetition. Counters: candidate pairs, contacts made, and
// pairs per second.
#include <string>

#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include "engine/src/world_state.h"
#include "nucleon/scene.h"
#include "systems/collision/primitive_contacts.h"
#include "systems/dynamics/integrate.h"

namespace nucleon {
namespace {

void BM_NarrowPhasePile(benchmark::State& state) {
  const bool carried = state.range(0) == 1;
  tbb::task_arena arena(int(state.range(1)));
  const Scene scene = loadScene(assetsFolder() + "/scenes/cloth_self.json");
  World world = buildWorld(scene);
  const double frame = 1.0 / 60.0;
  arena.execute([&] {
    for (int i = 0; i < 60; ++i) world.step(frame);
  });
  WorldState& s = world.impl().state;
  const Real h = Real(frame / double(s.solver.substeps));
  applyForces(s.particles, s.gravity, h);
  predictPositions(s.particles, h);
  PrimitiveContactPool& contacts = s.primitiveContacts;
  contacts.boundVersion = 0;
  if (carried)
    arena.execute(
        [&] { detectPrimitiveContacts(contacts, s.candidates, s.primitives, s.particles); });
  const PrimitiveContactPool input = contacts;
  for (auto _ : state) {
    state.PauseTiming();
    contacts = input;
    state.ResumeTiming();
    arena.execute(
        [&] { detectPrimitiveContacts(contacts, s.candidates, s.primitives, s.particles); });
  }
  state.counters["pairs"] = double(s.candidates.size());
  state.counters["contacts"] = double(contacts.size());
  state.counters["pairs/s"] = benchmark::Counter(double(s.candidates.size()),
                                                 benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_NarrowPhasePile)
    ->ArgNames({"carried", "threads"})
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

}  // namespace
}  // namespace nucleon
