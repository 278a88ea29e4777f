// `nucleon bench`: a thread sweep reports one row per configuration, the deterministic backends
// give the same final state at every thread count, and bad input is rejected with exit code 2.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "nucleon/lanes.h"

#include "engine/app/cli.h"

namespace nucleon {
namespace {

std::vector<std::string> readLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::istringstream in(line);
  for (std::string field; std::getline(in, field, ',');) fields.push_back(field);
  return fields;
}

std::size_t column(const std::vector<std::string>& header, const std::string& name) {
  const auto at = std::find(header.begin(), header.end(), name);
  EXPECT_NE(at, header.end()) << "no column " << name;
  return static_cast<std::size_t>(at - header.begin());
}

TEST(BenchCommand, ThreadSweepWritesOneRowPerConfigurationWithEqualHashes) {
  const std::string csv =
      (std::filesystem::temp_directory_path() / "nucleon_bench_command_test.csv").string();
  std::ostringstream out, err;
  const std::string scene = std::string(NUCLEON_ASSETS_DIR) + "/scenes/cloth_hang.json";
  const int code =
      runCommandLine({"bench", scene, "--threads", "1,2", "--solver", "colored-gs,jacobi",
                      "--steps", "4", "--warmup", "1", "--repeats", "1", "--csv", csv},
                     out, err);
  ASSERT_EQ(code, 0) << err.str();
  const std::vector<std::string> lines = readLines(csv);
  ASSERT_EQ(lines.size(), 5u);  // header + 2 solvers × 2 thread counts
  EXPECT_EQ(lines[0].rfind("scene,solver,iterations,threads", 0), 0u);
  const std::vector<std::string> header = split(lines[0]);
  const std::size_t sameHash = column(header, "same_hash");
  const std::size_t recoveries = column(header, "recoveries");
  const std::size_t nanCount = column(header, "nan_count");
  ASSERT_LT(std::max({sameHash, recoveries, nanCount}), header.size());
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> row = split(lines[i]);
    ASSERT_EQ(row.size(), header.size()) << lines[i];
    // Whether the final state equals the first thread count's.
    EXPECT_EQ(row[sameHash], "1") << lines[i];
    EXPECT_EQ(row[recoveries], "0") << lines[i];
    EXPECT_EQ(row[nanCount], "0") << lines[i];
    EXPECT_EQ(row[0], "cloth_hang");
  }
  EXPECT_NE(out.str().find("colored-gs"), std::string::npos);
  std::filesystem::remove(csv);
}

TEST(BenchCommand, RejectsBadInput) {
  std::ostringstream out, err;
  EXPECT_EQ(runCommandLine({"bench"}, out, err), 2);
  EXPECT_EQ(runCommandLine({"bench", "no_such_scene"}, out, err), 2);
  EXPECT_EQ(runCommandLine({"bench", "cloth_hang", "--threads", "0"}, out, err), 2);
  EXPECT_EQ(runCommandLine({"bench", "cloth_hang", "--solver", "newton"}, out, err), 2);
  EXPECT_EQ(runCommandLine({"bench", "cloth_hang", "--csv", "/no/such/folder/x.csv"}, out, err), 2);
  EXPECT_NE(err.str().find("--solver"), std::string::npos);
  EXPECT_EQ(runCommandLine({"bench", "cloth_hang", "--lanes", "sse4"}, out, err), 2);
  EXPECT_NE(err.str().find("--lanes"), std::string::npos);
}

// Every lane set the CPU runs, in one run: one row each, with the set named; the sets give the
// same state (nucleon/lanes.h), so every row's hash equals the first's.
TEST(BenchCommand, LaneSetsGiveOneRowEachAndTheSameHash) {
  std::vector<std::string> sets = {"avx2", "avx512"};
  sets.resize(static_cast<std::size_t>(bestLaneIsa()));  // the sets this CPU runs
  if (sets.empty()) GTEST_SKIP() << "no batched kernels in this build or CPU";
  std::string list;
  for (const std::string& set : sets) list += (list.empty() ? "" : ",") + set;
  const std::string csv =
      (std::filesystem::temp_directory_path() / "nucleon_bench_lanes_test.csv").string();
  std::ostringstream out, err;
  const std::string scene = std::string(NUCLEON_ASSETS_DIR) + "/scenes/cloth_hang.json";
  ASSERT_EQ(runCommandLine({"bench", scene, "--threads", "2", "--solver", "colored-gs", "--lanes",
                            list, "--steps", "4", "--warmup", "1", "--repeats", "1", "--csv", csv},
                           out, err),
            0)
      << err.str();
  const std::vector<std::string> lines = readLines(csv);
  ASSERT_EQ(lines.size(), sets.size() + 1);
  const std::vector<std::string> header = split(lines[0]);
  const std::size_t lanes = column(header, "lanes"), sameHash = column(header, "same_hash");
  for (std::size_t i = 0; i < sets.size(); ++i) {
    const std::vector<std::string> row = split(lines[i + 1]);
    ASSERT_EQ(row.size(), header.size()) << lines[i + 1];
    EXPECT_EQ(row[lanes], sets[i]);
    EXPECT_EQ(row[sameHash], "1") << lines[i + 1];
  }
  EXPECT_EQ(laneIsa(), bestLaneIsa());  // the bench leaves the best set selected
  std::filesystem::remove(csv);
}

}  // namespace
}  // namespace nucleon
