// A constraint family of your own, registered through the public headers alone: a point kept on a
// plane. A horizontal cloth is pinned at its two near corners; its two far corners may slide
// anywhere on a plane tilted 45° towards the pins but never leave it, so they slide down the
// plane as the cloth falls, and the cloth hangs between the pins and the slope.
//
//   build/examples/nucleon_user_constraint [solver]     (gauss-seidel, jacobi, colored-gs,
//                                                         multigrid; default gauss-seidel)
// Exit code 0 when the corners stayed on the plane and the cloth kept its edges.
#include <cmath>
#include <cstdio>
#include <string>

#include <nucleon/shapes.h>
#include <nucleon/user_constraint.h>
#include <nucleon/world.h>

namespace {

// C(x) = n · x − d for a unit normal n: the signed distance of x from the plane n · x = d.
// ∇C = n. The rest data of a constraint is the plane: (n_x, n_y, n_z, d).
nucleon::Real distanceFromPlane(const nucleon::Vec3* x, const nucleon::Real* plane,
                                nucleon::Vec3* gradient, const void* /*userData*/) {
  const nucleon::Vec3 normal(plane[0], plane[1], plane[2]);
  gradient[0] = normal;
  return normal.dot(x[0]) - plane[3];
}

}  // namespace

int main(int argc, char** argv) {
  nucleon::World world;
  nucleon::SolverSettings solver;
  if (argc > 1 && !nucleon::parseSolverKind(argv[1], solver.kind)) {
    std::fprintf(stderr, "unknown solver '%s'\n", argv[1]);
    return 2;
  }
  solver.substeps = 4;

  nucleon::UserConstraintFamilyDef onPlane;
  onPlane.name = "on-plane";
  onPlane.arity = 1;     // one particle per constraint
  onPlane.restSize = 4;  // the plane
  onPlane.evaluate = distanceFromPlane;
  onPlane.unitGradients = true;  // ‖n‖ = 1
  const nucleon::ConstraintFamily family = world.registerConstraintFamily(onPlane);
  // Scheduled by name like a built-in family: stretch first, then the plane, ten sweeps each.
  solver.schedule = {{nucleon::ConstraintFamily::Stretch, 10}, {family, 10}};
  world.setSolver(solver);

  nucleon::GridSpec grid;
  grid.resolution = {32, 32};
  nucleon::ObjectDef def = nucleon::gridCloth(grid);  // z from −1 to 1
  const nucleon::Index n = 32;
  def.pins = {0, n - 1};  // the near corners, at z = −1
  const nucleon::ObjectId cloth = world.addCloth(def);
  // The plane y = z, through the far corners' start (y = 1, z = 1), normal (0, 1, −1)/√2.
  const nucleon::Real s = nucleon::Real(std::sqrt(0.5));
  const nucleon::Real slope[] = {0, s, -s, 0};
  const nucleon::Index farCorners[] = {n * (n - 1), n * n - 1};  // at z = 1
  for (nucleon::Index corner : farCorners) world.addConstraint(cloth, family, {{corner}}, slope);

  for (int frame = 0; frame < 120; ++frame) world.step(1.0 / 60);

  double worst = 0;
  for (nucleon::Index corner : farCorners) {
    const nucleon::Vec3 x = world.positions(cloth)[corner];
    worst = std::max(worst, std::abs(double(s * (x.y() - x.z()))));
    std::printf("corner %u: x %.3f  y %.3f  z %.4f\n", corner, double(x.x()), double(x.y()),
                double(x.z()));
  }
  const nucleon::Measures m = world.measure();
  std::printf(
      "%s: %zu %s constraints, %d sweeps per substep; farthest corner %.2g m off the "
      "plane; max strain %.3g, NaN %zu\n",
      nucleon::toString(solver.kind), world.constraintCount(family),
      world.familyName(family).c_str(), world.sweepsPerSubstep(family), worst, m.maxStrain,
      m.nanCount);
  // On the plane to a millimetre, and no edge stretched by half its length or more.
  return worst < 1e-3 && m.maxStrain < 0.5 && m.nanCount == 0 ? 0 : 1;
}
