#include "engine/app/cli.h"
#include "engine/app/bench_command.h"
#include "engine/app/ccd_command.h"
#include "engine/app/cli_args.h"
#include "engine/app/sweep_command.h"
#include "engine/app/view_command.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "nucleon/checkpoint.h"
#include "nucleon/hash.h"
#include "nucleon/mesh_io.h"
#include "nucleon/render.h"
#include "nucleon/scene.h"
#include "nucleon/usd.h"

namespace nucleon {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

using cli::hex16;
using cli::parseInt;
using cli::parseNumber;
using cli::UsageError;

const char* kUsage =
    "usage: nucleon run SCENE.json [--frames N] [--substeps S] [--threads T]\n"
    "                              [--solver gauss-seidel|jacobi|colored-gs|multigrid]\n"
    "                              [--iterations K] [--out DIR] [--stats FILE.json]\n"
    "                              [--render FILE.png] [--quiet] [--max-kinematic-travel M]\n"
    "                              [--max-impact-travel M]\n"
    "                              [--usd FILE.usda] [--set KEY=VALUE]\n"
    "                              [--checkpoint-every N DIR]\n"
    "                              [--resume CHECKPOINT]\n"
    "       nucleon sweep SCENE.json --set KEY=V1,V2,.. [--set ..] [--frames N] [--threads T]\n"
    "                              [--jobs J] [--out DIR] [--csv FILE] [--emit]\n"
    "       nucleon sweep --gather DIR [--csv FILE]\n"
    "       nucleon view SCENE.json [--frames N --screenshot FILE.png] [--size WxH]\n"
    "       nucleon bench SCENE|NAME ... [--threads 1,2,..] [--solver a,b] [--iterations K]\n"
    "                              [--steps N] [--warmup W] [--repeats R] [--csv FILE]\n"
    "                              [--lanes avx2,avx512]\n"
    "       nucleon scenes\n"
    "       nucleon ccd QUERIES.txt [--answers FILE] [--thickness D]\n"
    "       nucleon --help | nucleon CMD --help\n";

const char* kRunHelp =
    "nucleon run SCENE.json [options]: simulate a scene and report on it.\n"
    "  --frames N        frames to simulate (each is one step of 1/fps seconds)\n"
    "  --substeps S      substeps per step\n"
    "  --threads T       worker threads (0 = all cores)\n"
    "  --solver NAME     gauss-seidel | jacobi | colored-gs | multigrid\n"
    "  --iterations K    constraint sweeps per substep (a scene schedule is rescaled so that\n"
    "                    its most-swept family gets K)\n"
    "  --out DIR         write one OBJ per object per frame into DIR\n"
    "  --stats FILE      write run statistics as JSON\n"
    "  --render FILE     write a PNG picture of the last frame\n"
    "  --usd FILE.usda   write the run as one USD layer, points sampled every frame\n"
    "  --quiet           no progress output\n"
    "  --max-kinematic-travel M\n"
    "                    the farthest (m) a moving collider's vertex or an animated pin may\n"
    "                    go in one substep before a step takes more substeps (0: never;\n"
    "                    default: 3/4 of the smallest contact distance between a collider or\n"
    "                    pinned object and a moving object)\n"
    "  --max-impact-travel M\n"
    "                    the farthest (m) the median free particle of an object that may\n"
    "                    strike a collider may go in one substep before a step takes more\n"
    "                    substeps (0: never; default: 1.5 times its median edge length)\n"
    "  --set KEY=VALUE   change a setting of the scene file: KEY is its JSON path with dots\n"
    "                    (solver.iterations, objects.0.material.friction), VALUE JSON or text\n"
    "                    (repeatable)\n"
    "  --checkpoint-every N DIR\n"
    "                    after every N-th frame write the world's state to\n"
    "                    DIR/SCENE_FRAME.ckpt (binary; see --resume)\n"
    "  --resume FILE     start from a checkpoint instead of the scene's first frame and run\n"
    "                    the frames after it: the same scene file and settings flags as the\n"
    "                    run that wrote it (refused otherwise), ending in the same state\n"
    "Flags override the scene file, which overrides the defaults. Bad input: exit code 2.\n";

// An edge this many times its rest length (or longer) in any frame makes a run not clean: the
// cloth is torn in all but name.
constexpr double kOverstretchedLength = 3.0;

// The failures a run met, over all of its frames: intersecting triangle pairs (exact checker),
// edges stretched beyond kOverstretchedLength, particles ending a frame behind a collider's
// surface, and, from the world's counters, repairs and crossings the fail-safe left. A run with
// any of them is reported as not clean.
struct FailureTally {
  std::uint64_t framesWithIntersections = 0;
  std::uint64_t maxIntersections = 0;
  std::uint64_t overstretchedFrames = 0;
  std::uint64_t framesInsideColliders = 0;
  std::uint64_t mostInsideColliders = 0;
  double worstStrain = 0;

  void add(const Measures& m) {
    framesWithIntersections += m.intersections > 0;
    maxIntersections = std::max<std::uint64_t>(maxIntersections, m.intersections);
    overstretchedFrames += m.maxStretch >= kOverstretchedLength - 1;
    framesInsideColliders += m.insideColliders > 0;
    mostInsideColliders = std::max<std::uint64_t>(mostInsideColliders, m.insideColliders);
    worstStrain = std::max(worstStrain, m.maxStrain);
  }
  bool clean(std::uint64_t nanCount, std::uint64_t repairs, std::uint64_t unresolved) const {
    return framesWithIntersections == 0 && overstretchedFrames == 0 && framesInsideColliders == 0 &&
           nanCount == 0 && repairs == 0 && unresolved == 0;
  }
};

struct RunOptions {
  std::string scene;
  std::optional<int> frames, substeps, threads, iterations;
  std::optional<double> maxKinematicTravel;
  std::optional<double> maxImpactTravel;
  std::optional<std::string> solver;
  std::string outDir, statsFile, renderFile, usdFile;
  bool quiet = false;
  std::vector<std::string> sets;  // --set KEY=VALUE, in order
  int checkpointEvery = 0;        // 0: no checkpoints
  std::string checkpointDir, resumeFile;
};

RunOptions parseRun(const std::vector<std::string>& args) {
  RunOptions o;
  for (cli::Arguments arguments(args); arguments.next();) {
    const std::string& a = arguments.current();
    const auto value = [&]() -> const std::string& { return arguments.value(); };
    if (a == "--frames")
      o.frames = parseInt(a, value(), 1, 1000000);
    else if (a == "--substeps")
      o.substeps = parseInt(a, value(), 1, 10000);
    else if (a == "--threads")
      o.threads = parseInt(a, value(), 0, 4096);
    else if (a == "--iterations")
      o.iterations = parseInt(a, value(), 0, 100000);
    else if (a == "--solver")
      o.solver = value();
    else if (a == "--out")
      o.outDir = value();
    else if (a == "--stats")
      o.statsFile = value();
    else if (a == "--render")
      o.renderFile = value();
    else if (a == "--usd")
      o.usdFile = value();
    else if (a == "--quiet")
      o.quiet = true;
    else if (a == "--checkpoint-every") {
      o.checkpointEvery = parseInt(a, value(), 1, 1000000);
      o.checkpointDir = value();
    } else if (a == "--set")
      o.sets.push_back(value());
    else if (a == "--resume")
      o.resumeFile = value();
    else if (a == "--max-kinematic-travel")
      o.maxKinematicTravel = parseNumber(a, value(), 0, 1000);
    else if (a == "--max-impact-travel")
      o.maxImpactTravel = parseNumber(a, value(), 0, 1000);
    else if (!a.empty() && a[0] == '-')
      throw UsageError("unknown option '" + a + "'");
    else if (o.scene.empty())
      o.scene = a;
    else
      throw UsageError("unexpected argument '" + a + "'");
  }
  if (o.scene.empty()) throw UsageError("run needs a scene file");
  return o;
}

// An output file's folder must exist before the run, so that a bad path fails up front.
void checkWritable(const std::string& file, const char* flag) {
  if (file.empty()) return;
  const fs::path parent = fs::path(file).parent_path();
  if (!parent.empty() && !fs::is_directory(parent))
    throw UsageError(std::string(flag) + ": folder '" + parent.string() + "' does not exist");
}

// Progress on stderr: a redrawn bar on a terminal, a plain line per second otherwise.
class Progress {
 public:
  Progress(std::ostream& err, int total, bool quiet)
      : err_(err),
        total_(total),
        quiet_(quiet),
        terminal_(isatty(STDERR_FILENO) && &err == &std::cerr),
        last_(Clock::now()) {}
  void update(int done) {
    if (quiet_) return;
    const auto now = Clock::now();
    if (terminal_) {
      const int width = 40, filled = width * done / total_;
      err_ << '\r' << '[' << std::string(filled, '#') << std::string(width - filled, '.') << "] "
           << done << '/' << total_ << std::flush;
      if (done == total_) err_ << '\n';
    } else if (now - last_ >= std::chrono::seconds(1) || done == total_) {
      err_ << "frame " << done << '/' << total_ << '\n';
      last_ = now;
    }
  }

 private:
  std::ostream& err_;
  int total_;
  bool quiet_, terminal_;
  Clock::time_point last_;
};

// What a checkpoint must have been written for: the scene's text after --set (FNV-1a) and the
// settings the other flags may change. Readable, so that a refusal says what differs.
std::string runLabel(const std::string& text, const Scene& scene) {
  Fnv1a hash;
  hash.add(text);
  std::ostringstream label;
  label << scene.name << " file " << hex16(hash.value) << ", " << toString(scene.solver.kind)
        << " x" << scene.solver.iterations << ", " << scene.solver.substeps << " substeps, travel "
        << scene.solver.maxKinematicTravel << '/' << scene.solver.maxImpactTravel << ", "
        << scene.fps << " fps";
  return label.str();
}

int runScene(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const RunOptions o = parseRun(args);
  cli::SceneSource source = cli::loadSceneWithSets(o.scene, o.sets);
  Scene& scene = source.scene;
  const std::string& sceneText = source.text;  // after --set
  if (o.frames) scene.frames = *o.frames;
  if (o.substeps) scene.solver.substeps = *o.substeps;
  if (o.maxKinematicTravel)
    scene.solver.maxKinematicTravel = static_cast<Real>(*o.maxKinematicTravel);
  if (o.maxImpactTravel) scene.solver.maxImpactTravel = static_cast<Real>(*o.maxImpactTravel);
  if (o.threads) scene.threads = *o.threads;
  if (o.iterations) {
    scene.solver.iterations = *o.iterations;
    scene.solver.schedule = rescaleSchedule(scene.solver.schedule, *o.iterations);
  }
  if (o.solver && !parseSolverKind(*o.solver, scene.solver.kind))
    throw UsageError("--solver: unknown solver '" + *o.solver + "'");
  checkWritable(o.statsFile, "--stats");
  checkWritable(o.renderFile, "--render");
  checkWritable(o.usdFile, "--usd");
  if (!o.outDir.empty() && fs::exists(o.outDir) && !fs::is_directory(o.outDir))
    throw UsageError("--out: '" + o.outDir + "' exists and is not a folder");
  World world;
  try {
    world = buildWorld(scene);
  } catch (const SceneError& e) {
    throw UsageError(e.what());
  }

  // A checkpoint is read before anything is written, so that a refused one fails up front.
  const std::string label = runLabel(sceneText, scene);
  int firstFrame = 1;
  if (!o.resumeFile.empty()) {
    std::ifstream in(o.resumeFile, std::ios::binary);
    if (!in) throw UsageError("--resume: cannot open '" + o.resumeFile + "'");
    try {
      loadCheckpoint(world, in, label);
    } catch (const CheckpointError& e) {
      throw UsageError(o.resumeFile + ": " + e.what());
    }
    firstFrame = static_cast<int>(world.steps()) + 1;
    if (firstFrame > scene.frames)
      throw UsageError("--resume: the checkpoint is at frame " + std::to_string(firstFrame - 1) +
                       ", the run has " + std::to_string(scene.frames) + " frames");
  }
  if (o.checkpointEvery > 0 && fs::exists(o.checkpointDir) && !fs::is_directory(o.checkpointDir))
    throw UsageError("--checkpoint-every: '" + o.checkpointDir + "' exists and is not a folder");

  // Input is valid: from here on outputs are written. Advice on the scene comes first, quiet or
  // not: it says why a run may turn out not clean.
  const std::vector<std::string> warnings = world.warnings();
  for (const std::string& line : warnings) err << "warning: " << line << '\n';
  if (!o.outDir.empty()) fs::create_directories(o.outDir);
  if (o.checkpointEvery > 0) fs::create_directories(o.checkpointDir);
  const double dt = 1.0 / scene.fps;
  nlohmann::json perFrame = nlohmann::json::array(), energy = nlohmann::json::array();
  double stepSeconds = 0;
  std::vector<double> frameMs;  // each frame's step, for the percentiles
  // What keeps a run from being clean, frame by frame (every frame counts, not only the last).
  FailureTally failures;
  const int framesRun = scene.frames - firstFrame + 1;
  std::optional<UsdRecorder> usd;
  if (!o.usdFile.empty()) usd.emplace(world, scene.fps);
  Progress progress(err, framesRun, o.quiet);
  const auto wallStart = Clock::now();
  for (int frame = firstFrame; frame <= scene.frames; ++frame) {
    const auto start = Clock::now();
    const std::uint64_t substepsBefore = world.profile().substeps;
    world.step(dt);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    stepSeconds += seconds;
    frameMs.push_back(seconds * 1e3);
    const Measures m = world.measure();
    energy.push_back(m.kineticEnergy + m.potentialEnergy);
    failures.add(m);
    perFrame.push_back({{"frame", frame},
                        {"ms", seconds * 1e3},
                        {"max_strain", m.maxStrain},
                        {"max_stretch", m.maxStretch},
                        {"intersections", m.intersections},
                        {"inside_colliders", m.insideColliders},
                        {"contacts", m.contacts},
                        {"substeps", world.profile().substeps - substepsBefore}});
    // Tearable cloths: the vertices split so far, so that a frame's time can be set beside its
    // tears.
    if (world.tearReport().spareParticles > 0)
      perFrame.back()["new_vertices"] = world.tearReport().newVertices;
    // Pressured cloths: volume (m³) and pressure (Pa, absolute) at the frame's end, in object
    // order.
    for (std::size_t i = 0; i < world.objectCount(); ++i)
      if (const ObjectId id = world.objectAt(i); world.hasPressure(id)) {
        const PressureReading p = world.pressure(id);
        perFrame.back()["pressure"].push_back({p.volume, p.pressure});
      }
    // Liquids: the compression the density constraints left, [mean, p99, max], in object order.
    for (std::size_t i = 0; i < world.objectCount(); ++i)
      if (const ObjectId id = world.objectAt(i); world.isLiquid(id)) {
        const LiquidReading l = world.liquid(id);
        perFrame.back()["liquid"].push_back(
            {l.meanCompression, l.compressionP99, l.maxCompression});
      }
    if (!o.outDir.empty())
      for (std::size_t i = 0; i < world.objectCount(); ++i) {
        const ObjectId id = world.objectAt(i);
        std::ostringstream name;
        name << world.name(id) << '_' << std::setw(4) << std::setfill('0') << frame << ".obj";
        writeObj((fs::path(o.outDir) / name.str()).string(), world.positions(id),
                 world.surfaceTriangles(id), world.curveEdges(id));
      }
    if (usd) usd->addFrame(world, frame);
    if (o.checkpointEvery > 0 && frame % o.checkpointEvery == 0) {
      std::ostringstream name;
      name << scene.name << '_' << std::setw(4) << std::setfill('0') << frame << ".ckpt";
      const std::string path = (fs::path(o.checkpointDir) / name.str()).string();
      // Written whole under another name first: a reader never finds half a checkpoint.
      {
        std::ofstream file(path + ".part", std::ios::binary);
        saveCheckpoint(world, file, label);
        file.close();
        if (!file) throw std::runtime_error(path + ": cannot write");
      }
      fs::rename(path + ".part", path);
    }
    progress.update(frame - firstFrame + 1);
  }
  const double wall = std::chrono::duration<double>(Clock::now() - wallStart).count();
  const Measures m = world.measure();
  const double msPerStep = stepSeconds * 1e3 / framesRun;
  // The world is new and `run` steps it once per frame, so the world's counters cover exactly
  // this run and its 1-based step of the first repair is the frame of the stats.
  const Recoveries& recoveries = world.recoveries();
  const nlohmann::json firstRecoveryFrame =
      recoveries.firstStep > 0 ? nlohmann::json(recoveries.firstStep) : nlohmann::json();
  // nan_count: non-finite values seen or repaired during the run. Each non-finite repair is one
  // particle whose new position or velocity was not finite (it kept its position and lost its
  // velocity, so the value is gone from the state); to those add the non-finite position and
  // velocity components still in the state at the end, which a healthy run never has. A run
  // that met none reports 0.
  const std::uint64_t nanCount = recoveries.nonFinite + m.nanCount;
  // Per family where the figure means something: the distance families (stretch is two-sided,
  // a tether limits from above only).
  nlohmann::json strainByFamily = nlohmann::json::object();
  if (world.constraintCount(ConstraintFamily::Stretch) > 0)
    strainByFamily["stretch"] = {{"max", m.maxStrain},
                                 {"mean", m.meanStrain},
                                 {"p99", m.strainP99},
                                 {"max_stretch", m.maxStretch},
                                 {"max_compression", m.maxCompression}};
  if (world.constraintCount(ConstraintFamily::Tether) > 0)
    strainByFamily["tether"] = {{"max_violation", m.maxTetherViolation}};

  nlohmann::json constraints = nlohmann::json::object();
  nlohmann::json sweeps = nlohmann::json::object();  // per substep, from the schedule
  for (std::size_t f = 0; f < world.familyCount(); ++f) {
    const auto family = static_cast<ConstraintFamily>(f);
    constraints[world.familyName(family)] = world.constraintCount(family);
    sweeps[world.familyName(family)] = world.sweepsPerSubstep(family);
  }
  nlohmann::json stats = {
      {"scene", scene.name},
      {"frames", scene.frames},
      {"steps", framesRun},
      {"resumed_from_frame", firstFrame - 1},
      {"substeps", scene.solver.substeps},
      {"iterations", scene.solver.iterations},
      {"threads", world.threads()},
      {"solver", toString(scene.solver.kind)},
      {"particles", world.particleCount()},
      {"constraints", constraints},
      {"sweeps", sweeps},
      {"wall_s", wall},
      {"ms_per_step", msPerStep},
      {"max_strain", m.maxStrain},
      {"mean_strain", m.meanStrain},
      {"strain_p99", m.strainP99},
      {"max_stretch", m.maxStretch},
      {"max_compression", m.maxCompression},
      {"max_tether_violation", m.maxTetherViolation},
      {"strain_by_family", strainByFamily},
      {"intersections", m.intersections},
      {"contacts", m.contacts},
      {"nan_count", nanCount},
      {"recoveries", recoveries.total()},
      {"recoveries_by_kind",
       {{"non_finite", recoveries.nonFinite},
        {"missed_contacts", recoveries.missedContacts},
        {"collapsed_pressure_volumes", recoveries.collapsedPressureVolumes},
        {"limited_pressure_steps", recoveries.limitedPressureSteps},
        {"limited_density_moves", recoveries.limitedDensityMoves}}},
      {"first_recovery_frame", firstRecoveryFrame},
      {"failures",
       {{"clean",
         failures.clean(nanCount, recoveries.total(), world.collisionReport().unresolvedPairs)},
        {"frames_with_intersections", failures.framesWithIntersections},
        {"max_intersections", failures.maxIntersections},
        {"overstretched_frames", failures.overstretchedFrames},
        {"frames_inside_colliders", failures.framesInsideColliders},
        {"most_inside_colliders", failures.mostInsideColliders},
        {"worst_frame_max_strain", failures.worstStrain},
        {"unresolved_crossing_pairs", world.collisionReport().unresolvedPairs}}},
      {"min_height", m.minHeight},
      {"volume_ratio", m.volumeRatio >= 0 ? nlohmann::json(m.volumeRatio) : nlohmann::json()},
      {"energy", energy},
      {"state_hash", hex16(world.stateHash())},
      {"warnings", warnings},
      {"per_frame", perFrame}};
  // Attachments made and broken over the run.
  if (world.attachmentCount() > 0)
    stats["attachments"] = {{"total", world.attachmentCount()},
                            {"broken", world.brokenAttachments()}};
  // Each pressured cloth's state at the end (World::pressure).
  for (std::size_t i = 0; i < world.objectCount(); ++i) {
    const ObjectId id = world.objectAt(i);
    if (!world.hasPressure(id)) continue;
    const PressureReading p = world.pressure(id);
    stats["pressure"].push_back({{"object", world.name(id)},
                                 {"volume", p.volume},
                                 {"rest_volume", p.restVolume},
                                 {"pressure", p.pressure},
                                 {"gas", p.gas}});
  }
  // Each liquid's state at the end (World::liquid), with its worst frame.
  for (std::size_t i = 0, liquids = 0; i < world.objectCount(); ++i) {
    const ObjectId id = world.objectAt(i);
    if (!world.isLiquid(id)) continue;
    const LiquidReading l = world.liquid(id);
    double worst = 0;
    for (const nlohmann::json& frame : perFrame)
      worst = std::max(worst, frame.at("liquid")[liquids][2].get<double>());
    ++liquids;
    stats["liquid"].push_back({{"object", world.name(id)},
                               {"particles", l.density.size()},
                               {"rest_density", l.restDensity},
                               {"mean_compression", l.meanCompression},
                               {"compression_p99", l.compressionP99},
                               {"max_compression", l.maxCompression},
                               {"worst_frame_max_compression", worst},
                               {"dropped_neighbours", l.droppedNeighbours}});
  }
  // The frames' step times by nearest rank: a tear's rebuild shows in the tail, not the mean.
  if (!frameMs.empty()) {
    std::sort(frameMs.begin(), frameMs.end());
    const auto rank = [&](double q) {
      const auto r = static_cast<std::size_t>(std::ceil(q * double(frameMs.size()) - 1e-9));
      return frameMs[std::min(frameMs.size(), std::max<std::size_t>(r, 1)) - 1];
    };
    stats["frame_ms"] = {{"p50", rank(0.5)}, {"p99", rank(0.99)}, {"max", frameMs.back()}};
  }
  // Tearable cloths: edges cut, vertices split and tears refused for want of spare particles.
  if (const TearReport& tear = world.tearReport(); tear.spareParticles > 0)
    stats["tearing"] = {{"torn_edges", tear.tornEdges},
                        {"new_vertices", tear.newVertices},
                        {"refused_tears", tear.refusedTears},
                        {"tear_steps", tear.tearSteps},
                        {"spare_particles", tear.spareParticles}};
  // Multigrid's fine-sweep backend (scene key solver.smoother).
  if (scene.solver.kind == SolverKind::Multigrid)
    stats["smoother"] = toString(scene.solver.smoother);
  {
    // Where the step's time went (the engine's own profile, per step), and what the collision
    // stages between primitives did over the run.
    const StepProfile& profile = world.profile();
    const double perStep = profile.steps > 0 ? 1e3 / double(profile.steps) : 0.0;
    stats["profile_ms_per_step"] = {{"forces", profile.forces * perStep},
                                    {"animate", profile.animate * perStep},
                                    {"predict", profile.predict * perStep},
                                    {"solve", profile.solve * perStep},
                                    {"cascade", profile.cascade * perStep},
                                    {"broad_phase", profile.broadPhase * perStep},
                                    {"narrow_phase", profile.narrowPhase * perStep},
                                    {"collisions", profile.collisions * perStep},
                                    {"update", profile.update * perStep},
                                    {"tear", profile.tear * perStep},
                                    {"derived_tables", profile.derivedTables * perStep}};
    const CollisionReport& c = world.collisionReport();
    stats["collisions"] = {
        {"broad_phases", c.broadPhases},
        {"kept_pair_sets", c.keptPairSets},
        {"broad_phase_refreshes", c.broadPhaseRefreshes},
        {"incremental_broad_phases", c.incrementalBroadPhases},
        {"solve_redetections", c.solveRedetections},
        {"collider_redetections", c.colliderRedetections},
        {"supported_particles", c.supportedParticles},
        {"candidate_pairs", c.candidatePairs},
        {"contacts", c.contacts},
        {"clamped_particles", c.clampedParticles},
        {"crossings_stopped", c.crossings},
        {"stopped_particles", c.stoppedParticles},
        {"carried_particles", c.carriedParticles},
        {"squeezes", c.squeezes},
        {"impact_zones", c.impactZones},
        {"stopped_impact_zones", c.stoppedImpactZones},
        {"impact_zone_turns_dropped", c.impactZoneTurnsDropped},
        {"carry_relaxations", c.carryRelaxations},
        {"raised_substep_steps", c.raisedSubstepSteps},
        {"impact_raised_steps", c.impactRaisedSteps},
        {"impact_held_steps", c.impactHeldSteps},
        {"most_substeps", c.mostSubsteps},
        {"capped_substep_steps", c.cappedSubstepSteps},
        {"unresolved_pairs", c.unresolvedPairs},
        {"broad_phase_tree_errors", c.broadPhaseTreeErrors},
        {"first_crossing_step",
         c.firstCrossingStep > 0 ? nlohmann::json(c.firstCrossingStep) : nlohmann::json()}};
  }
  if (!o.statsFile.empty()) {
    std::ofstream file(o.statsFile);
    file << stats.dump(2) << '\n';
    if (!file) throw std::runtime_error(o.statsFile + ": cannot write");
  }
  if (!o.renderFile.empty()) renderPng(world, o.renderFile);
  if (usd) usd->write(o.usdFile);

  out << scene.name << ": " << scene.frames << " frames, " << world.particleCount()
      << " particles, " << world.constraintCount(ConstraintFamily::Stretch)
      << " stretch constraints, " << toString(scene.solver.kind) << " x" << scene.solver.iterations
      << ", " << world.threads() << " threads\n"
      << std::setprecision(4) << "  " << msPerStep << " ms/step, max strain " << m.maxStrain
      << ", mean strain " << m.meanStrain << ", p99 strain " << m.strainP99 << ", min height "
      << m.minHeight << ", NaN " << nanCount << ", recoveries " << recoveries.total();
  if (recoveries.firstStep > 0) out << " (first at frame " << recoveries.firstStep << ')';
  out << ", state " << hex16(world.stateHash()) << '\n';
  const std::uint64_t unresolved = world.collisionReport().unresolvedPairs;
  if (!failures.clean(nanCount, recoveries.total(), unresolved)) {
    out << "  NOT CLEAN:";
    if (failures.framesWithIntersections > 0)
      out << " intersections in " << failures.framesWithIntersections << " frames (most "
          << failures.maxIntersections << ")";
    if (failures.overstretchedFrames > 0)
      out << " edges beyond " << kOverstretchedLength << "x their rest length in "
          << failures.overstretchedFrames << " frames (worst strain " << failures.worstStrain
          << ")";
    if (failures.framesInsideColliders > 0)
      out << " particles behind a collider's surface in " << failures.framesInsideColliders
          << " frames (most " << failures.mostInsideColliders << ")";
    if (unresolved > 0) out << " " << unresolved << " crossing pairs left unresolved";
    if (nanCount > 0 || recoveries.total() > 0) out << " repairs (NaN, recoveries above)";
    out << '\n';
  }
  if (!o.renderFile.empty()) out << "  picture: " << o.renderFile << '\n';
  if (!o.usdFile.empty()) out << "  usd: " << o.usdFile << '\n';
  if (!o.statsFile.empty()) out << "  stats: " << o.statsFile << '\n';
  if (!o.outDir.empty()) out << "  meshes: " << o.outDir << '\n';
  return 0;
}

int listScenes(std::ostream& out) {
  const fs::path folder = fs::path(assetsFolder()) / "scenes";
  if (!fs::is_directory(folder)) throw UsageError(folder.string() + ": no scene folder");
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder))
    if (entry.path().extension() == ".json") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& f : files) {
    try {
      const Scene s = loadScene(f.string());
      out << std::left << std::setw(24) << f.filename().string() << s.description << '\n';
    } catch (const SceneError& e) {
      out << std::left << std::setw(24) << f.filename().string() << "(invalid: " << e.what()
          << ")\n";
    }
  }
  return 0;
}

}  // namespace

int runCommandLine(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    if (args.empty()) {
      err << kUsage;
      return 2;
    }
    const std::string& command = args[0];
    const bool help = std::find(args.begin(), args.end(), "--help") != args.end() ||
                      std::find(args.begin(), args.end(), "-h") != args.end();
    if (command == "--help" || command == "-h" || command == "help") {
      out << kUsage;
      return 0;
    }
    if (command == "run") {
      if (help) return out << kRunHelp, 0;
      return runScene(args, out, err);
    }
    if (command == "bench") {
      if (help) return out << kBenchHelp, 0;
      return runBench(args, out, err);
    }
    if (command == "view") {
      if (help) return out << kViewHelp, 0;
      return runView(args, out, err);
    }
    if (command == "sweep") {
      if (help) return out << kSweepHelp, 0;
      return runSweep(args, out, err);
    }
    if (command == "ccd") {
      if (help) return out << kCcdHelp, 0;
      return runCcd(args, out, err);
    }
    if (command == "scenes") {
      if (help) return out << "nucleon scenes: lists the bundled scenes, one line each\n", 0;
      return listScenes(out);
    }
    throw UsageError("unknown command '" + command + "' (try nucleon --help)");
  } catch (const UsageError& e) {
    err << "nucleon: " << e.what() << '\n';
    return 2;
  } catch (const std::exception& e) {
    err << "nucleon: " << e.what() << '\n';
    return 1;
  }
}

}  // namespace nucleon
