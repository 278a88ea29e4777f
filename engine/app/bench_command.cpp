#include "engine/app/bench_command.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <thread>

#include "engine/app/cli_args.h"
#include "nucleon/lanes.h"
#include "nucleon/scene.h"

namespace nucleon {

const char* const kBenchHelp =
    "nucleon bench SCENE.json|NAME ... [options]: time scenes at several thread counts.\n"
    "  NAME              a bundled scene (nucleon scenes), e.g. cloth_hang_128\n"
    "  --threads LIST    thread counts, e.g. 1,2,4 (default 1 .. all cores)\n"
    "  --solver LIST     backends, e.g. colored-gs,jacobi (default: the scene's)\n"
    "  --iterations K    sweeps per substep (rescales a scene schedule)\n"
    "  --steps N         timed steps per run (default 100)\n"
    "  --warmup W        steps run before timing starts (default 10)\n"
    "  --repeats R       runs per configuration; the median is reported (default 3)\n"
    "  --csv FILE        also write one CSV row per configuration\n"
    "  --lanes LIST      instruction sets of the batched kernels, e.g. avx2,avx512 (default: the\n"
    "                    best this CPU has; 'none' runs the scalar paths)\n"
    "Per configuration: ms/step (median of repeats), per-stage ms/step from the engine's\n"
    "profile (cascade: the part of solve the multigrid cascade took), million constraint "
    "projections per second, speedup and parallel efficiency\n"
    "against the first configuration of the solver, max/mean strain, the repairs the step made "
    "(recoveries,\n"
    "warm-up included; 0 in a healthy run) and the final state hash ('same' when it equals the\n"
    "hash at the solver's first configuration: the lane sets give the same bits, 'none'\n"
    "rounds differently).\n";

namespace {

namespace fs = std::filesystem;
using cli::UsageError;
using Clock = std::chrono::steady_clock;

struct BenchOptions {
  std::vector<std::string> scenes;
  std::vector<int> threads;
  std::vector<SolverKind> solvers;
  std::vector<LaneIsa> lanes;
  int iterations = -1;
  int steps = 100, warmup = 10, repeats = 3;
  std::string csv;
};

BenchOptions parseBench(const std::vector<std::string>& args) {
  BenchOptions o;
  for (cli::Arguments arguments(args); arguments.next();) {
    const std::string& a = arguments.current();
    const auto value = [&]() -> const std::string& { return arguments.value(); };
    if (a == "--threads") {
      o.threads = cli::parseIntList(a, value(), 1, 4096);
    } else if (a == "--solver") {
      for (const std::string& name : cli::splitList(value())) {
        SolverKind kind;
        if (!parseSolverKind(name, kind))
          throw UsageError("--solver: unknown solver '" + name + "'");
        o.solvers.push_back(kind);
      }
    } else if (a == "--iterations") {
      o.iterations = cli::parseInt(a, value(), 0, 100000);
    } else if (a == "--steps") {
      o.steps = cli::parseInt(a, value(), 1, 1000000);
    } else if (a == "--warmup") {
      o.warmup = cli::parseInt(a, value(), 0, 1000000);
    } else if (a == "--repeats") {
      o.repeats = cli::parseInt(a, value(), 1, 1000);
    } else if (a == "--csv") {
      o.csv = value();
    } else if (a == "--lanes") {
      for (const std::string& name : cli::splitList(value())) {
        LaneIsa isa;
        if (!parseLaneIsa(name, isa))
          throw UsageError("--lanes: unknown instruction set '" + name + "' (none, avx2, avx512)");
        if (static_cast<int>(isa) > static_cast<int>(bestLaneIsa()))
          throw UsageError(std::string("--lanes: this build or CPU cannot run ") + name +
                           " (best: " + laneIsaName(bestLaneIsa()) + ")");
        o.lanes.push_back(isa);
      }
    } else if (!a.empty() && a[0] == '-') {
      throw UsageError("unknown option '" + a + "'");
    } else {
      o.scenes.push_back(a);
    }
  }
  if (o.scenes.empty()) throw UsageError("bench needs at least one scene");
  if (o.threads.empty()) {
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    for (int t = 1; t <= cores; ++t) o.threads.push_back(t);
  }
  return o;
}

// A path, or the name of a bundled scene.
Scene loadNamedScene(const std::string& name) {
  std::string path = name;
  if (!fs::exists(path)) {
    const fs::path bundled = fs::path(assetsFolder()) / "scenes" / (name + ".json");
    if (fs::exists(bundled)) path = bundled.string();
  }
  try {
    return loadScene(path);
  } catch (const SceneError& e) {
    throw UsageError(e.what());
  }
}

struct Run {
  double msPerStep = 0;
  StepProfile profile;
  Measures measures;
  Recoveries recoveries;  // over the whole run, warm-up included
  std::uint64_t hash = 0;
  std::size_t particles = 0;
};

Run runOnce(const Scene& scene, const BenchOptions& o) {
  World world;
  try {
    world = buildWorld(scene);
  } catch (const SceneError& e) {
    throw UsageError(e.what());
  }
  const double dt = 1.0 / scene.fps;
  for (int i = 0; i < o.warmup; ++i) world.step(dt);
  world.resetProfile();
  const auto start = Clock::now();
  for (int i = 0; i < o.steps; ++i) world.step(dt);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return {seconds * 1e3 / o.steps, world.profile(),   world.measure(),
          world.recoveries(),      world.stateHash(), world.particleCount()};
}

const char* kCsvHeader =
    "scene,solver,iterations,threads,particles,steps,repeats,ms_per_step,ms_min,forces_ms,"
    "predict_ms,solve_ms,collisions_ms,update_ms,mprojections_per_s,speedup,efficiency,"
    "max_strain,mean_strain,state_hash,same_hash,strain_p99,recoveries,nan_count,lanes,"
    "cascade_ms\n";

}  // namespace

int runBench(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const BenchOptions o = parseBench(args);
  std::vector<Scene> scenes;
  for (const std::string& name : o.scenes) scenes.push_back(loadNamedScene(name));
  std::ofstream csv;
  if (!o.csv.empty()) {
    const fs::path parent = fs::path(o.csv).parent_path();
    if (!parent.empty() && !fs::is_directory(parent))
      throw UsageError("--csv: folder '" + parent.string() + "' does not exist");
    csv.open(o.csv);
    if (!csv) throw UsageError("--csv: cannot write '" + o.csv + "'");
    csv << kCsvHeader;
  }
  char line[512];
  std::snprintf(line, sizeof line,
                "%-16s %-12s %6s %3s %3s %9s %7s %7s %7s %7s %7s %7s %8s %6s %5s %9s %9s %5s %s\n",
                "scene", "solver", "lanes", "K", "T", "ms/step", "forces", "predict", "solve",
                "cascade", "contact", "update", "Mproj/s", "speed", "eff", "maxstrain", "meanstr",
                "recov", "state hash");
  out << line;
  for (Scene scene : scenes) {
    if (o.iterations >= 0) {
      scene.solver.iterations = o.iterations;
      scene.solver.schedule = rescaleSchedule(scene.solver.schedule, o.iterations);
    }
    const std::vector<SolverKind> solvers =
        o.solvers.empty() ? std::vector<SolverKind>{scene.solver.kind} : o.solvers;
    for (SolverKind kind : solvers) {
      scene.solver.kind = kind;
      double baseMs = 0;
      int baseThreads = 0;
      std::uint64_t baseHash = 0;
      const std::vector<LaneIsa> lanes =
          o.lanes.empty() ? std::vector<LaneIsa>{bestLaneIsa()} : o.lanes;
      for (LaneIsa isa : lanes)
        for (int threads : o.threads) {
          selectLaneIsa(isa);
          scene.threads = threads;
          std::vector<Run> runs;
          for (int r = 0; r < o.repeats; ++r) runs.push_back(runOnce(scene, o));
          std::sort(runs.begin(), runs.end(),
                    [](const Run& a, const Run& b) { return a.msPerStep < b.msPerStep; });
          const Run& median = runs[runs.size() / 2];  // the middle run (upper middle for even R)
          if (baseThreads == 0)
            baseMs = median.msPerStep, baseThreads = threads, baseHash = median.hash;
          const double steps = double(median.profile.steps);
          auto perStep = [&](double seconds) { return seconds * 1e3 / steps; };
          const StepProfile& p = median.profile;
          const double mproj = double(p.projections) / (median.msPerStep * 1e-3 * steps) * 1e-6;
          const double speedup = baseMs / median.msPerStep;
          const double efficiency = speedup * baseThreads / threads;
          const bool same = median.hash == baseHash;
          // Same meaning as nan_count in `nucleon run --stats`: non-finite values repaired during
          // the run plus those left in the final state.
          const std::uint64_t nanCount = median.recoveries.nonFinite + median.measures.nanCount;
          std::snprintf(line, sizeof line,
                        "%-16s %-12s %6s %3d %3d %9.3f %7.3f %7.3f %7.3f %7.3f %7.3f %7.3f %8.1f "
                        "%5.2fx %5.2f "
                        "%9.4f %9.5f %5llu %s%s\n",
                        scene.name.c_str(), toString(kind), laneIsaName(isa),
                        scene.solver.iterations, threads, median.msPerStep, perStep(p.forces),
                        perStep(p.predict), perStep(p.solve), perStep(p.cascade),
                        perStep(p.collisions), perStep(p.update), mproj, speedup, efficiency,
                        median.measures.maxStrain, median.measures.meanStrain,
                        static_cast<unsigned long long>(median.recoveries.total()),
                        cli::hex16(median.hash).c_str(), same ? " same" : " DIFFERENT");
          out << line << std::flush;
          if (csv)
            csv << scene.name << ',' << toString(kind) << ',' << scene.solver.iterations << ','
                << threads << ',' << median.particles << ',' << o.steps << ',' << o.repeats << ','
                << median.msPerStep << ',' << runs.front().msPerStep << ',' << perStep(p.forces)
                << ',' << perStep(p.predict) << ',' << perStep(p.solve) << ','
                << perStep(p.collisions) << ',' << perStep(p.update) << ',' << mproj << ','
                << speedup << ',' << efficiency << ',' << median.measures.maxStrain << ','
                << median.measures.meanStrain << ',' << cli::hex16(median.hash) << ','
                << (same ? 1 : 0) << ',' << median.measures.strainP99 << ','
                << median.recoveries.total() << ',' << nanCount << ',' << laneIsaName(isa) << ','
                << perStep(p.cascade) << '\n';
        }
    }
  }
  selectLaneIsa(bestLaneIsa());
  if (csv && !csv.flush()) err << "nucleon: " << o.csv << ": write failed\n";
  return 0;
}

}  // namespace nucleon
