#include "systems/solve_constraints.h"

#include <algorithm>

#include "systems/constraint_sweeps.h"
#include "systems/ground_contact.h"

namespace nucleon {

void solveConstraints(ConstraintPools& pools, ParticlePool& particles, const SweepPlan& plan,
                      const GroundPlane& ground, SolverKind kind, Real h, Real relaxation) {
  pools.forEach([](auto& pool) { std::fill(pool.lambda.begin(), pool.lambda.end(), Real(0)); });
  SweepContext context{particles, h, relaxation, nullptr};
  for (const SweepOp& op : plan.ops) {
    context.objectRuns =
        op.objectRunsOffset < 0 ? nullptr : plan.objectRuns.data() + op.objectRunsOffset;
    switch (op.family) {
      case ConstraintFamily::Stretch:
        solveSweep<DistanceKernel>(kind, pools.stretch, context);
        break;
      case ConstraintFamily::Shear:
        solveSweep<AngleKernel>(kind, pools.shear, context);
        break;
      case ConstraintFamily::Bend:
        solveSweep<DihedralKernel>(kind, pools.bend, context);
        solveSweep<AngleKernel>(kind, pools.curveBend, context);
        break;
      case ConstraintFamily::Twist:
        solveSweep<DihedralKernel>(kind, pools.twist, context);
        break;
      case ConstraintFamily::Volume:
        solveSweep<VolumeKernel>(kind, pools.volume, context);
        break;
      case ConstraintFamily::Tether:
        solveSweep<TetherKernel>(kind, pools.tether, context);
        break;
    }
    if (op.endsRound && ground.enabled) projectGround(particles, ground);
  }
  if (plan.ops.empty() && ground.enabled) projectGround(particles, ground);
}

}  // namespace nucleon
