#include "engine/app/ccd_command.h"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <ostream>
#include <sstream>

#include "engine/app/cli_args.h"
#include "systems/collision/ccd.h"

namespace nucleon {

const char* const kCcdHelp =
    "nucleon ccd QUERIES.txt [options]: continuous collision detection on a query file.\n"
    "  --answers FILE    write one line 'H T' per query: H = 1 for a hit, T = a lower bound\n"
    "                    of the earliest time of contact (1 without a hit)\n"
    "  --thickness D     minimum separation distance, D >= 0 (default 0: touching)\n"
    "Query file: one query per line, '#' starts a comment line. 'vf' then 24 numbers: point,\n"
    "triangle v0 v1 v2 at t = 0, then the same at t = 1; or 'ee' then 24 numbers: edge a0 a1,\n"
    "edge b0 b1 at t = 0, then at t = 1; then an optional 0/1 truth. Prints queries, hits and\n"
    "nanoseconds per query for each kind and, when every query has a truth, the false\n"
    "negatives and false positives. Bad input: exit code 2, no answers file written.\n";

namespace {

using cli::parseNumber;
using cli::UsageError;
using Clock = std::chrono::steady_clock;

enum class QueryKind { VertexFace, EdgeEdge };
constexpr int kKinds = 2;
constexpr const char* kKindNames[kKinds] = {"vf", "ee"};

struct Query {
  QueryKind kind;
  std::array<Vec3d, 8> points;
  int truth = -1;  // -1: none given
};

struct CcdOptions {
  std::string queries, answers;
  double thickness = 0;
};

CcdOptions parseCcd(const std::vector<std::string>& args) {
  CcdOptions o;
  for (cli::Arguments arguments(args); arguments.next();) {
    const std::string& a = arguments.current();
    const auto value = [&]() -> const std::string& { return arguments.value(); };
    if (a == "--answers")
      o.answers = value();
    else if (a == "--thickness")
      o.thickness = parseNumber(a, value(), 0, std::numeric_limits<double>::infinity());
    else if (!a.empty() && a[0] == '-')
      throw UsageError("unknown option '" + a + "'");
    else if (o.queries.empty())
      o.queries = a;
    else
      throw UsageError("unexpected argument '" + a + "'");
  }
  if (o.queries.empty()) throw UsageError("ccd needs a query file");
  return o;
}

std::vector<Query> loadQueries(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw UsageError(path + ": cannot open");
  std::vector<Query> queries;
  int lineNumber = 0;
  for (std::string line; std::getline(in, line);) {
    ++lineNumber;
    std::istringstream fields(line);
    std::string kind;
    if (!(fields >> kind) || kind[0] == '#') continue;
    auto fail = [&](const std::string& why) {
      return UsageError(path + ":" + std::to_string(lineNumber) + ": " + why);
    };
    Query q;
    if (kind == "vf")
      q.kind = QueryKind::VertexFace;
    else if (kind == "ee")
      q.kind = QueryKind::EdgeEdge;
    else
      throw fail("unknown query kind '" + kind + "' (expected vf or ee)");
    std::string token;
    for (int i = 0; i < 24; ++i) {
      if (!(fields >> token)) throw fail("expected 24 coordinates, got " + std::to_string(i));
      char* end = nullptr;
      const double x = std::strtod(token.c_str(), &end);
      if (end != token.c_str() + token.size() || !std::isfinite(x))
        throw fail("'" + token + "' is not a finite number");
      q.points[i / 3][i % 3] = x;
    }
    if (fields >> token) {
      if (token != "0" && token != "1") throw fail("truth must be 0 or 1, got '" + token + "'");
      q.truth = token == "1";
    }
    if (fields >> token) throw fail("unexpected field '" + token + "'");
    queries.push_back(q);
  }
  return queries;
}

CcdResult solve(const Query& q, double thickness) {
  const auto& x = q.points;
  if (q.kind == QueryKind::VertexFace)
    return vertexFaceCcd(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], thickness);
  return edgeEdgeCcd(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], thickness);
}

}  // namespace

int runCcd(const std::vector<std::string>& args, std::ostream& out, std::ostream& /*err*/) {
  const CcdOptions o = parseCcd(args);
  const std::vector<Query> queries = loadQueries(o.queries);

  std::vector<CcdResult> results(queries.size());
  struct Tally {
    int queries = 0, hits = 0, withTruth = 0, falseNegatives = 0, falsePositives = 0;
    double seconds = 0;
  } tally[kKinds];
  // Kinds are timed separately over the whole file, one clock reading per pass, and passes are
  // repeated up to a tenth of a second so that a small file still gives a stable figure.
  for (int k = 0; k < kKinds; ++k) {
    const QueryKind kind = static_cast<QueryKind>(k);
    int passes = 0;
    const auto start = Clock::now();
    double elapsed = 0;
    do {
      for (std::size_t i = 0; i < queries.size(); ++i)
        if (queries[i].kind == kind) results[i] = solve(queries[i], o.thickness);
      ++passes;
      elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    } while (elapsed < 0.1 && passes < 1000);
    tally[k].seconds = elapsed / passes;
  }
  for (std::size_t i = 0; i < queries.size(); ++i) {
    Tally& t = tally[static_cast<int>(queries[i].kind)];
    ++t.queries;
    t.hits += results[i].hit;
    if (queries[i].truth < 0) continue;
    ++t.withTruth;
    t.falseNegatives += queries[i].truth == 1 && !results[i].hit;
    t.falsePositives += queries[i].truth == 0 && results[i].hit;
  }

  if (!o.answers.empty()) {
    std::ofstream file(o.answers);
    if (!file) throw UsageError(o.answers + ": cannot write");
    file << std::setprecision(17);
    for (const CcdResult& r : results) file << (r.hit ? 1 : 0) << ' ' << r.toi << '\n';
    if (!file) throw std::runtime_error(o.answers + ": cannot write");
  }

  out << o.queries << ": " << queries.size() << " queries, thickness " << o.thickness << '\n';
  for (int k = 0; k < kKinds; ++k) {
    const Tally& t = tally[k];
    if (t.queries == 0) continue;
    out << "  " << kKindNames[k] << ": " << t.queries << " queries, " << t.hits << " hits, "
        << std::fixed << std::setprecision(0) << t.seconds / t.queries * 1e9 << " ns/query"
        << std::defaultfloat;
    if (t.withTruth == t.queries)
      out << ", false negatives " << t.falseNegatives << ", false positives " << t.falsePositives;
    out << '\n';
  }
  if (!o.answers.empty()) out << "  answers: " << o.answers << '\n';
  return 0;
}

}  // namespace nucleon
