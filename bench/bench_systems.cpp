// Per-system micro benchmarks. Sizes follow the square cloths of 64², 128² and 256² vertices:
//  - BM_Sweep: one sweep of one constraint family with one backend at 1 and 2 threads, in
//    constraint projections per second, every sweep from the same predicted state. Stretch,
//    shear, bend (dihedral and isometric) and tethers run on the hanging cloth; volume on a
//    tetrahedral box and curve bend / twist on a helix of about the same particle count.
//  - BM_Residual: the strain left after k sweeps of the stretch family from the same predicted
//    state, per backend (convergence per sweep; with the time, convergence per millisecond).
//  - BM_Cascade: one multigrid coarse-to-fine cascade (every coarse level's sweeps, tethers and
//    prolongation) of the hanging cloth, from the same predicted state every repetition, in coarse
//    projections per second; compare its time with one stretch sweep of BM_Sweep.
//  - BM_ClothStep: a whole step of the hanging cloth.
//  - BM_Contacts: contact detection and one projection of the contact pool for an n² cloth
//    across the ground plane or a sphere (the collisions stage; nucleon has no mesh broad phase
//    or CCD yet to benchmark).
//  - BM_Liquid: the liquids' per-substep work on a block of n³ water particles at 1 and 2
//    threads, every repetition from the same compressed state: the neighbour search (hash grid,
//    sort into slots, lists) and one density projection, in particles per second.
// Times are wall-clock (UseRealTime): with two threads the main thread's CPU time would leave
// out the worker's.
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <numbers>
#include <type_traits>
#include <vector>

#include "engine/src/world_state.h"
#include "nucleon/shapes.h"
#include "systems/collision/particle_contacts.h"
#include "systems/diagnostics/measures.h"
#include "systems/dynamics/integrate.h"
#include "systems/liquid/density_constraints.h"
#include "systems/liquid/neighbour_grid.h"
#include "systems/solver/constraint_sweeps.h"
#include "systems/solver/multigrid_cascade.h"
#include "systems/solver/tether_sweep.h"

namespace {

using namespace nucleon;

constexpr Real kH = Real(1) / 60;

// SoftClothBend: the dihedral hinges with a bend compliance (1 m/N, cloth_hang_388's), which
// the Jacobi backend sweeps by colors instead of through its slots (constraint_sweeps.h).
enum class Subject {
  Stretch,
  Shear,
  ClothBend,
  Volume,
  CurveBend,
  Twist,
  Tether,
  IsometricBend,
  SoftClothBend
};
const char* subjectName(Subject s) {
  constexpr const char* names[] = {"stretch",        "shear", "cloth-bend", "volume",
                                   "curve-bend",     "twist", "tether",     "cloth-bend-isometric",
                                   "cloth-bend-soft"};
  return names[static_cast<int>(s)];
}

World hangingCloth(int n, bool shearAndBend, BendModel bendModel = BendModel::Dihedral,
                   Real bendCompliance = 0) {
  GridSpec spec;
  spec.resolution = {n, n};
  ObjectDef cloth = gridCloth(spec);
  cloth.pins = {0, static_cast<Index>(n - 1)};
  cloth.material.shear = cloth.material.bending = shearAndBend;
  cloth.material.bendModel = bendModel;
  cloth.material.bendCompliance = bendCompliance;
  World world;
  world.addCloth(cloth);
  return world;
}

// A world whose pools hold the subject's family at the size of an n² cloth.
World worldFor(Subject subject, int n) {
  World world;
  if (subject == Subject::Volume) {
    const int k = static_cast<int>(std::cbrt(double(n) * n)) - 1;  // (k+1)³ ≈ n² vertices
    world.addSolid(tetBox(Vec3(0, 1, 0), Vec3(1, 1, 1), {k, k, k}));
  } else if (subject == Subject::CurveBend || subject == Subject::Twist) {
    std::vector<Vec3> helix;
    for (int i = 0; i < n * n; ++i) {
      const double t = 0.3 * i;
      helix.emplace_back(Real(std::cos(t)), Real(0.01 * i), Real(std::sin(t)));
    }
    ObjectDef rope = polylineRope(helix);
    rope.material.bending = subject == Subject::CurveBend;
    rope.material.twist = subject == Subject::Twist;
    world.addRope(rope);
  } else if (subject == Subject::Tether) {
    world = hangingCloth(n, false);  // tethers need no shear or bend, whose steps are slow
  } else {
    world = hangingCloth(
        n, true, subject == Subject::IsometricBend ? BendModel::Isometric : BendModel::Dihedral,
        subject == Subject::SoftClothBend ? Real(1) : Real(0));
  }
  return world;
}

// Frames of motion before the swept state. A tether acts only once the cloth has fallen far
// enough to pull on it: five frames in, about 2% of them are taut and the sweep would time
// mostly the test that skips the others. One second in, the cloth hangs from its pins.
int framesBefore(Subject subject) {
  return subject == Subject::Tether ? 60 : 5;
}

// A deformed state to sweep on: some frames of motion, then forces and prediction of one more
// substep so that p differs from x as it does inside a step.
void prepare(World& world, SolverKind kind, int threads, int frames = 5) {
  SolverSettings settings;
  settings.kind = kind;
  world.setSolver(settings);
  world.setThreads(threads);
  for (int i = 0; i < frames; ++i) world.step(kH);
  WorldState& s = world.impl().state;
  applyForces(s.particles, s.gravity, kH);
  predictPositions(s.particles, kH);
}

// The sweep the solve stage runs for a family (systems/solver/solve_constraints.cpp): the generic
// sweep of the backend, except the tethers, which have their own.
template <class Kernel, std::size_t N>
void sweepFamily(SolverKind kind, ConstraintPool<N>& pool, const SweepContext& context) {
  if constexpr (std::is_same_v<Kernel, TetherKernel>)
    solveTethers(kind, pool, context);
  else
    solveSweep<Kernel>(kind, pool, context);
}

// Every timed sweep starts from the same state, the one the first sweep of a substep sees: the
// predicted positions and every multiplier at zero (as the solve starts each substep), restored
// outside the timing. Sweeping the result of the previous iteration instead would time a state
// that is already nearly solved, which flatters a unilateral family most: a satisfied tether
// returns before any arithmetic, and after one sweep almost all of them are satisfied.
template <class Kernel, std::size_t N>
void sweepLoop(benchmark::State& state, ConstraintPool<N>& pool, WorldState& s, SolverKind kind,
               int threads) {
  tbb::task_arena arena(threads);
  const SweepContext context{s.particles, kH, 1, nullptr};
  const std::vector<Vec3> predicted = s.particles.p;
  for (auto _ : state) {
    state.PauseTiming();
    s.particles.p = predicted;
    s.constraints.forEach(
        [](auto& family) { std::fill(family.lambda.begin(), family.lambda.end(), Real(0)); });
    state.ResumeTiming();
    arena.execute([&] { sweepFamily<Kernel>(kind, pool, context); });
  }
  state.counters["projections/s"] = benchmark::Counter(
      static_cast<double>(pool.size()), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["constraints"] = static_cast<double>(pool.size());
  // Constraints the timed sweep had to project: all of a two-sided family, the violated ones of
  // the tethers (the others cost only the test). Every row has the counter, as Google
  // Benchmark's CSV output needs the same counters in every row.
  std::size_t active = pool.size();
  if constexpr (std::is_same_v<Kernel, TetherKernel>) {
    active = 0;
    for (std::size_t c = 0; c < pool.size(); ++c) {
      const auto [free, pin] = pool.particles[c];
      active += (predicted[free] - predicted[pin]).norm() > pool.rest[c];
    }
  }
  state.counters["active"] = static_cast<double>(active);
}

void BM_Sweep(benchmark::State& state) {
  const auto subject = static_cast<Subject>(state.range(0));
  const int n = static_cast<int>(state.range(1));
  const auto kind = static_cast<SolverKind>(state.range(2));
  const int threads = static_cast<int>(state.range(3));
  World world = worldFor(subject, n);
  prepare(world, kind, threads, framesBefore(subject));
  WorldState& s = world.impl().state;
  ConstraintPools& pools = s.constraints;
  switch (subject) {
    case Subject::Stretch:
      sweepLoop<DistanceKernel>(state, pools.stretch, s, kind, threads);
      break;
    case Subject::Shear:
      sweepLoop<AngleKernel>(state, pools.shear, s, kind, threads);
      break;
    case Subject::ClothBend:
      sweepLoop<DihedralKernel>(state, pools.bend, s, kind, threads);
      break;
    case Subject::Volume:
      sweepLoop<VolumeKernel>(state, pools.volume, s, kind, threads);
      break;
    case Subject::CurveBend:
      sweepLoop<AngleKernel>(state, pools.curveBend, s, kind, threads);
      break;
    case Subject::Twist:
      sweepLoop<DihedralKernel>(state, pools.twist, s, kind, threads);
      break;
    case Subject::Tether:
      sweepLoop<TetherKernel>(state, pools.tether, s, kind, threads);
      break;
    case Subject::IsometricBend:
      sweepLoop<IsometricBendKernel>(state, pools.isometricBend, s, kind, threads);
      break;
    case Subject::SoftClothBend:
      sweepLoop<DihedralKernel>(state, pools.bend, s, kind, threads);
      break;
  }
  state.SetLabel(std::string(subjectName(subject)) + " " + toString(kind));
}

// Every subject × size × backend, at 1 and 2 threads (Gauss–Seidel is sequential: 1 only).
void sweepArguments(benchmark::internal::Benchmark* b) {
  for (int subject = 0; subject <= static_cast<int>(Subject::SoftClothBend); ++subject)
    for (int n : {64, 128, 256})
      for (SolverKind kind :
           {SolverKind::GaussSeidel, SolverKind::Jacobi, SolverKind::ColoredGaussSeidel})
        for (int threads : {1, 2}) {
          if (kind == SolverKind::GaussSeidel && threads > 1) continue;
          b->Args({subject, n, static_cast<int>(kind), threads});
        }
}
BENCHMARK(BM_Sweep)
    ->Apply(sweepArguments)
    ->ArgNames({"family", "n", "solver", "threads"})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

// Strain left after k stretch sweeps from the same predicted state (restored every iteration,
// outside the timing). The counters give the mean and max strain |L/L0 − 1| reached.
void BM_Residual(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto kind = static_cast<SolverKind>(state.range(1));
  const int sweeps = static_cast<int>(state.range(2));
  const int threads = static_cast<int>(state.range(3));
  World world = hangingCloth(n, false);
  prepare(world, kind, threads);
  WorldState& s = world.impl().state;
  StretchConstraints& pool = s.constraints.stretch;
  const std::vector<Vec3> predicted = s.particles.p;
  tbb::task_arena arena(threads);
  const SweepContext context{s.particles, kH, 1, nullptr};
  for (auto _ : state) {
    state.PauseTiming();
    s.particles.p = predicted;
    std::fill(pool.lambda.begin(), pool.lambda.end(), Real(0));
    state.ResumeTiming();
    arena.execute([&] {
      for (int k = 0; k < sweeps; ++k) solveSweep<DistanceKernel>(kind, pool, context);
    });
  }
  const StrainStats strain = measureStrain(pool, s.particles.p);
  state.counters["mean_strain"] = strain.mean;
  state.counters["max_strain"] = strain.max;
  state.SetLabel(toString(kind));
}
BENCHMARK(BM_Residual)
    ->ArgsProduct({{128},
                   {static_cast<int>(SolverKind::GaussSeidel), static_cast<int>(SolverKind::Jacobi),
                    static_cast<int>(SolverKind::ColoredGaussSeidel)},
                   {1, 2, 4, 8, 16, 32, 64},
                   {2}})
    ->ArgNames({"n", "solver", "sweeps", "threads"})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

void BM_Cascade(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  World world = hangingCloth(n, false);
  prepare(world, SolverKind::Multigrid, threads);
  WorldState& s = world.impl().state;
  const SolverSettings settings;  // the default sweeps per level
  const std::vector<Vec3> predicted = s.particles.p;
  tbb::task_arena arena(threads);
  std::size_t projections = 0;
  for (auto _ : state) {
    state.PauseTiming();
    s.particles.p = predicted;
    state.ResumeTiming();
    arena.execute([&] {
      projections = runMultigridCascade(s.hierarchies, s.objects, s.particles, s.cascade,
                                        settings.sweepsPerLevel);
    });
  }
  state.counters["projections/s"] = benchmark::Counter(
      static_cast<double>(projections), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["projections"] = static_cast<double>(projections);
  state.counters["fine_edges"] = static_cast<double>(s.constraints.stretch.size());
}
BENCHMARK(BM_Cascade)
    ->ArgsProduct({{128, 256}, {1, 2}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

void BM_ClothStep(benchmark::State& state) {
  World world = hangingCloth(static_cast<int>(state.range(0)), false);
  SolverSettings settings;
  settings.kind = static_cast<SolverKind>(state.range(1));
  world.setSolver(settings);
  world.setThreads(static_cast<int>(state.range(2)));
  world.step(kH);  // warm-up: arena and graph creation
  for (auto _ : state) world.step(kH);
  state.SetLabel(toString(settings.kind));
}
BENCHMARK(BM_ClothStep)
    ->ArgsProduct({{64, 128, 256},
                   {static_cast<int>(SolverKind::GaussSeidel), static_cast<int>(SolverKind::Jacobi),
                    static_cast<int>(SolverKind::ColoredGaussSeidel)},
                   {1, 2}})
    ->ArgNames({"n", "solver", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The collisions stage of one substep for an n² cloth lying flat at y = 0.45 across a collider:
// contact detection into the per-substep pool, then one projection of the pool, from the same
// state every iteration (restored outside the timing). Every third particle is 5 cm lower. The
// ground's contact surface is 2.5 cm under the cloth, so the lowered third are inside it and the
// rest are beyond the contact reach; the sphere (r = 0.5 at the origin) reaches only the middle
// of the cloth. The counters say what the pool held: contacts made, particles inside a contact
// surface before the projection and still inside after it.
void BM_Contacts(benchmark::State& state) {
  const bool sphere = state.range(0) == 1;
  const int n = static_cast<int>(state.range(1));
  const int threads = static_cast<int>(state.range(2));
  GridSpec spec;
  spec.resolution = {n, n};
  spec.center = Vec3(0, Real(0.45), 0);
  World world;
  world.addCloth(gridCloth(spec));
  const SphereCollider ball;
  GroundPlane ground;
  ground.enabled = true;
  ground.height = Real(0.42);
  if (sphere)
    world.addSphereCollider(ball);
  else
    world.setGround(ground);
  world.step(kH);  // pools sized, topology built
  WorldState& s = world.impl().state;
  std::vector<Vec3> start = s.particles.restPosition;
  for (std::size_t i = 0; i < start.size(); i += 3) start[i].y() -= Real(0.05);
  const std::vector<Vec3> zero(start.size(), Vec3::Zero());
  // Deeper than `slack` inside the contact surface, from the collider's own definition rather
  // than the contact code.
  auto inside = [&](const std::vector<Vec3>& x, Real slack) {
    std::size_t count = 0;
    for (const Vec3& y : x)
      count += sphere ? (y - ball.center).norm() < ball.radius + ball.thickness - slack
                      : y.y() < ground.height + ground.thickness - slack;
    return count;
  };
  tbb::task_arena arena(threads);
  for (auto _ : state) {
    state.PauseTiming();
    s.particles.x = start;
    s.particles.p = start;
    s.particles.v = zero;
    state.ResumeTiming();
    arena.execute([&] {
      detectContacts(s.contacts, s.colliders, s.particles, kH);
      projectContacts(s.contacts, s.colliders, s.particles, SolverKind::ColoredGaussSeidel);
    });
  }
  state.counters["contacts"] = static_cast<double>(s.contacts.size());
  state.counters["inside"] = static_cast<double>(inside(start, 0));
  // Projected onto the surface means within a rounding error of it.
  state.counters["inside_after"] = static_cast<double>(inside(s.particles.p, Real(1e-5)));
  state.counters["particles/s"] = benchmark::Counter(static_cast<double>(start.size()),
                                                     benchmark::Counter::kIsIterationInvariantRate);
  state.SetLabel(sphere ? "sphere" : "ground");
}
BENCHMARK(BM_Contacts)
    ->ArgsProduct({{0, 1}, {64, 128, 256}, {1, 2}})
    ->ArgNames({"shape", "n", "threads"})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

// A block of n³ water particles 2 cm apart, squeezed by 5% along y so that every constraint is
// active. Part 0: the neighbour search alone; part 1: one density projection (its λ and Δp
// passes) over lists found once. The counter `neighbours` is the mean list length.
void BM_Liquid(benchmark::State& state) {
  const bool projection = state.range(0) == 1;
  const int n = static_cast<int>(state.range(1));
  const int threads = static_cast<int>(state.range(2));
  const Real spacing = Real(0.02);
  ObjectDef block = particleBlock(Vec3(0, 1, 0), Vec3::Constant(spacing * Real(n)), spacing);
  for (Vec3& x : block.vertices) x.y() *= Real(0.95);
  block.material.mass = 1000 * Real(block.vertices.size()) * spacing * spacing * spacing;
  block.material.liquid.enabled = true;
  World world;
  world.addParticles(block);
  WorldState& s = world.impl().state;
  LiquidPool& pool = s.constraints.liquid;
  const std::vector<Vec3> start = s.particles.x;
  tbb::task_arena arena(threads);
  arena.execute([&] { startLiquidSubstep(pool, s.particles); });
  for (auto _ : state) {
    state.PauseTiming();
    s.particles.p = start;
    state.ResumeTiming();
    arena.execute([&] {
      if (projection)
        projectDensity(pool, s.particles, 2 * pool.kernels.radius);
      else
        buildNeighbourLists(pool, s.particles.p, s.particles.w);
    });
  }
  double listed = 0;
  for (std::uint16_t count : pool.neighbourCount) listed += count;
  state.counters["neighbours"] = listed / double(pool.size());
  state.counters["particles/s"] = benchmark::Counter(static_cast<double>(pool.size()),
                                                     benchmark::Counter::kIsIterationInvariantRate);
  state.SetLabel(projection ? "density projection" : "neighbour search");
}
BENCHMARK(BM_Liquid)
    ->ArgsProduct({{0, 1}, {20, 32}, {1, 2}})
    ->ArgNames({"part", "n", "threads"})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
