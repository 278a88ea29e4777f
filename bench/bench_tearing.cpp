// Frame times of the tearing scenes: p50 and p99 over all frames, and where the time of the frame
// after a tear goes (the stages of the step, tearing itself and the derived tables it rebuilds),
// against the frames without one.
//
//   build/bench/nucleon_bench_tearing [SCENE.json ...] [--threads T] [--repeats R]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "nucleon/scene.h"
#include "nucleon/world.h"

using namespace nucleon;

namespace {

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * double(values.size()) - 1e-9));
  return values[std::min(values.size(), std::max<std::size_t>(rank, 1)) - 1];
}

// One frame's milliseconds per stage: the step as a whole, the broad and narrow phases, the
// solve, the rest of the collisions, tearing and the derived tables.
struct Frame {
  double step = 0, broad = 0, narrow = 0, solve = 0, collisions = 0, tear = 0, tables = 0;
};

Frame difference(const StepProfile& a, const StepProfile& b, double step) {
  return {step,
          (a.broadPhase - b.broadPhase) * 1e3,
          (a.narrowPhase - b.narrowPhase) * 1e3,
          (a.solve - b.solve) * 1e3,
          (a.collisions - b.collisions) * 1e3,
          (a.tear - b.tear) * 1e3,
          (a.derivedTables - b.derivedTables) * 1e3};
}

void report(const char* label, const std::vector<Frame>& frames) {
  auto median = [&](double Frame::*field) {
    std::vector<double> v;
    for (const Frame& f : frames) v.push_back(f.*field);
    return percentile(v, 0.5);
  };
  std::printf(
      "  %-22s %4zu frames: step p50 %6.2f | broad %5.2f narrow %5.2f solve %5.2f "
      "collisions %5.2f tear %5.2f tables %5.2f ms\n",
      label, frames.size(), median(&Frame::step), median(&Frame::broad), median(&Frame::narrow),
      median(&Frame::solve), median(&Frame::collisions), median(&Frame::tear),
      median(&Frame::tables));
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenes;
  int threads = 2, repeats = 3;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--threads" && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (arg == "--repeats" && i + 1 < argc)
      repeats = std::atoi(argv[++i]);
    else
      scenes.push_back(arg);
  }
  if (scenes.empty())
    scenes = {std::string(NUCLEON_ASSETS_DIR) + "/scenes/tear.json",
              std::string(NUCLEON_ASSETS_DIR) + "/scenes/bullet_cloth_tear.json"};
  for (const std::string& path : scenes) {
    const Scene scene = loadScene(path);
    std::vector<double> all;
    std::vector<Frame> afterTear, others;
    TearReport tears;
    for (int r = 0; r < repeats; ++r) {
      World world = buildWorld(scene);
      world.setThreads(threads);
      bool tore = false;
      for (int frame = 0; frame < scene.frames; ++frame) {
        const StepProfile before = world.profile();
        const std::uint64_t splits = world.tearReport().newVertices;
        const auto start = std::chrono::steady_clock::now();
        world.step(1.0 / scene.fps);
        const double ms =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() * 1e3;
        all.push_back(ms);
        // A tear's rebuild and new search fall in the step after the one that tore.
        (tore ? afterTear : others).push_back(difference(world.profile(), before, ms));
        tore = world.tearReport().newVertices > splits;
      }
      tears = world.tearReport();
    }
    std::printf(
        "%s: %d threads, %d repeats: frame p50 %.2f ms, p99 %.2f ms, max %.2f ms; %llu splits, "
        "%llu torn edges, %llu refused\n",
        scene.name.c_str(), threads, repeats, percentile(all, 0.5), percentile(all, 0.99),
        percentile(all, 1.0), static_cast<unsigned long long>(tears.newVertices),
        static_cast<unsigned long long>(tears.tornEdges),
        static_cast<unsigned long long>(tears.refusedTears));
    report("after a tear", afterTear);
    report("other frames", others);
  }
}
