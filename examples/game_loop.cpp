// A minimal game loop around a World, through the public headers alone: a scene file loaded,
// stepped at a fixed 60 Hz, and played with between steps the way a game does: a corner of the
// cloth dragged around a circle (as a mouse would), a gust given as an impulse on the whole
// cloth, a second cloth added mid-run, the first frozen and teleported, and the second removed.
//
//   build/examples/nucleon_game_loop [SCENE.json]       (default: assets/scenes/cloth_hang.json)
// Exit code 0 when each control did what it says (checked with tolerances printed beside it).
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <nucleon/scene.h>
#include <nucleon/shapes.h>
#include <nucleon/world.h>

namespace {

using nucleon::Vec3;

// Σ m v over an object's free particles (pinned ones have no mass to speak of: w = 0).
Vec3 momentum(const nucleon::World& world, nucleon::ObjectId id, std::size_t first) {
  const auto v = world.velocities();
  const auto w = world.inverseMasses();
  Vec3 sum = Vec3::Zero();
  for (std::size_t i = first; i < first + world.positions(id).size(); ++i)
    if (w[i] > 0) sum += v[i] / w[i];
  return sum;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string path =
      argc > 1 ? argv[1] : std::string(NUCLEON_EXAMPLE_ASSETS) + "/scenes/cloth_hang.json";
  nucleon::World world;
  try {
    world = nucleon::buildWorld(nucleon::loadScene(path));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  const nucleon::ObjectId cloth = world.objectAt(0);
  const std::size_t first = 0;  // the scene's first object owns the first particles
  const nucleon::Index corner = static_cast<nucleon::Index>(world.positions(cloth).size() - 1);
  const double dt = 1.0 / 60;
  bool ok = true;

  // 1. Drag the free corner around a circle for a second.
  const Vec3 centre = world.positions(cloth)[corner] + Vec3(0, -0.3f, 0);
  const auto onCircle = [&](double t) {
    const double a = 2 * std::numbers::pi * t;
    return Vec3(centre + nucleon::Real(0.25) *
                             Vec3(nucleon::Real(std::cos(a)), 0, nucleon::Real(std::sin(a))));
  };
  const std::size_t drag = world.beginDrag(cloth, corner, onCircle(0));
  double worstLag = 0;
  for (int frame = 1; frame <= 60; ++frame) {
    const Vec3 target = onCircle(frame * dt);
    world.moveDrag(drag, target);
    world.step(dt);
    if (frame > 10)
      worstLag = std::max(worstLag, double((world.positions(cloth)[corner] - target).norm()));
  }
  world.endDrag(drag);
  std::printf("drag: the corner stayed within %.2e m of the moving point (bound 0.005)\n",
              worstLag);
  ok &= worstLag < 0.005;

  // 2. A gust: an impulse on the whole cloth adds exactly J to its momentum.
  const Vec3 gust(0, 0, 2);  // N·s
  const Vec3 before = momentum(world, cloth, first);
  world.applyImpulse(cloth, gust);
  const double momentumError = (momentum(world, cloth, first) - before - gust).norm() / gust.norm();
  std::printf("gust: momentum gained %.2e off J (bound 1e-4)\n", momentumError);
  ok &= momentumError < 1e-4;
  for (int frame = 0; frame < 30; ++frame) world.step(dt);

  // 3. A second cloth added mid-run falls.
  nucleon::GridSpec small;
  small.resolution = {8, 8};
  small.size = {0.4f, 0.4f};
  small.center = Vec3(1.5f, 2, 0);
  nucleon::ObjectDef def = nucleon::gridCloth(small);
  def.name = "dropped";
  const nucleon::ObjectId dropped = world.addCloth(def);
  for (int frame = 0; frame < 30; ++frame) world.step(dt);
  const double fell = 2 - world.positions(dropped)[0].y();
  // Symplectic Euler's free fall over N substeps of h: g h² N (N + 1) / 2 (g t²/2 = 1.226 m in
  // the limit). Its corner is free, and nothing else touches it.
  const int substeps = world.solver().substeps, n = 30 * substeps;
  const double h = dt / substeps, expected = 9.81 * h * h * n * (n + 1) / 2;
  std::printf("added cloth: fell %.4f m in 0.5 s (symplectic Euler %.4f m, bound 1e-3 m)\n", fell,
              expected);
  ok &= std::abs(fell - expected) < 1e-3;

  // 4. Freeze the first cloth and lift it by 10 cm: its pinned corner holds the new height
  // through the next step (a pin never moves), so the teleport reached the solver's state.
  std::vector<Vec3> still(world.positions(cloth).size(), Vec3::Zero());
  world.setVelocities(cloth, still);
  std::vector<Vec3> lifted(world.positions(cloth).begin(), world.positions(cloth).end());
  for (Vec3& p : lifted) p.y() += 0.1f;
  world.setPositions(cloth, lifted);
  world.step(dt);
  const double heightError = std::abs(world.positions(cloth)[0].y() - lifted[0].y());
  std::printf("teleport: pinned corner at the new height a step later (off by %.1e m)\n",
              heightError);
  ok &= heightError == 0;

  // 5. Remove the added cloth: its particles go, its id is refused, the first cloth goes on.
  const std::size_t particles = world.particleCount();
  world.removeObject(dropped);
  bool refused = false;
  try {
    world.positions(dropped);
  } catch (const std::invalid_argument&) {
    refused = true;
  }
  std::printf("removed: %zu particles fewer, its id %s\n", particles - world.particleCount(),
              refused ? "refused" : "STILL VALID");
  ok &= refused && particles - world.particleCount() == 64;
  for (int frame = 0; frame < 30; ++frame) world.step(dt);
  const nucleon::Measures m = world.measure();
  std::printf("after %llu steps: max strain %.3f, NaN %llu, recoveries %llu\n",
              static_cast<unsigned long long>(world.steps()), m.maxStrain,
              static_cast<unsigned long long>(m.nanCount),
              static_cast<unsigned long long>(world.recoveries().total()));
  ok &= m.nanCount == 0 && world.recoveries().total() == 0 && m.maxStrain < 0.5;
  std::printf(ok ? "ok\n" : "FAILED\n");
  return ok ? 0 : 1;
}
