// nucleon against Bullet's btSoftBody on the same cloth, in one process, alternating the engines
// run by run so that both see the same machine state. Prints a table with the step-time ratio and
// both engines' strain, and optionally writes every run's figures as CSV.
//
//   nucleon_bench_cloth [--n 64,128,256] [--iterations 4,10,20] [--scenes hanging,sphere]
//                       [--bending off|on|both] [--solvers colored-gs,jacobi]
//                       [--tethers on|off|both] [--threads 2] [--repeats 3] [--steps 120]
//                       [--warmup 10] [--csv FILE] [--no-bullet]
//
// Bullet's cloth has no long-range attachments; nucleon's pinned cloth has tethers by default.
// `--tethers both` (the default) runs every nucleon configuration with and without them, so that
// the comparison shows both nucleon as it ships and nucleon on exactly Bullet's constraint set.
// The `tethers` column says which: on, off, or none where the cloth has no tethers to switch
// (Bullet, or a cloth without pins).
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/cloth_case.h"
#include "engine/app/cli_args.h"

namespace nucleon::bench {
namespace {

using cli::parseIntList;
using cli::splitList;

struct Options {
  std::vector<int> resolutions = {64, 128, 256};
  std::vector<int> iterations = {4, 10, 20};
  std::vector<ClothScene> scenes = {ClothScene::Hanging, ClothScene::Sphere};
  std::vector<bool> bending = {false};
  std::vector<SolverKind> solvers = {SolverKind::ColoredGaussSeidel, SolverKind::Jacobi};
  std::vector<bool> tethers = {true, false};
  int threads = 2;
  int repeats = 3;
  int steps = 120;
  int warmup = 10;
  std::string csv;
  bool bullet = true;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--n") {
      o.resolutions = parseIntList(a, value(), 2, 2048);
    } else if (a == "--iterations") {
      o.iterations = parseIntList(a, value(), 1, 1000);
    } else if (a == "--scenes") {
      o.scenes.clear();
      for (const std::string& s : splitList(value())) {
        if (s == "hanging")
          o.scenes.push_back(ClothScene::Hanging);
        else if (s == "sphere")
          o.scenes.push_back(ClothScene::Sphere);
        else
          throw std::invalid_argument("--scenes: unknown scene '" + s + "'");
      }
    } else if (a == "--bending") {
      const std::string v = value();
      if (v == "off")
        o.bending = {false};
      else if (v == "on")
        o.bending = {true};
      else if (v == "both")
        o.bending = {false, true};
      else
        throw std::invalid_argument("--bending: expected off, on or both");
    } else if (a == "--tethers") {
      const std::string v = value();
      if (v == "on")
        o.tethers = {true};
      else if (v == "off")
        o.tethers = {false};
      else if (v == "both")
        o.tethers = {true, false};
      else
        throw std::invalid_argument("--tethers: expected on, off or both");
    } else if (a == "--solvers") {
      o.solvers.clear();
      for (const std::string& s : splitList(value())) {
        SolverKind kind;
        if (!parseSolverKind(s, kind) || kind == SolverKind::Multigrid)
          throw std::invalid_argument("--solvers: unknown solver '" + s + "'");
        o.solvers.push_back(kind);
      }
    } else if (a == "--threads") {
      o.threads = parseIntList(a, value(), 0, 4096).front();
    } else if (a == "--repeats") {
      o.repeats = parseIntList(a, value(), 1, 1000).front();
    } else if (a == "--steps") {
      o.steps = parseIntList(a, value(), 2, 100000).front();
    } else if (a == "--warmup") {
      o.warmup = parseIntList(a, value(), 0, 100000).front();
    } else if (a == "--csv") {
      o.csv = value();
    } else if (a == "--no-bullet") {
      o.bullet = false;
    } else {
      throw std::invalid_argument("unknown option '" + a + "' (see the header of " __FILE__ ")");
    }
  }
  if (o.warmup >= o.steps) throw std::invalid_argument("--warmup must be below --steps");
  if (o.scenes.empty() || o.solvers.empty() || o.tethers.empty())
    throw std::invalid_argument("nothing to run");
  return o;
}

// The figures of one engine configuration on one case.
struct Summary {
  std::string engine, solver;
  std::string tethers;  // on, off, or none (Bullet; a cloth without pins)
  int threads = 1;
  RunResult result;
  double medianMs = 0, minMs = 0;
};

Summary summarise(std::string engine, std::string solver, std::string tethers, int threads,
                  std::vector<RunResult> runs) {
  // The run with the median step time supplies every figure, so that its stage profile adds up
  // to the step time shown beside it.
  std::sort(runs.begin(), runs.end(),
            [](const RunResult& a, const RunResult& b) { return a.msPerStep < b.msPerStep; });
  const RunResult& middle = runs[runs.size() / 2];
  if (tethers == "on" && middle.tetherCount == 0) tethers = "none";  // nothing to switch
  return {std::move(engine), std::move(solver),     std::move(tethers), threads, middle,
          middle.msPerStep,  runs.front().msPerStep};
}

void writeCsvHeader(std::ostream& out) {
  out << "scene,bending,n,iterations,engine,solver,threads,repeats,ms_per_step,ms_min,"
         "forces_ms,predict_ms,solve_ms,collisions_ms,update_ms,projections_per_s,max_strain,"
         "mean_strain,peak_max_strain,average_mean_strain,penetration_m,lowest_y,finite,state_"
         "hash,tethers,p99_strain\n";
}

void writeCsvRow(std::ostream& out, const ClothCase& c, int repeats, const Summary& s) {
  const RunResult& r = s.result;
  char hash[32];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(r.stateHash));
  out << toString(c.scene) << ',' << (c.bending ? 1 : 0) << ',' << c.resolution << ','
      << c.iterations << ',' << s.engine << ',' << s.solver << ',' << s.threads << ',' << repeats
      << ',' << s.medianMs << ',' << s.minMs << ',' << r.forcesMs << ',' << r.predictMs << ','
      << r.solveMs << ',' << r.collisionsMs << ',' << r.updateMs << ',' << r.projectionsPerSecond
      << ',' << r.finalStrain.max << ',' << r.finalStrain.mean << ',' << r.peakMaxStrain << ','
      << r.averageMeanStrain << ',' << (c.scene == ClothScene::Sphere ? r.penetration : 0.0) << ','
      << r.lowestY << ',' << (r.finite ? 1 : 0) << ',' << (s.engine == "nucleon" ? hash : "") << ','
      << s.tethers << ',' << r.finalStrainP99 << '\n';
}

int run(const Options& o) {
  const bool withBullet = o.bullet && bulletAvailable();
  if (o.bullet && !withBullet)
    std::cerr << "nucleon_bench_cloth: built without Bullet (install libbullet-dev and "
                 "reconfigure); running nucleon only\n";
  std::ofstream csv;
  if (!o.csv.empty()) {
    csv.open(o.csv);
    if (!csv) throw std::runtime_error(o.csv + ": cannot write");
    writeCsvHeader(csv);
  }
  std::printf("%-8s %4s %4s %4s | %-14s %-7s %9s %9s %9s %9s | %6s\n", "scene", "N", "K", "bend",
              "engine", "tethers", "ms/step", "maxstrain", "meanstr", "p99strain", "ratio");
  for (ClothScene scene : o.scenes)
    for (bool bending : o.bending)
      for (int n : o.resolutions)
        for (int k : o.iterations) {
          ClothCase c;
          c.scene = scene;
          c.resolution = n;
          c.iterations = k;
          c.bending = bending;
          c.steps = o.steps;
          c.warmup = o.warmup;
          const ClothMesh mesh = makeClothMesh(c);
          // Every nucleon configuration: solver × tethers.
          struct Configuration {
            SolverKind solver;
            bool tethers;
          };
          std::vector<Configuration> configurations;
          for (SolverKind solver : o.solvers)
            for (bool tethers : o.tethers) configurations.push_back({solver, tethers});
          // Alternate: each repeat runs every configuration once, Bullet first.
          std::vector<RunResult> bulletRuns;
          std::vector<std::vector<RunResult>> nucleonRuns(configurations.size());
          for (int rep = 0; rep < o.repeats; ++rep) {
            if (withBullet) bulletRuns.push_back(runBulletCloth(c, mesh));
            for (std::size_t s = 0; s < configurations.size(); ++s) {
              ClothCase variant = c;
              variant.tethers = configurations[s].tethers;
              nucleonRuns[s].push_back(
                  runNucleonCloth(variant, mesh, configurations[s].solver, o.threads));
            }
          }
          std::vector<Summary> rows;
          if (withBullet) rows.push_back(summarise("bullet", "btSoftBody", "none", 1, bulletRuns));
          for (std::size_t s = 0; s < configurations.size(); ++s)
            rows.push_back(summarise("nucleon", toString(configurations[s].solver),
                                     configurations[s].tethers ? "on" : "off", o.threads,
                                     nucleonRuns[s]));
          for (const Summary& row : rows) {
            const std::string label = row.engine == "bullet" ? "bullet" : row.solver;
            std::printf("%-8s %4d %4d %4s | %-14s %-7s %9.3f %9.4f %9.5f %9.5f |", toString(scene),
                        n, k, bending ? "yes" : "no", label.c_str(), row.tethers.c_str(),
                        row.medianMs, row.result.finalStrain.max, row.result.finalStrain.mean,
                        row.result.finalStrainP99);
            if (withBullet && row.engine == "nucleon")
              std::printf(" %5.2fx", rows.front().medianMs / row.medianMs);
            std::printf("\n");
            if (csv) writeCsvRow(csv, c, o.repeats, row);
          }
          std::fflush(stdout);
        }
  return 0;
}

}  // namespace
}  // namespace nucleon::bench

int main(int argc, char** argv) {
  try {
    return nucleon::bench::run(nucleon::bench::parse(argc, argv));
  } catch (const std::exception& e) {
    std::cerr << "nucleon_bench_cloth: " << e.what() << '\n';
    return 2;
  }
}
