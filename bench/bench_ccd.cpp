// Continuous collision detection (systems/collision/ccd.h) on the public query set
// tests/data/ccd_public.txt (vertex–face and edge–edge queries with exact ground truth): time per
// query for each kind, at thickness 0 and 1e-3, with the hits and, against the thickness-0 truth,
// the false negatives and false positives. At thickness 1e-3 the truth no longer applies to near
// misses, so the false positives there count pairs that come within the thickness without touching.
#include <array>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "systems/collision/ccd.h"

namespace nucleon {
namespace {

struct Query {
  std::array<Vec3d, 8> x;
  int truth = 0;
};

struct QuerySet {
  std::vector<Query> vertexFace, edgeEdge;
};

const QuerySet& publicSet() {
  static const QuerySet set = [] {
    const std::string path = std::string(NUCLEON_SHARED_DATA) + "/ccd_public.txt";
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open");
    QuerySet s;
    for (std::string line; std::getline(in, line);) {
      std::istringstream fields(line);
      std::string kind;
      if (!(fields >> kind) || kind[0] == '#') continue;
      Query q;
      for (int i = 0; i < 24; ++i) fields >> q.x[i / 3][i % 3];
      fields >> q.truth;
      (kind == "vf" ? s.vertexFace : s.edgeEdge).push_back(q);
    }
    return s;
  }();
  return set;
}

template <bool kVertexFace>
void BM_Ccd(benchmark::State& state) {
  const double thickness = state.range(0) == 0 ? 0.0 : 1e-3;
  const std::vector<Query>& queries = kVertexFace ? publicSet().vertexFace : publicSet().edgeEdge;
  int hits = 0, falseNegatives = 0, falsePositives = 0;
  for (auto _ : state) {
    hits = falseNegatives = falsePositives = 0;
    for (const Query& q : queries) {
      const auto& x = q.x;
      const CcdResult r =
          kVertexFace ? vertexFaceCcd(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], thickness)
                      : edgeEdgeCcd(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], thickness);
      benchmark::DoNotOptimize(r);
      hits += r.hit;
      falseNegatives += q.truth == 1 && !r.hit;
      falsePositives += q.truth == 0 && r.hit;
    }
  }
  const double n = static_cast<double>(queries.size());
  state.counters["queries"] = n;
  state.counters["hits"] = hits;
  state.counters["false_negatives"] = falseNegatives;
  state.counters["false_positives"] = falsePositives;
  // Seconds per query (CPU time), printed with its SI prefix: "500ns".
  state.counters["time_per_query"] = benchmark::Counter(
      n, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.SetItemsProcessed(static_cast<std::int64_t>(n) * state.iterations());
}

// Argument: 0 for thickness 0, 1 for thickness 1e-3.
BENCHMARK(BM_Ccd<true>)->Name("BM_CcdVertexFace")->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Ccd<false>)->Name("BM_CcdEdgeEdge")->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace nucleon
