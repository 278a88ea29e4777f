#include "engine/app/viewer/scene_snapshot.h"

#include <algorithm>
#include <cmath>

namespace nucleon::viewer {

void takeSnapshot(const World& world, const std::vector<std::vector<Vec3>>& rest,
                  SceneSnapshot& out) {
  out.objects.resize(world.objectCount());
  double strainSum = 0, strainMax = 0;
  std::size_t strainCount = 0;
  for (std::size_t i = 0; i < world.objectCount(); ++i) {
    const ObjectId id = world.objectAt(i);
    ObjectSnapshot& o = out.objects[i];
    o.name = world.name(id);
    o.kind = world.kind(id);
    const auto x = world.positions(id);
    o.x.assign(x.begin(), x.end());
    const auto triangles = world.surfaceTriangles(id);
    o.triangles.assign(triangles.begin(), triangles.end());
    const auto edges = world.curveEdges(id);
    o.edges.assign(edges.begin(), edges.end());
    o.radius = float(world.thickness(id));
    // Strain colours: |x_a − x_b| / |X_a − X_b| − 1 of the edges of each triangle or segment,
    // the largest at each vertex. Vertices added since the rest shape was taken (a tear) get 0.
    o.strain.assign(o.x.size(), 0.f);
    if (i >= rest.size() || o.kind == ObjectKind::Collider) continue;
    const std::vector<Vec3>& X = rest[i];
    const auto edge = [&](Index a, Index b) {
      if (a >= X.size() || b >= X.size()) return;
      const float length = (X[a] - X[b]).norm();
      if (!(length > 0)) return;
      const float s = std::abs((o.x[a] - o.x[b]).norm() / length - 1);
      o.strain[a] = std::max(o.strain[a], s), o.strain[b] = std::max(o.strain[b], s);
      strainSum += s, strainMax = std::max(strainMax, double(s)), ++strainCount;
    };
    for (const auto& t : o.triangles) edge(t[0], t[1]), edge(t[1], t[2]), edge(t[2], t[0]);
    for (const auto& e : o.edges) edge(e[0], e[1]);
  }
  world.contactPoints(out.contactPoints);
  const auto spheres = world.sphereColliders();
  out.spheres.assign(spheres.begin(), spheres.end());
  out.ground = world.ground();
  out.frame = world.steps();
  out.time = world.time();
  // Over triangle edges (an inner edge counts once per triangle): the picture's figure, cheaper
  // than World::measure, whose intersection count is too slow for every frame.
  out.meanStrain = strainCount > 0 ? strainSum / double(strainCount) : 0;
  out.maxStrain = strainMax;
  out.contacts = world.collisionReport().contacts;
  out.recoveries = world.recoveries().total();
}

}  // namespace nucleon::viewer
