// nucleon against Bullet's btSoftBody on the same cloth, in one process, alternating the engines
// run by run so that both see the same machine state. Prints a table with the step-time ratio and
// both engines' strain, and optionally writes every run's figures as CSV.
//
//   nucleon_bench_cloth [--n 64,128,256] [--iterations 4,10,20] [--scenes hanging,sphere,mesh]
//                       [--bending off|on|both] [--solvers colored-gs,jacobi,multigrid]
//                       (also multigrid-jacobi: multigrid with Jacobi fine sweeps)
//                       [--tethers on|off|both] [--threads 2 | 1,2] [--repeats 3] [--steps 120]
//                       [--warmup 10] [--substeps S] [--bullet-collision sdf|cluster|both]
//                       [--mesh-offset 0.15] [--csv FILE] [--no-bullet]
//
// The `mesh` scene (not in the default list) drops a free cloth onto a static icosphere triangle
// mesh with two substeps per step, the settings of nucleon's cloth_drop_sphere scene (see
// meshDropCase); its rows add the deepest penetration of a cloth vertex into the mesh over the
// run, measured by the benchmark from each engine's positions. `--bullet-collision` picks
// Bullet's soft-versus-rigid mode for that scene (SDF_RS, Bullet's default, or CL_RS); `both`
// runs Bullet twice. `--threads` takes a list: every nucleon configuration runs at each count.
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

// A backend as the comparison names it: multigrid-jacobi is multigrid with the Jacobi smoother.
struct Solver {
  SolverKind kind = SolverKind::ColoredGaussSeidel;
  SolverKind smoother = SolverKind::ColoredGaussSeidel;
  std::string name() const {
    return kind == SolverKind::Multigrid && smoother == SolverKind::Jacobi ? "multigrid-jacobi"
                                                                           : toString(kind);
  }
};

struct Options {
  std::vector<int> resolutions = {64, 128, 256};
  std::vector<int> iterations = {4, 10, 20};
  std::vector<ClothScene> scenes = {ClothScene::Hanging, ClothScene::Sphere};
  std::vector<bool> bending = {false};
  std::vector<Solver> solvers = {
      {SolverKind::ColoredGaussSeidel}, {SolverKind::Jacobi}, {SolverKind::Multigrid}};
  std::vector<bool> tethers = {true, false};
  std::vector<int> threads = {2};
  std::vector<BulletCollision> bulletCollisions = {BulletCollision::Sdf};
  double meshOffset = -1;  // mesh scene: the sphere's offset along x; < 0 keeps meshDropCase's
  int repeats = 3;
  int steps = 120;
  int warmup = 10;
  int substeps = 0;  // > 0: substeps per step for every scene (0 keeps each scene's own)
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
        else if (s == "mesh")
          o.scenes.push_back(ClothScene::Mesh);
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
        Solver solver;
        if (s == "multigrid-jacobi")
          solver = {SolverKind::Multigrid, SolverKind::Jacobi};
        else if (!parseSolverKind(s, solver.kind))
          throw std::invalid_argument("--solvers: unknown solver '" + s + "'");
        o.solvers.push_back(solver);
      }
    } else if (a == "--threads") {
      o.threads = parseIntList(a, value(), 0, 4096);
    } else if (a == "--bullet-collision") {
      const std::string v = value();
      if (v == "sdf")
        o.bulletCollisions = {BulletCollision::Sdf};
      else if (v == "cluster")
        o.bulletCollisions = {BulletCollision::Cluster};
      else if (v == "both")
        o.bulletCollisions = {BulletCollision::Sdf, BulletCollision::Cluster};
      else
        throw std::invalid_argument("--bullet-collision: expected sdf, cluster or both");
    } else if (a == "--repeats") {
      o.repeats = parseIntList(a, value(), 1, 1000).front();
    } else if (a == "--steps") {
      o.steps = parseIntList(a, value(), 2, 100000).front();
    } else if (a == "--substeps") {
      o.substeps = parseIntList(a, value(), 1, 1000).front();
    } else if (a == "--warmup") {
      o.warmup = parseIntList(a, value(), 0, 100000).front();
    } else if (a == "--mesh-offset") {
      o.meshOffset = std::stod(value());
      if (!(o.meshOffset >= 0 && o.meshOffset <= 2))
        throw std::invalid_argument("--mesh-offset: expected metres in [0, 2]");
    } else if (a == "--csv") {
      o.csv = value();
    } else if (a == "--no-bullet") {
      o.bullet = false;
    } else {
      throw std::invalid_argument("unknown option '" + a + "' (see the header of " __FILE__ ")");
    }
  }
  if (o.warmup >= o.steps) throw std::invalid_argument("--warmup must be below --steps");
  if (o.scenes.empty() || o.solvers.empty() || o.tethers.empty() || o.threads.empty())
    throw std::invalid_argument("nothing to run");
  return o;
}

// The figures of one engine configuration on one case.
struct Summary {
  std::string engine, solver;
  std::string tethers;  // on, off, or none (Bullet; a cloth without pins)
  int threads = 1;
  std::string bulletCollision;  // Bullet in the mesh scene: SDF_RS or CL_RS
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
  Summary summary;
  summary.engine = std::move(engine);
  summary.solver = std::move(solver);
  summary.tethers = std::move(tethers);
  summary.threads = threads;
  summary.result = middle;
  summary.medianMs = middle.msPerStep;
  summary.minMs = runs.front().msPerStep;
  return summary;
}

// Depth in mm of the deepest vertex below the contact distance the engines keep from the mesh,
// over the whole run.
double deepestPenetrationMm(const ClothCase& c, const RunResult& r) {
  return std::max(0.0, meshContactDistance(c) - r.meshMinDistance) * 1e3;
}

void writeCsvHeader(std::ostream& out) {
  out << "scene,bending,n,iterations,engine,solver,threads,repeats,ms_per_step,ms_min,"
         "forces_ms,predict_ms,solve_ms,collisions_ms,update_ms,projections_per_s,max_strain,"
         "mean_strain,peak_max_strain,average_mean_strain,penetration_m,lowest_y,finite,state_"
         "hash,tethers,p99_strain,substeps,bullet_collision,contact_distance_m,mesh_min_distance_m,"
         "mesh_deepest_penetration_mm,mesh_inside_end,mesh_inside_peak,mesh_min_distance_end_m,"
         "late_mean_strain,late_p99_strain,late_max_strain\n";
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
      << s.tethers << ',' << r.finalStrainP99 << ',' << c.substeps << ',' << s.bulletCollision;
  if (c.scene == ClothScene::Mesh)
    out << ',' << meshContactDistance(c) << ',' << r.meshMinDistance << ','
        << deepestPenetrationMm(c, r) << ',' << r.meshInsideAtEnd << ',' << r.meshInsidePeak << ','
        << r.meshMinDistanceAtEnd;
  else
    out << ",,,,,,";
  out << ',' << r.lateStrain.mean << ',' << r.lateStrainP99 << ',' << r.lateStrain.max << '\n';
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
  // late-*: each step's strain averaged over the second half of the run.
  std::printf("%-8s %4s %4s %4s | %-16s %-7s %3s %9s %9s %9s %9s | %9s %9s %9s | %6s\n", "scene",
              "N", "K", "bend", "engine", "tethers", "thr", "ms/step", "maxstrain", "meanstr",
              "p99strain", "late-max", "late-mean", "late-p99", "ratio");
  for (ClothScene scene : o.scenes)
    for (bool bending : o.bending)
      for (int n : o.resolutions)
        for (int k : o.iterations) {
          ClothCase c = scene == ClothScene::Mesh ? meshDropCase(n, k) : ClothCase{};
          c.scene = scene;
          c.resolution = n;
          c.iterations = k;
          c.bending = bending;
          c.steps = o.steps;
          c.warmup = o.warmup;
          if (o.substeps > 0) c.substeps = o.substeps;
          if (o.meshOffset >= 0) c.meshCenter.x() = Real(o.meshOffset);
          const ClothMesh mesh = makeClothMesh(c);
          // Every nucleon configuration: solver × tethers × threads.
          struct Configuration {
            Solver solver;
            bool tethers;
            int threads;
          };
          std::vector<Configuration> configurations;
          for (const Solver& solver : o.solvers)
            for (bool tethers : o.tethers)
              for (int threads : o.threads) configurations.push_back({solver, tethers, threads});
          // Bullet once, or once per collision mode in the mesh scene.
          std::vector<ClothCase> bulletCases;
          if (withBullet) {
            if (scene == ClothScene::Mesh)
              for (BulletCollision mode : o.bulletCollisions) {
                bulletCases.push_back(c);
                bulletCases.back().bulletCollision = mode;
              }
            else
              bulletCases.push_back(c);
          }
          // Alternate: each repeat runs every configuration once, Bullet first.
          std::vector<std::vector<RunResult>> bulletRuns(bulletCases.size());
          std::vector<std::vector<RunResult>> nucleonRuns(configurations.size());
          for (int rep = 0; rep < o.repeats; ++rep) {
            for (std::size_t b = 0; b < bulletCases.size(); ++b)
              bulletRuns[b].push_back(runBulletCloth(bulletCases[b], mesh));
            for (std::size_t s = 0; s < configurations.size(); ++s) {
              ClothCase variant = c;
              variant.tethers = configurations[s].tethers;
              nucleonRuns[s].push_back(runNucleonCloth(variant, mesh, configurations[s].solver.kind,
                                                       configurations[s].threads,
                                                       configurations[s].solver.smoother));
            }
          }
          std::vector<Summary> rows;
          for (std::size_t b = 0; b < bulletCases.size(); ++b) {
            rows.push_back(summarise("bullet", "btSoftBody", "none", 1, bulletRuns[b]));
            if (scene == ClothScene::Mesh)
              rows.back().bulletCollision = toString(bulletCases[b].bulletCollision);
          }
          for (std::size_t s = 0; s < configurations.size(); ++s)
            rows.push_back(summarise("nucleon", configurations[s].solver.name(),
                                     configurations[s].tethers ? "on" : "off",
                                     configurations[s].threads, nucleonRuns[s]));
          for (const Summary& row : rows) {
            const std::string label =
                row.engine == "bullet" ? ("bullet " + row.bulletCollision) : row.solver;
            std::printf(
                "%-8s %4d %4d %4s | %-16s %-7s %3d %9.3f %9.4f %9.5f %9.5f | %9.4f %9.5f %9.5f |",
                toString(scene), n, k, bending ? "yes" : "no", label.c_str(), row.tethers.c_str(),
                row.threads, row.medianMs, row.result.finalStrain.max, row.result.finalStrain.mean,
                row.result.finalStrainP99, row.result.lateStrain.max, row.result.lateStrain.mean,
                row.result.lateStrainP99);
            if (withBullet && row.engine == "nucleon")
              std::printf(" %5.2fx", rows.front().medianMs / row.medianMs);
            if (scene == ClothScene::Mesh)
              std::printf(" | deepest %.1f mm, inside at end %d (peak %d), closest at end %.1f mm",
                          deepestPenetrationMm(c, row.result), row.result.meshInsideAtEnd,
                          row.result.meshInsidePeak, row.result.meshMinDistanceAtEnd * 1e3);
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
