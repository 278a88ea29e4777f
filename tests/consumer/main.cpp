// Drops a rope pinned at one end for half a second (a quarter swing) through the installed public
// API and checks that it fell and stayed finite; exit code 0 on success.
#include <cstdio>

#include <nucleon/shapes.h>
#include <nucleon/world.h>

int main() {
  nucleon::ObjectDef rope =
      nucleon::polylineRope(nucleon::Vec3(0, 2, 0), nucleon::Vec3(1, 2, 0), 10);
  rope.pins = {0};
  nucleon::World world;
  const nucleon::ObjectId id = world.addRope(rope);
  for (int i = 0; i < 30; ++i) world.step(1.0 / 60);
  const auto x = world.positions(id);
  const bool fell = x[10].y() < 1.5f && x[0].y() == 2.0f;
  const nucleon::Measures m = world.measure();
  std::printf("rope end at y = %.3f, max strain %.2g, NaN %zu\n", double(x[10].y()), m.maxStrain,
              m.nanCount);
  return fell && m.nanCount == 0 ? 0 : 1;
}
