#include "engine/app/sweep_command.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "engine/app/cli_args.h"
#include "nucleon/scene.h"

extern char** environ;

namespace nucleon {

const char* const kSweepHelp =
    "nucleon sweep SCENE.json --set KEY=V1,V2,.. [options]: runs the scene once per point of\n"
    "the grid the --set flags span (every combination of their values) and gathers the runs'\n"
    "stats into one CSV.\n"
    "  --set KEY=V1,V2   a setting of the scene file (as `run --set`) and its values, split at\n"
    "                    commas (repeatable; at least one)\n"
    "  --frames N        frames per run (default: the scene's)\n"
    "  --threads T       worker threads per run (default 1: the runs are the parallelism)\n"
    "  --jobs J          runs at once (default: the cores)\n"
    "  --out DIR         the sweep's folder (default sweep_SCENE): runs.csv (the grid),\n"
    "                    jobs.txt (one `nucleon run` command a line), slurm.sh, and per run its\n"
    "                    stats (run_NNNN.json) and output (run_NNNN.log)\n"
    "  --csv FILE        the gathered results (default DIR/results.csv)\n"
    "  --emit            write the folder and stop, without running: then run jobs.txt with\n"
    "                    GNU parallel (parallel --jobs J < DIR/jobs.txt) or submit slurm.sh\n"
    "                    (sbatch DIR/slurm.sh), and gather with --gather\n"
    "nucleon sweep --gather DIR [--csv FILE]: gathers the stats of the runs found in DIR.\n"
    "Results: one row per run, its settings, status (ok, failed, missing) and stats; exit 1 when "
    "a\n"
    "run failed or is missing. Bad input: exit 2 before anything is written.\n";

namespace {

namespace fs = std::filesystem;
using cli::UsageError;

struct Axis {
  std::string key;
  std::vector<std::string> values;
};

struct SweepOptions {
  std::string scene, outDir, csv, gather;
  std::vector<Axis> axes;
  int frames = 0, threads = 1, jobs = 0;
  bool emit = false;
};

SweepOptions parseSweep(const std::vector<std::string>& args) {
  SweepOptions o;
  for (cli::Arguments arguments(args); arguments.next();) {
    const std::string& a = arguments.current();
    const auto value = [&]() -> const std::string& { return arguments.value(); };
    if (a == "--set") {
      const std::string& entry = value();
      const std::size_t equals = entry.find('=');
      if (equals == std::string::npos || equals == 0)
        throw UsageError("--set: '" + entry + "' is not KEY=V1,V2,..");
      Axis axis{entry.substr(0, equals), cli::splitList(entry.substr(equals + 1))};
      if (axis.values.empty()) throw UsageError("--set: '" + entry + "' has no values");
      for (const Axis& other : o.axes)
        if (other.key == axis.key) throw UsageError("--set: '" + axis.key + "' is set twice");
      o.axes.push_back(axis);
    } else if (a == "--frames")
      o.frames = cli::parseInt(a, value(), 1, 1000000);
    else if (a == "--threads")
      o.threads = cli::parseInt(a, value(), 0, 4096);
    else if (a == "--jobs")
      o.jobs = cli::parseInt(a, value(), 1, 4096);
    else if (a == "--out")
      o.outDir = value();
    else if (a == "--csv")
      o.csv = value();
    else if (a == "--gather")
      o.gather = value();
    else if (a == "--emit")
      o.emit = true;
    else if (!a.empty() && a[0] == '-')
      throw UsageError("unknown option '" + a + "'");
    else if (o.scene.empty())
      o.scene = a;
    else
      throw UsageError("unexpected argument '" + a + "'");
  }
  if (!o.gather.empty()) {
    if (!o.scene.empty() || !o.axes.empty())
      throw UsageError("--gather takes a sweep folder, not a scene or --set");
    return o;
  }
  if (o.scene.empty()) throw UsageError("sweep needs a scene file");
  if (o.axes.empty()) throw UsageError("sweep needs at least one --set KEY=V1,V2,..");
  return o;
}

// Single quotes for a POSIX shell: the job lines are run by sh (here, GNU parallel, Slurm).
std::string quoted(const std::string& text) {
  std::string q = "'";
  for (const char c : text) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string runName(std::size_t run) {
  std::ostringstream name;
  name << "run_" << std::setw(4) << std::setfill('0') << run;
  return name.str();
}

// Every combination of the axes' values, the last axis varying fastest.
std::vector<std::vector<std::string>> gridPoints(const std::vector<Axis>& axes) {
  std::vector<std::vector<std::string>> points(1);
  for (const Axis& axis : axes) {
    std::vector<std::vector<std::string>> next;
    for (const auto& point : points)
      for (const std::string& value : axis.values) {
        next.push_back(point);
        next.back().push_back(value);
      }
    points.swap(next);
  }
  return points;
}

// The program's own path, so that the job lines run this build.
std::string selfPath() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("nucleon") : self.string();
}

std::vector<std::string> splitCsvLine(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  bool inQuotes = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (inQuotes) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"')
        field += '"', ++i;
      else if (c == '"')
        inQuotes = false;
      else
        field += c;
    } else if (c == '"')
      inQuotes = true;
    else if (c == ',')
      fields.push_back(field), field.clear();
    else
      field += c;
  }
  fields.push_back(field);
  return fields;
}

std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string q = "\"";
  for (const char c : text) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// The stats each row carries, by their names in the run's --stats JSON.
constexpr const char* kColumns[] = {"ms_per_step", "wall_s",        "mean_strain", "strain_p99",
                                    "max_strain",  "intersections", "recoveries",  "nan_count",
                                    "contacts",    "state_hash"};

// Reads DIR/runs.csv and each run's stats into one CSV; returns the runs that failed or are
// missing.
std::size_t gather(const fs::path& dir, const fs::path& csv, std::ostream& out) {
  std::ifstream grid(dir / "runs.csv");
  if (!grid) throw UsageError("--gather: '" + (dir / "runs.csv").string() + "' is missing");
  std::string headerLine;
  std::getline(grid, headerLine);
  const std::vector<std::string> header = splitCsvLine(headerLine);
  if (header.empty() || header[0] != "run")
    throw UsageError("--gather: '" + (dir / "runs.csv").string() + "' is not a sweep's grid");
  std::ostringstream table;
  for (std::size_t k = 0; k < header.size(); ++k) table << (k ? "," : "") << csvField(header[k]);
  table << ",status,clean";
  for (const char* column : kColumns) table << ',' << column;
  table << '\n';
  std::size_t runs = 0, bad = 0;
  for (std::string line; std::getline(grid, line);) {
    if (line.empty()) continue;
    ++runs;
    const std::vector<std::string> row = splitCsvLine(line);
    for (std::size_t k = 0; k < row.size(); ++k) table << (k ? "," : "") << csvField(row[k]);
    const fs::path statsFile = dir / (row[0] + ".json");
    nlohmann::json stats;
    std::string status = "ok";
    std::ifstream in(statsFile);
    if (!in)  // a run that stopped with an error leaves its log and no stats
      status = fs::exists(dir / (row[0] + ".log")) ? "failed" : "missing";
    else {
      stats = nlohmann::json::parse(in, nullptr, false);
      if (stats.is_discarded() || !stats.is_object()) status = "failed";
    }
    bad += status != "ok";
    table << ',' << status << ',';
    if (status == "ok" && stats.contains("failures"))
      table << (stats["failures"].value("clean", false) ? 1 : 0);
    for (const char* column : kColumns) {
      table << ',';
      if (status != "ok" || !stats.contains(column)) continue;
      const nlohmann::json& v = stats[column];
      table << csvField(v.is_string() ? v.get<std::string>() : v.dump());
    }
    table << '\n';
  }
  std::ofstream file(csv);
  file << table.str();
  if (!file) throw std::runtime_error(csv.string() + ": cannot write");
  out << "sweep: " << runs << " runs gathered into " << csv.string();
  if (bad > 0) out << " (" << bad << " failed or missing)";
  out << '\n';
  return bad;
}

// Runs the job lines with at most `jobs` at once, each through /bin/sh; returns how many exited
// with a non-zero status.
std::size_t runJobs(const std::vector<std::string>& lines, int jobs, std::ostream& err) {
  std::size_t next = 0, running = 0, failed = 0, done = 0;
  while (next < lines.size() || running > 0) {
    while (running < static_cast<std::size_t>(jobs) && next < lines.size()) {
      const std::string& line = lines[next++];
      const char* argv[] = {"/bin/sh", "-c", line.c_str(), nullptr};
      pid_t pid = 0;
      if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char* const*>(argv), environ) !=
          0) {
        ++failed, ++done;
        continue;
      }
      ++running;
    }
    if (running == 0) break;
    int status = 0;
    if (wait(&status) < 0) break;
    --running, ++done;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) ++failed;
    err << "sweep: " << done << '/' << lines.size() << " runs done\n";
  }
  return failed;
}

}  // namespace

int runSweep(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const SweepOptions o = parseSweep(args);
  if (!o.gather.empty()) {
    const fs::path dir = o.gather;
    return gather(dir, o.csv.empty() ? dir / "results.csv" : fs::path(o.csv), out) > 0 ? 1 : 0;
  }
  // Every grid point is parsed before anything is written: a bad key or value fails the sweep
  // up front, naming the setting.
  const std::string text = cli::readSceneText(o.scene);
  const std::vector<std::vector<std::string>> points = gridPoints(o.axes);
  for (const auto& point : points) {
    std::vector<std::string> sets;
    for (std::size_t k = 0; k < o.axes.size(); ++k) sets.push_back(o.axes[k].key + "=" + point[k]);
    cli::parseSceneWithSets(text, sets, o.scene);
  }
  const fs::path dir =
      fs::absolute(o.outDir.empty() ? "sweep_" + fs::path(o.scene).stem().string() : o.outDir);
  if (fs::exists(dir) && !fs::is_directory(dir))
    throw UsageError("--out: '" + dir.string() + "' exists and is not a folder");
  const fs::path csv = o.csv.empty() ? dir / "results.csv" : fs::absolute(o.csv);
  if (!csv.parent_path().empty() && csv.parent_path() != dir &&
      !fs::is_directory(csv.parent_path()))
    throw UsageError("--csv: folder '" + csv.parent_path().string() + "' does not exist");

  fs::create_directories(dir);
  const std::string program = selfPath(), scene = fs::absolute(o.scene).string();
  std::ofstream grid(dir / "runs.csv"), jobsFile(dir / "jobs.txt");
  grid << "run";
  for (const Axis& axis : o.axes) grid << ',' << csvField(axis.key);
  grid << '\n';
  std::vector<std::string> lines;
  for (std::size_t run = 0; run < points.size(); ++run) {
    const std::string name = runName(run);
    grid << name;
    std::ostringstream line;
    line << quoted(program) << " run " << quoted(scene) << " --quiet";
    for (std::size_t k = 0; k < o.axes.size(); ++k) {
      grid << ',' << csvField(points[run][k]);
      line << " --set " << quoted(o.axes[k].key + "=" + points[run][k]);
    }
    grid << '\n';
    if (o.frames > 0) line << " --frames " << o.frames;
    line << " --threads " << o.threads << " --stats " << quoted((dir / (name + ".json")).string())
         << " > " << quoted((dir / (name + ".log")).string()) << " 2>&1";
    lines.push_back(line.str());
    jobsFile << line.str() << '\n';
  }
  grid.close(), jobsFile.close();
  {
    std::ofstream slurm(dir / "slurm.sh");
    slurm << "#!/bin/bash\n"
          << "# A Slurm array of the sweep's runs, one line of jobs.txt per task. Submit with\n"
          << "# `sbatch " << (dir / "slurm.sh").string() << "`; when all are done, gather with\n"
          << "# `nucleon sweep --gather " << dir.string() << "`.\n"
          << "#SBATCH --job-name=nucleon-sweep\n"
          << "#SBATCH --array=0-" << points.size() - 1 << '\n'
          << "#SBATCH --cpus-per-task=" << std::max(o.threads, 1) << '\n'
          << "#SBATCH --output=" << (dir / "slurm_%a.out").string() << '\n'
          << "line=$(sed -n \"$((SLURM_ARRAY_TASK_ID + 1))p\" "
          << quoted((dir / "jobs.txt").string()) << ")\n"
          << "exec /bin/sh -c \"$line\"\n";
    if (!slurm) throw std::runtime_error((dir / "slurm.sh").string() + ": cannot write");
  }
  if (o.emit) {
    out << "sweep: " << points.size() << " runs written to " << (dir / "jobs.txt").string()
        << "\n  run them:  parallel --jobs J < " << (dir / "jobs.txt").string()
        << "\n        or:  sbatch " << (dir / "slurm.sh").string() << "\n  gather:    " << program
        << " sweep --gather " << dir.string() << '\n';
    return 0;
  }
  const int jobs =
      o.jobs > 0 ? o.jobs : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  runJobs(lines, jobs, err);
  return gather(dir, csv, out) > 0 ? 1 : 0;
}

}  // namespace nucleon
