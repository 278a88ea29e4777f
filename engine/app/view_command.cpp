#include "engine/app/view_command.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <optional>
#include <thread>

#include "engine/app/cli_args.h"
#include "nucleon/scene.h"

#ifdef NUCLEON_VIEWER
#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>
#include <stb/stb_image_write.h>

#include "engine/app/viewer/gl_renderer.h"
#include "engine/app/viewer/scene_snapshot.h"
#endif

namespace nucleon {

const char* const kViewHelp =
    "nucleon view SCENE.json [options]: runs the scene live in a window.\n"
    "  --frames N          stop stepping after frame N (with --screenshot: save and exit)\n"
    "  --screenshot FILE   after the last frame, save the window as a PNG and exit\n"
    "  --size WxH          window size (default 1280x800)\n"
    "  --threads T, --solver NAME, --iterations K, --substeps S, --set KEY=VALUE  as in `run`\n"
    "Mouse: left drag orbits, right drag pulls a particle, middle drag pans, wheel zooms.\n"
    "Keys: space play/pause, N one step, R restart, C strain colours, S screenshot, Esc quit.\n"
    "The panel changes the backend, sweeps and substeps live and plots ms/step and strain.\n";

namespace {

namespace fs = std::filesystem;
using cli::UsageError;

struct ViewOptions {
  std::string scene, screenshot;
  int frames = 0, width = 1280, height = 800;
  std::optional<int> threads, iterations, substeps;
  std::optional<std::string> solver;
  std::vector<std::string> sets;
};

ViewOptions parseView(const std::vector<std::string>& args) {
  ViewOptions o;
  for (cli::Arguments arguments(args); arguments.next();) {
    const std::string& a = arguments.current();
    const auto value = [&]() -> const std::string& { return arguments.value(); };
    if (a == "--frames")
      o.frames = cli::parseInt(a, value(), 1, 1000000);
    else if (a == "--screenshot")
      o.screenshot = value();
    else if (a == "--size") {
      const std::string& size = value();
      const std::size_t x = size.find('x');
      if (x == std::string::npos) throw UsageError("--size: expected WxH, got '" + size + "'");
      o.width = cli::parseInt(a, size.substr(0, x), 64, 8192);
      o.height = cli::parseInt(a, size.substr(x + 1), 64, 8192);
    } else if (a == "--threads")
      o.threads = cli::parseInt(a, value(), 0, 4096);
    else if (a == "--iterations")
      o.iterations = cli::parseInt(a, value(), 0, 100000);
    else if (a == "--substeps")
      o.substeps = cli::parseInt(a, value(), 1, 10000);
    else if (a == "--solver")
      o.solver = value();
    else if (a == "--set")
      o.sets.push_back(value());
    else if (!a.empty() && a[0] == '-')
      throw UsageError("unknown option '" + a + "'");
    else if (o.scene.empty())
      o.scene = a;
    else
      throw UsageError("unexpected argument '" + a + "'");
  }
  if (o.scene.empty()) throw UsageError("view needs a scene file");
  if (!o.screenshot.empty() && o.frames == 0)
    throw UsageError("--screenshot needs --frames N (the frame to save)");
  return o;
}

Scene loadViewScene(const ViewOptions& o) {
  Scene scene = cli::loadSceneWithSets(o.scene, o.sets).scene;
  if (o.substeps) scene.solver.substeps = *o.substeps;
  if (o.threads) scene.threads = *o.threads;
  if (o.iterations) {
    scene.solver.iterations = *o.iterations;
    scene.solver.schedule = rescaleSchedule(scene.solver.schedule, *o.iterations);
  }
  if (o.solver && !parseSolverKind(*o.solver, scene.solver.kind))
    throw UsageError("--solver: unknown solver '" + *o.solver + "'");
  return scene;
}

#ifdef NUCLEON_VIEWER

using Clock = std::chrono::steady_clock;
using viewer::Camera;
using viewer::SceneSnapshot;

// What the window asks of the simulation thread, and what it hands back. One mutex guards all
// of it; the thread holds it only to swap a finished snapshot in and to read the requests.
struct Channel {
  std::mutex mutex;
  SceneSnapshot latest;
  bool fresh = false;
  bool playing = true, restart = false, quit = false, finished = false;
  int stepsRequested = 0;
  std::optional<SolverSettings> settings;  // to apply before the next step
  SolverSettings current;                  // what the world runs with
  // A drag by the mouse: begin on (object, vertex), move to point, end.
  std::optional<std::pair<std::size_t, Index>> dragBegin;
  std::optional<Vec3> dragPoint;
  bool dragEnd = false;
  std::string error;  // a step that threw: shown, and the thread stops stepping
};

void simulate(const Scene& scene, int frameLimit, Channel& channel) {
  const auto build = [&](World& world, std::vector<std::vector<Vec3>>& rest) {
    world = buildWorld(scene);
    rest.clear();
    for (std::size_t i = 0; i < world.objectCount(); ++i) {
      const auto x = world.positions(world.objectAt(i));
      rest.emplace_back(x.begin(), x.end());
    }
  };
  World world;
  std::vector<std::vector<Vec3>> rest;
  SceneSnapshot snapshot;
  // The drag in progress (its attachment index), kNoDrag when none.
  constexpr std::size_t kNoDrag = ~std::size_t{0};
  std::size_t drag = kNoDrag;
  try {
    build(world, rest);
    viewer::takeSnapshot(world, rest, snapshot);
  } catch (const std::exception& e) {
    std::lock_guard lock(channel.mutex);
    channel.error = e.what();
    return;
  }
  {
    std::lock_guard lock(channel.mutex);
    channel.current = world.solver();
    std::swap(channel.latest, snapshot);
    channel.fresh = true;
  }
  const double dt = 1.0 / scene.fps;
  for (;;) {
    bool step = false;
    {
      std::lock_guard lock(channel.mutex);
      if (channel.quit) return;
      try {
        if (channel.restart) {
          channel.restart = false;
          drag = kNoDrag;
          build(world, rest);
          world.setSolver(channel.current);
          channel.finished = false;
        }
        if (channel.settings) {
          world.setSolver(*channel.settings);
          channel.current = world.solver();
          channel.settings.reset();
        }
        if (channel.dragBegin) {
          const auto [object, vertex] = *channel.dragBegin;
          if (drag != kNoDrag) world.endDrag(drag);
          drag = world.beginDrag(world.objectAt(object), vertex,
                                 world.positions(world.objectAt(object))[vertex]);
          channel.dragBegin.reset();
        }
        if (channel.dragPoint && drag != kNoDrag) world.moveDrag(drag, *channel.dragPoint);
        channel.dragPoint.reset();
        if (channel.dragEnd && drag != kNoDrag) world.endDrag(drag), drag = kNoDrag;
        channel.dragEnd = false;
      } catch (const std::exception& e) {
        channel.error = e.what();
      }
      const bool withinLimit = frameLimit == 0 || world.steps() < std::uint64_t(frameLimit);
      step =
          channel.error.empty() && withinLimit && (channel.playing || channel.stepsRequested > 0);
      if (step && channel.stepsRequested > 0) --channel.stepsRequested;
      if (!withinLimit) channel.finished = true;
    }
    if (!step) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    try {
      const StepProfile before = world.profile();
      const auto start = Clock::now();
      world.step(dt);
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
      const StepProfile& after = world.profile();
      viewer::takeSnapshot(world, rest, snapshot);
      snapshot.stepMs = ms;
      snapshot.stages = {(after.forces - before.forces) * 1e3,
                         (after.predict - before.predict) * 1e3,
                         (after.solve - before.solve) * 1e3,
                         (after.cascade - before.cascade) * 1e3,
                         (after.broadPhase - before.broadPhase) * 1e3,
                         (after.narrowPhase - before.narrowPhase) * 1e3,
                         (after.collisions - before.collisions) * 1e3,
                         (after.update - before.update) * 1e3};
    } catch (const std::exception& e) {
      std::lock_guard lock(channel.mutex);
      channel.error = e.what();
      continue;
    }
    std::lock_guard lock(channel.mutex);
    std::swap(channel.latest, snapshot);
    channel.fresh = true;
    if (frameLimit > 0 && world.steps() >= std::uint64_t(frameLimit)) channel.finished = true;
  }
}

// Frames the camera on the bounding box of the non-collider objects (all objects if none).
void frameCamera(const SceneSnapshot& scene, Camera& camera) {
  Eigen::AlignedBox3d box;
  for (int pass = 0; pass < 2 && box.isEmpty(); ++pass)
    for (const auto& o : scene.objects)
      if (pass == 1 || o.kind != ObjectKind::Collider)
        for (const Vec3& p : o.x) box.extend(p.cast<double>());
  if (box.isEmpty()) return;
  camera.target = box.center();
  camera.distance = std::max(0.5, 1.2 * box.diagonal().norm() / (2 * std::tan(camera.fovY / 2)));
}

bool savePng(const std::string& path, int width, int height) {
  std::vector<unsigned char> pixels(std::size_t(width) * std::size_t(height) * 3);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, pixels.data());
  stbi_flip_vertically_on_write(1);
  return stbi_write_png(path.c_str(), width, height, 3, pixels.data(), width * 3) != 0;
}

// The particle nearest the mouse ray (within 3% of the camera distance), as (object, vertex).
std::optional<std::pair<std::size_t, Index>> pick(const SceneSnapshot& scene, const Vec3d& from,
                                                  const Vec3d& direction, double reach) {
  std::optional<std::pair<std::size_t, Index>> best;
  double bestDistance = reach;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const auto& o = scene.objects[i];
    if (o.kind == ObjectKind::Collider) continue;
    for (Index v = 0; v < o.x.size(); ++v) {
      const Vec3d d = o.x[v].cast<double>() - from;
      const double along = d.dot(direction);
      if (along <= 0) continue;
      const double off = (d - along * direction).norm();
      if (off < bestDistance) bestDistance = off, best = {{i, v}};
    }
  }
  return best;
}

int runWindow(const ViewOptions& o, const Scene& scene, std::ostream& out, std::ostream& err) {
  if (!glfwInit()) {
    err << "nucleon: view: no display (GLFW could not start; under a headless machine run it "
           "with xvfb-run)\n";
    return 1;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_SAMPLES, 4);
  GLFWwindow* window =
      glfwCreateWindow(o.width, o.height, ("nucleon: " + scene.name).c_str(), nullptr, nullptr);
  if (!window) {
    glfwTerminate();
    err << "nucleon: view: no OpenGL 3.3 window could be opened\n";
    return 1;
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(o.screenshot.empty() ? 1 : 0);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");

  int status = 0;
  {
    viewer::GlRenderer renderer;
    Channel channel;
    std::thread simulation(simulate, std::cref(scene), o.frames, std::ref(channel));
    SceneSnapshot shown;
    Camera camera;
    bool framed = false;
    viewer::DrawOptions draw;
    std::deque<float> msHistory, strainHistory;
    int iterations = scene.solver.iterations, substeps = scene.solver.substeps;
    int kind = static_cast<int>(scene.solver.kind);
    double lastX = 0, lastY = 0;
    bool dragging = false;
    Vec3d dragPlanePoint = Vec3d::Zero();
    std::string screenshotNote;
    std::array<bool, GLFW_KEY_LAST + 1> keysDown{};
    const char* kinds[] = {"gauss-seidel", "jacobi", "colored-gs", "multigrid"};
    while (!glfwWindowShouldClose(window)) {
      glfwPollEvents();
      int width = 0, height = 0;
      glfwGetFramebufferSize(window, &width, &height);
      bool finished = false;
      std::string error;
      SolverSettings current;
      {
        std::lock_guard lock(channel.mutex);
        if (channel.fresh) {
          std::swap(shown, channel.latest);
          channel.fresh = false;
          msHistory.push_back(float(shown.stepMs));
          strainHistory.push_back(float(shown.meanStrain * 100));
          while (msHistory.size() > 300) msHistory.pop_front(), strainHistory.pop_front();
        }
        finished = channel.finished && !channel.fresh;
        error = channel.error;
        current = channel.current;
      }
      if (!framed && !shown.objects.empty()) frameCamera(shown, camera), framed = true;

      // Input the panel does not take: camera and particle drags.
      ImGuiIO& io = ImGui::GetIO();
      double mx = 0, my = 0;
      glfwGetCursorPos(window, &mx, &my);
      const double dx = mx - lastX, dy = my - lastY;
      lastX = mx, lastY = my;
      int windowWidth = 1, windowHeight = 1;
      glfwGetWindowSize(window, &windowWidth, &windowHeight);
      const auto mouseRay = [&] {
        const Vec3d eye = camera.eye(), f = (camera.target - eye).normalized();
        const Vec3d s = f.cross(Vec3d(0, 1, 0)).normalized(), u = s.cross(f);
        const double t = std::tan(camera.fovY / 2);
        const double ndcX = 2 * mx / windowWidth - 1, ndcY = 1 - 2 * my / windowHeight;
        return (f + ndcX * t * double(windowWidth) / windowHeight * s + ndcY * t * u).normalized();
      };
      if (!io.WantCaptureMouse) {
        if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) {
          camera.yaw -= dx * 0.008;
          camera.pitch = std::clamp(camera.pitch + dy * 0.008, -1.5, 1.5);
        }
        if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS) {
          const Vec3d f = (camera.target - camera.eye()).normalized();
          const Vec3d s = f.cross(Vec3d(0, 1, 0)).normalized(), u = s.cross(f);
          camera.target += camera.distance * 0.0015 * (-dx * s + dy * u);
        }
        const bool right = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
        if (right && !dragging) {
          const Vec3d ray = mouseRay();
          if (const auto hit = pick(shown, camera.eye(), ray, 0.03 * camera.distance)) {
            dragging = true;
            dragPlanePoint = shown.objects[hit->first].x[hit->second].cast<double>();
            std::lock_guard lock(channel.mutex);
            channel.dragBegin = hit;
          }
        } else if (right && dragging) {
          // The point under the mouse on the plane through the grabbed point facing the camera.
          const Vec3d eye = camera.eye(), ray = mouseRay();
          const Vec3d n = (camera.target - eye).normalized();
          const double along = (dragPlanePoint - eye).dot(n) / ray.dot(n);
          std::lock_guard lock(channel.mutex);
          channel.dragPoint = (eye + along * ray).cast<Real>();
        } else if (!right && dragging) {
          dragging = false;
          std::lock_guard lock(channel.mutex);
          channel.dragEnd = true;
        }
        if (io.MouseWheel != 0) camera.distance *= std::pow(0.9, io.MouseWheel);
      }
      bool screenshotNow = false;
      // Keys by their GLFW state, on the press (ImGui 1.86 names only a few letter keys).
      const auto pressed = [&](int key) {
        const bool down = glfwGetKey(window, key) == GLFW_PRESS;
        const bool was = keysDown[std::size_t(key)];
        keysDown[std::size_t(key)] = down;
        return down && !was;
      };
      if (!io.WantCaptureKeyboard) {
        const bool space = pressed(GLFW_KEY_SPACE), next = pressed(GLFW_KEY_N),
                   restart = pressed(GLFW_KEY_R), colours = pressed(GLFW_KEY_C),
                   shot = pressed(GLFW_KEY_S);
        std::lock_guard lock(channel.mutex);
        if (space) channel.playing = !channel.playing;
        if (next) channel.playing = false, ++channel.stepsRequested;
        if (restart) channel.restart = true;
        if (colours) draw.strainColours = !draw.strainColours;
        if (shot) screenshotNow = true;
        if (glfwGetKey(window, GLFW_KEY_ESCAPE) == GLFW_PRESS) glfwSetWindowShouldClose(window, 1);
      }

      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
      ImGui::SetNextWindowSize(ImVec2(330, 0), ImGuiCond_FirstUseEver);
      ImGui::Begin(scene.name.c_str());
      ImGui::Text("frame %llu  t %.3f s", static_cast<unsigned long long>(shown.frame), shown.time);
      ImGui::Text("%.2f ms/step  strain mean %.3f%%  max %.2f%%", shown.stepMs,
                  shown.meanStrain * 100, shown.maxStrain * 100);
      ImGui::Text("contacts (total) %llu  repairs %llu",
                  static_cast<unsigned long long>(shown.contacts),
                  static_cast<unsigned long long>(shown.recoveries));
      {
        std::lock_guard lock(channel.mutex);
        if (ImGui::Button(channel.playing ? "Pause" : "Play")) channel.playing = !channel.playing;
        ImGui::SameLine();
        if (ImGui::Button("Step")) channel.playing = false, ++channel.stepsRequested;
        ImGui::SameLine();
        if (ImGui::Button("Restart")) channel.restart = true;
        ImGui::SameLine();
        if (ImGui::Button("Screenshot")) screenshotNow = true;
      }
      bool changed = ImGui::Combo("backend", &kind, kinds, 4);
      changed |= ImGui::SliderInt("sweeps", &iterations, 1, 100);
      changed |= ImGui::SliderInt("substeps", &substeps, 1, 32);
      if (changed) {
        SolverSettings settings = current;
        settings.kind = static_cast<SolverKind>(kind);
        settings.substeps = substeps;
        settings.iterations = iterations;
        settings.schedule = rescaleSchedule(settings.schedule, iterations);
        std::lock_guard lock(channel.mutex);
        channel.settings = settings;
      }
      ImGui::Checkbox("strain colours", &draw.strainColours);
      ImGui::SameLine();
      ImGui::Checkbox("colliders", &draw.colliders);
      ImGui::SameLine();
      ImGui::Checkbox("ground", &draw.ground);
      ImGui::SameLine();
      ImGui::Checkbox("contacts", &draw.contacts);
      if (draw.strainColours) ImGui::SliderFloat("red at strain", &draw.strainScale, 0.005f, 0.5f);
      std::vector<float> values(msHistory.begin(), msHistory.end());
      ImGui::PlotLines("ms/step", values.data(), int(values.size()), 0, nullptr, 0, FLT_MAX,
                       ImVec2(0, 50));
      values.assign(strainHistory.begin(), strainHistory.end());
      ImGui::PlotLines("mean strain %", values.data(), int(values.size()), 0, nullptr, 0, FLT_MAX,
                       ImVec2(0, 50));
      if (ImGui::CollapsingHeader("profile (ms, last step)", ImGuiTreeNodeFlags_DefaultOpen)) {
        const viewer::StageTimes& t = shown.stages;
        const std::pair<const char*, double> rows[] = {{"forces", t.forces},
                                                       {"predict", t.predict},
                                                       {"solve", t.solve},
                                                       {"  of it cascade", t.cascade},
                                                       {"broad phase", t.broadPhase},
                                                       {"narrow phase", t.narrowPhase},
                                                       {"contacts", t.collisions},
                                                       {"update", t.update}};
        for (const auto& [name, ms] : rows) ImGui::Text("%-16s %8.3f", name, ms);
      }
      if (!error.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", error.c_str());
      if (!screenshotNote.empty()) ImGui::TextUnformatted(screenshotNote.c_str());
      ImGui::End();
      ImGui::Render();

      renderer.draw(shown, camera, width, height, draw);
      // The scripted picture is taken before the panel is drawn: the scene alone.
      const bool scripted =
          !o.screenshot.empty() && finished && framed && shown.frame >= std::uint64_t(o.frames);
      if (scripted) {
        if (!savePng(o.screenshot, width, height)) {
          err << "nucleon: view: cannot write '" << o.screenshot << "'\n";
          status = 1;
        } else
          out << scene.name << ": frame " << shown.frame << " saved to " << o.screenshot << '\n';
        break;
      }
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      if (screenshotNow) {
        const std::string name = "nucleon_view_" + std::to_string(shown.frame) + ".png";
        screenshotNote = savePng(name, width, height) ? "saved " + name : "cannot write " + name;
      }
      glfwSwapBuffers(window);
      if (!error.empty() && !o.screenshot.empty()) {
        err << "nucleon: view: " << error << '\n';
        status = 1;
        break;
      }
    }
    {
      std::lock_guard lock(channel.mutex);
      channel.quit = true;
    }
    simulation.join();
  }
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  glfwTerminate();
  return status;
}

#endif

}  // namespace

int runView(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const ViewOptions o = parseView(args);
  const Scene scene = loadViewScene(o);
  if (!o.screenshot.empty()) {
    const fs::path parent = fs::path(o.screenshot).parent_path();
    if (!parent.empty() && !fs::is_directory(parent))
      throw UsageError("--screenshot: folder '" + parent.string() + "' does not exist");
  }
#ifdef NUCLEON_VIEWER
  return runWindow(o, scene, out, err);
#else
  (void)out;
  err << "nucleon: view: this build has no viewer (install libglfw3-dev and libimgui-dev and "
         "build again)\n";
  return 1;
#endif
}

}  // namespace nucleon
