// The generic sweeps, one per backend (ARCHITECTURE.md §3): Gauss–Seidel in coloring order one
// constraint at a time, Jacobi (corrections from the same state, averaged fixed-order gather) and
// colored Gauss–Seidel (colors in sequence, each in parallel). Every family runs through them: a
// built-in pool (ConstraintPool<N>) with its kernel as a template parameter, so dispatch is per
// family and never per constraint, and a registered family's pool (UserConstraintPool, Kernel =
// UserKernel) through its evaluate function. `Paths` (sweep_paths.h, from the family table) says
// which faster paths a built-in pool may take instead where they apply.
//
// A sweep may be restricted to some objects (per-object schedules): `objectRuns`, when not null,
// says for each object index whether its constraints take part in this sweep. A constraint
// belongs to the object of its first particle (particles.phase).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>

#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "components/constraint_pool.h"
#include "components/particles.h"
#include "components/user_constraint_pool.h"
#include "nucleon/solver_settings.h"
#include "systems/solver/angular_batch.h"
#include "systems/solver/colored_sweep.h"
#include "systems/solver/constraint_kernels.h"
#include "systems/solver/distance_batch.h"
#include "systems/solver/jacobi_chebyshev.h"
#include "systems/solver/jacobi_gather.h"
#include "systems/solver/jacobi_vertex.h"
#include "systems/solver/sweep_paths.h"

namespace nucleon {

// The state a sweep reads besides the pool: particles, substep length and the object filter.
struct SweepContext {
  ParticlePool& particles;
  Real h = 0;
  Real relaxation = 1;                       // Jacobi γ (under/over-relaxation of each step)
  const std::uint8_t* objectRuns = nullptr;  // null: every object
  // Jacobi sweeps of each pool so far in this solve: the Chebyshev weight follows the sweep's
  // index. A context lives for one substep's solve, so the count restarts with every substep.
  mutable JacobiSweepCounter jacobiSweeps{};
  Real chebyshevRho = kChebyshevSpectralRadius;  // Jacobi: the spectral radius estimate ρ
  // Jacobi's γ for the particles of a sheet or solid (at least three constraints in the pool)
  // in the vertex-centric sweep; 0: `relaxation`, as for every other particle.
  Real sheetRelaxation = 0;
  // False: every pool takes the generic sweep, none of the optimised paths of the family table
  // (SolverSettings::optimizedPaths).
  bool optimizedPaths = true;
  // True while supported particles are weighed (supported_particles.h): the in-place projections
  // of two-particle pools take their ends' inverse masses from the pool's endInverseMass, as the
  // colored batches always do, so the weighing does not depend on which path a constraint takes
  // (a batch, a color's remainder, the double build's or a CPU without AVX2's generic sweep).
  bool weighedEnds = false;
};

// The kernel tag of a registered family's pool: C and ∇C come from the family's evaluate.
struct UserKernel {};

// Paths a direct caller of a sweep gets: every optimised path that applies to the kernel.
constexpr unsigned kApplicablePaths = kDistanceBatch | kVertexJacobi | kAngularBatch;

namespace sweep_detail {
constexpr std::size_t kGrain = 512;

// Particles per constraint as a compile-time bound: the arity of a built-in kernel, the largest
// arity of a registered family.
template <class Kernel>
constexpr std::size_t kMaxArity = Kernel::kArity;
template <>
constexpr std::size_t kMaxArity<UserKernel> = kMaxUserConstraintArity;

template <class Pool>
NUCLEON_KERNEL bool takesPart(const Pool& pool, std::size_t c, const SweepContext& context) {
  return !context.objectRuns ||
         context.objectRuns[context.particles.phase[pool.particle(c, 0)]] != 0;
}

// Computes constraint c's correction dx (one per particle) from p (the positions being solved);
// returns Δλ. With `inverseMass` = pool.splitInverseMass (Jacobi), particle i's inverse mass is
// multiplied by the number of the pool's constraints that share it (mass splitting): see
// solveJacobi. With `endInverseMass`, the constraint's own particles' inverse masses in pool order
// (SweepContext::weighedEnds).
template <class Kernel, class Pool>
NUCLEON_KERNEL Real correct(const Pool& pool, std::size_t c, const Vec3* p, const ParticlePool& ps,
                            Real invH, Vec3* dx, const Real* inverseMass = nullptr,
                            const Real* endInverseMass = nullptr) {
  constexpr std::size_t kMax = kMaxArity<Kernel>;
  const std::size_t n = pool.arity();  // a constant for the built-in pools
  Points<kMax> x, start, grad;
  std::array<Real, kMax> weights;
  for (std::size_t k = 0; k < n; ++k) {
    const Index i = pool.particle(c, k);
    x[k] = p[i];
    weights[k] = endInverseMass ? endInverseMass[k] : inverseMass ? inverseMass[i] : ps.w[i];
  }
  const Real invH2 = invH * invH;
  ProjectionTerms terms;
  terms.alphaTilde = pool.compliance[c] * invH2;
  terms.alphaTildeBelow = pool.compressionCompliance[c] * invH2;
  terms.lambda = pool.lambda[c];
  if (pool.damping[c] > 0) {  // only damped constraints read the substep's start positions
    terms.gamma = pool.damping[c] * invH;
    for (std::size_t k = 0; k < n; ++k) start[k] = ps.x[pool.particle(c, k)];
  }
  if constexpr (std::is_same_v<Kernel, UserKernel>) {
    // The family's C includes its rest data: terms.rest stays 0.
    const UserConstraintFamilyDef& family = pool.family;
    for (std::size_t k = 0; k < n; ++k) grad[k].setZero();
    const Real value = family.evaluate(x.data(), pool.restOf(c), grad.data(), family.userData);
    ProjectionForm form;
    form.angular = family.angular;
    form.unilateral = family.unilateral;
    form.unitGradients = family.unitGradients;
    return projectEvaluated(value, grad.data(), x.data(), start.data(), weights.data(), n, terms,
                            form, dx);
  } else {
    terms.rest = pool.rest[c];
    Real value;
    if constexpr (requires { Kernel::kWeighted; })
      value = Kernel::value(x, pool.weights[c], grad);
    else
      value = Kernel::value(x, grad);
    return projectEvaluated(value, grad.data(), x.data(), start.data(), weights.data(), kMax, terms,
                            projectionFormOf<Kernel>(), dx);
  }
}

template <class Kernel, class Pool>
NUCLEON_KERNEL void projectInPlace(Pool& pool, std::size_t c, ParticlePool& ps, Real invH,
                                   bool weighedEnds = false) {
  Vec3 dx[kMaxArity<Kernel>];
  Vec3* p = ps.p.data();
  const Real* endInverseMass = nullptr;
  if constexpr (requires { pool.endInverseMass; })
    if (weighedEnds && !pool.endInverseMass.empty()) endInverseMass = pool.endInverseMass[c].data();
  pool.lambda[c] += correct<Kernel>(pool, c, p, ps, invH, dx, nullptr, endInverseMass);
  // Pins (w = 0) get dx = 0 and are not written: constraints of one color may share them.
  for (std::size_t k = 0; k < pool.arity(); ++k) {
    const Index i = pool.particle(c, k);
    if (ps.w[i] != 0) p[i] += dx[k];
  }
}
}  // namespace sweep_detail

// The sequential reference: Gauss–Seidel one constraint at a time, in coloring order (all of
// color 0, then color 1, …, then the overflow range). The order decides stability, not only the
// rate of convergence. A sweep of sequential projections is one nonlinear Gauss–Seidel iteration
// on the multipliers' system J W Jᵀ Δλ = −C (Macklin et al. 2016, eq. 18): it applies (D + L)⁻¹,
// L holding each constraint's couplings to those before it in the order, which is not
// symmetric. With one sweep per substep the sweep's correction is the whole velocity change, so
// the non-symmetric part acts as a non-conservative force (our reading of the measurements
// below), and it is largest where the order runs long chains of constraints that each start from
// the previous one's result. The pool's own order is such an order: edges sorted by vertex index,
// so a cloth's edges run along its rows, and one sweep carries a correction the whole width of the
// cloth. Measured in that order, on a 64×64 cloth hanging from two corners with 10 substeps of one
// sweep, the total energy rises from 10 J to 10⁵ J within a second, starting on the row between the
// pins; the reverse of that order diverges alike, while coloring order and a random order, with the
// same kernel and the same work, lose energy steadily, and ropes (no loops in their constraint
// graph) are stable in either order. Within a color no two constraints share a free particle,
// so a sweep carries a correction across at most one constraint per color (at most 15 on
// the grid cloths). The price is a slower spread of corrections per sweep: the strain left after
// one second is up to about twice that of the pool's order in the runs that order survives.
// colored-gs runs this same order with each color in parallel, so it matches this reference up to
// the rounding of its batched distance path. Needs pool.coloring current (the derived tables).
template <class Kernel, class Pool>
void solveGaussSeidel(Pool& pool, const SweepContext& context) {
  const Real invH = 1 / context.h;
  for (const Index c : pool.coloring.order)
    if (sweep_detail::takesPart(pool, c, context))
      sweep_detail::projectInPlace<Kernel>(pool, c, context.particles, invH, context.weighedEnds);
}

// Jacobi with mass splitting (Tonge et al. 2012): each constraint sees particle i with n_i times
// its inverse mass (n_i = the family's constraints on i), as if i's mass were shared equally
// among them; the gather then averages the copies, so that particle i moves by
//   Δx_i = γ Σ_c w_i ∇_i C_c Δλ_c,
// exactly the displacement that the multipliers account for. λ_c therefore accumulates γ Δλ_c,
// and the compliance term −α̃λ stays consistent with the positions: with plain averaging,
// particles move n_i times less than λ says, and a soft material comes out softer.
//
// On top of it, Chebyshev acceleration (jacobi_chebyshev.h): constraint c's slot becomes
//   u_c = ω γ Δx_c + (ω − 1) u_c,prev,
// the gather averaging u over the particle's slots. A hard, undamped constraint's λ_c books the
// ω γ Δλ_c part of the move but not the carried (ω − 1) u_prev part: its λ enters no projection
// (the −α̃λ term vanishes). A compliant constraint reads λ_c, so λ_c must account for every move
// the slots make (x − x̃ = M⁻¹ ∇Cᵀ λ, Macklin et al. 2016, eq. 9); it keeps the same recurrence
// in its multiplier, the step of the last sweep with its carried part,
//   δλ_c = ω γ Δλ_c + (ω − 1) δλ_c,prev,  λ_c += δλ_c,
// and restarts slots and multiplier together, when Δλ_c opposes δλ_c,prev. A damped constraint
// takes the same rule (its damping term reads ∇C · (p − x), which the carried moves enter as any
// other). Unaccelerated, a compliant cloth stayed far less converged than a hard one (the 64²
// cloth_sphere under Jacobi × 10: mean strain 44% at compliance 10⁻⁹ against 11%), and a damped
// one further still (74% at τ = 5 ms, an edge 24 times its length). This is for the distance
// family and the registered families that ask for it (kCarriesMultiplier); compliant or damped
// angular constraints run plain. A constraint the object filter leaves out writes zero and drops
// its history.
//
// Pools of hard, undamped distance constraints (the common inextensible cloth) take the
// vertex-centric form of the same sweep instead (jacobi_vertex.h): each particle computes its
// averaged move from its neighbours, with one Chebyshev history per particle in place of the
// slots. The slot path writes and reads back two slots per constraint and was the slower
// backend; measured side by side (BM_Sweep stretch, 256² hanging cloth, 2 threads, one 2-core
// machine), the slot path ran 185 M projections/s, the vertex path 351 M/s and colored
// Gauss–Seidel 295 M/s. Sweeps restricted to some objects keep the slot path, and since the two
// keep their history in different places, a sweep that follows one of the other path restarts
// the acceleration (runs plain).
namespace sweep_detail {
template <class Pool>
NUCLEON_KERNEL bool acceleratable(const Pool& pool, std::size_t c) {
  if constexpr (requires { pool.family.jacobiAcceleration; })
    if (!pool.family.jacobiAcceleration) return false;
  return pool.compliance[c] == 0 && pool.compressionCompliance[c] == 0 && pool.damping[c] == 0;
}

// The kernels whose compliant and damped constraints are accelerated with their multiplier's
// history (above): the distance family, and a registered family that asks for acceleration
// unless its C is an angle. The angular families stay plain when compliant: their steps swing
// with the angles' nonlinearity, and carried along they grew (a bent, sheared 24² cloth's angle
// constraints moved particles by metres in five accelerated sweeps).
template <class Kernel>
constexpr bool kCarriesMultiplier =
    std::is_base_of_v<DistanceKernel, Kernel> || std::is_same_v<UserKernel, Kernel>;

// A compliant or damped constraint of such a kernel.
template <class Kernel, class Pool>
NUCLEON_KERNEL bool carriesMultiplier(const Pool& pool, std::size_t c) {
  if constexpr (!kCarriesMultiplier<Kernel>) return false;
  if constexpr (requires { pool.family.jacobiAcceleration; })
    if (!pool.family.jacobiAcceleration || pool.family.angular) return false;
  return pool.damping[c] != 0 || pool.compliance[c] != 0 || pool.compressionCompliance[c] != 0;
}

// The per-sweep factors of the Jacobi update: γ for unaccelerated constraints, ω γ and ω − 1 for
// the accelerated ones.
struct JacobiFactors {
  Real relaxation = 1;  // γ
  Real step = 1;        // ω γ
  Real carry = 0;       // ω − 1; 0 on the plain sweeps, which then never read the old slots
};

template <class Kernel, class Pool>
NUCLEON_KERNEL void jacobiOne(Pool& pool, std::size_t c, const SweepContext& context,
                              const JacobiFactors& factors, Real invH) {
  const std::size_t n = pool.arity();
  Vec3* slot = pool.correction.data() + n * c;
  if (!takesPart(pool, c, context)) {
    for (std::size_t k = 0; k < n; ++k) slot[k].setZero();
    if constexpr (kCarriesMultiplier<Kernel>) pool.lambdaMove[c] = 0;
    return;
  }
  Vec3 dx[kMaxArity<Kernel>];
  const Real deltaLambda = correct<Kernel>(pool, c, context.particles.p.data(), context.particles,
                                           invH, dx, pool.splitInverseMass.data());
  if (factors.carry != 0 && acceleratable(pool, c)) {
    pool.lambda[c] += factors.step * deltaLambda;
    for (std::size_t k = 0; k < n; ++k) {
      // Adaptive restart: history that opposes this sweep's correction is an overshoot (a
      // contact or another family pushed the particle back), and carrying it would extrapolate
      // through that obstacle; such a slot restarts from the plain step.
      const Real keep = dx[k].dot(slot[k]) >= 0 ? factors.carry : Real(0);
      slot[k] = factors.step * dx[k] + keep * slot[k];
    }
    if constexpr (kCarriesMultiplier<Kernel>) pool.lambdaMove[c] = factors.step * deltaLambda;
  } else if (factors.carry != 0 && carriesMultiplier<Kernel>(pool, c)) {
    const Real stepLambda = factors.step * deltaLambda;
    const Real previous = pool.lambdaMove[c];
    const Real keep = stepLambda * previous >= 0 ? factors.carry : Real(0);
    const Real move = stepLambda + keep * previous;
    pool.lambda[c] += move;
    pool.lambdaMove[c] = move;
    for (std::size_t k = 0; k < n; ++k) slot[k] = factors.step * dx[k] + keep * slot[k];
  } else {
    pool.lambda[c] += factors.relaxation * deltaLambda;
    if constexpr (kCarriesMultiplier<Kernel>) pool.lambdaMove[c] = factors.relaxation * deltaLambda;
    for (std::size_t k = 0; k < n; ++k) slot[k] = factors.relaxation * dx[k];
  }
}
}  // namespace sweep_detail

namespace sweep_detail {
// The kernels with an AVX2 batch (distance_batch.h, angular_batch.h) where `Paths` allows it.
template <class Kernel>
constexpr bool kAngularKernel =
    std::is_same_v<Kernel, DihedralKernel> || std::is_same_v<Kernel, IsometricBendKernel> ||
    std::is_same_v<Kernel, AngleKernel>;
template <class Kernel, unsigned Paths>
constexpr bool kBatched = ((Paths & kDistanceBatch) && std::is_base_of_v<DistanceKernel, Kernel>) ||
                          ((Paths & kAngularBatch) && kAngularKernel<Kernel>);
static_assert(kAngularBatchSize == kDistanceBatchSize, "one block size for every batch");

template <class Kernel>
bool batchesAvailable() {
  return kAngularKernel<Kernel> ? angularBatchesAvailable() : distanceBatchesAvailable();
}

// The batch functions by kernel: distance constraints, angles, dihedral and isometric hinges.
template <class Kernel>
Index projectBatches(const InPlaceBatch<Kernel::kArity>& b, Index begin, Index end) {
  if constexpr (Kernel::kArity == 2)
    return projectDistanceBatches(b, begin, end);
  else if constexpr (Kernel::kArity == 3)
    return projectAngleBatches(b, begin, end);
  else if constexpr (std::is_same_v<Kernel, IsometricBendKernel>)
    return projectIsometricBendBatches(b, begin, end);
  else
    return projectHingeBatches(b, begin, end);
}
template <class Kernel>
Index projectJacobiBatches(const JacobiBatch<Kernel::kArity>& b, Index begin, Index end) {
  if constexpr (Kernel::kArity == 2)
    return projectDistanceJacobiBatches(b, begin, end);
  else if constexpr (Kernel::kArity == 3)
    return projectAngleJacobiBatches(b, begin, end);
  else if constexpr (std::is_same_v<Kernel, IsometricBendKernel>)
    return projectIsometricBendJacobiBatches(b, begin, end);
  else
    return projectHingeJacobiBatches(b, begin, end);
}

// A pool's batch records (batch_parameters.h).
template <class Kernel, class Pool>
BatchColumns<Kernel::kArity> columnsOf(Pool& pool, Real invH) {
  return {pool.particles.data(),
          pool.rest.data(),
          pool.compliance.data(),
          pool.compressionCompliance.data(),
          pool.lambda.data(),
          invH * invH,
          std::is_same_v<Kernel, TetherKernel>,
          pool.weights.empty() ? nullptr : pool.weights.data()};
}

template <class Kernel, class Pool>
InPlaceBatch<Kernel::kArity> inPlaceBatchOf(Pool& pool, const SweepContext& context, Real invH) {
  InPlaceBatch<Kernel::kArity> batch{columnsOf<Kernel>(pool, invH)};
  batch.positions = context.particles.p.data();
  batch.inverseMass = context.particles.w.data();
  batch.endInverseMass = pool.endInverseMass.data();
  return batch;
}

template <class Kernel, class Pool>
JacobiBatch<Kernel::kArity> jacobiBatchOf(Pool& pool, const SweepContext& context,
                                          const JacobiFactors& factors, Real invH) {
  JacobiBatch<Kernel::kArity> batch{columnsOf<Kernel>(pool, invH)};
  batch.positions = context.particles.p.data();
  batch.splitInverseMass = pool.splitInverseMass.data();
  batch.correction = pool.correction.data();
  batch.relaxation = factors.relaxation;
  batch.step = factors.step;
  batch.carry = factors.carry;
  batch.lambdaMove = pool.lambdaMove.data();
  return batch;
}
}  // namespace sweep_detail

// Adds the multiplier steps that vertex-centric sweeps left in the lanes (jacobi_vertex.h) to the
// pool's λ; a no-op for other pools. The solve calls it at the end of each substep, before
// anything reads λ, and clears the lanes' sum with λ at the start (resetMultipliers).
template <class Pool>
void bookVertexMultipliers(Pool& pool) {
  if constexpr (requires { pool.vertexLambdaPending; }) {
    if (!pool.vertexLambdaPending) return;
    bookVertexLambda(pool.vertexRows, pool.vertexLaneLambda, pool.lambda);
    pool.vertexLambdaPending = false;
  }
}

// λ = 0 for every constraint of the pool, as at the start of a substep, pending lanes included.
template <class Pool>
void resetMultipliers(Pool& pool) {
  std::fill(pool.lambda.begin(), pool.lambda.end(), Real(0));
  if constexpr (requires { pool.vertexLambdaPending; }) pool.vertexLambdaPending = false;
}

// Which form of the Jacobi sweep runs: the vertex-centric one wherever it applies (Automatic), or
// the slot path always (Slots; the reference the tests compare the vertex path with).
enum class JacobiPath { Automatic, Slots };

namespace sweep_detail {
// Below this many constraints an angular pool keeps the slot path: a parallel loop per color
// costs more than the gather it saves.
constexpr std::size_t kColorJacobiMinimum = 4096;

template <class Kernel>
Index accumulateJacobiBatches(const JacobiBatch<Kernel::kArity>& b, Index begin, Index end) {
  if constexpr (Kernel::kArity == 3)
    return accumulateAngleJacobiBatches(b, begin, end);
  else if constexpr (std::is_same_v<Kernel, IsometricBendKernel>)
    return accumulateIsometricBendJacobiBatches(b, begin, end);
  else
    return accumulateHingeJacobiBatches(b, begin, end);
}

// The slot path's sweep with the gather folded into the projections, for an angular pool stored
// in color order whose constraints are all soft (pool.correctionSum). The slot path writes
// n corrections per constraint into slots and gathers them per particle, 24 bytes written and
// read back per corner, scattered across the colors, which cost the 388² cloth's bend sweep as
// much as its projections. Here each color in turn adds its constraints' corrections to the
// per-particle sums (no two constraints of a color share a free particle), then each particle
// moves by its sum over its constraint count. Each constraint is projected from the same
// positions, by the lanes or the scalar kernel exactly where the slot path uses each, and each
// sum takes its terms in the slot order of the incidence table (increasing constraint index,
// hence color by color): the same bits as the slot path, for any thread count.
template <class Kernel, class Pool>
void solveJacobiByColors(Pool& pool, const SweepContext& context, const JacobiFactors& factors,
                         Real invH) {
  const std::size_t n = pool.arity();
  JacobiBatch<Kernel::kArity> batch = jacobiBatchOf<Kernel>(pool, context, factors, invH);
  batch.sum = pool.correctionSum.data();
  Vec3* sum = pool.correctionSum.data();
  // The slot path's lanes take the whole blocks of eight from constraint 0.
  const Index batchedEnd =
      static_cast<Index>(pool.size() / kDistanceBatchSize * kDistanceBatchSize);
  for (std::size_t color = 0; color < pool.coloring.colorCount(); ++color) {
    const Index begin = pool.coloring.colorOffset[color];
    const Index end = pool.coloring.colorOffset[color + 1];
    const Index lanesEnd = std::min(end, batchedEnd);
    Index scalarBegin = std::max(begin, batchedEnd);
    if (begin < lanesEnd) {
      const Index firstBlock = begin / kDistanceBatchSize;
      const Index lastBlock = (lanesEnd + kDistanceBatchSize - 1) / kDistanceBatchSize;
      std::atomic<bool> unbatched{false};
      tbb::parallel_for(
          tbb::blocked_range<Index>(firstBlock, lastBlock, kGrain / kDistanceBatchSize),
          [&](const tbb::blocked_range<Index>& r) {
            const Index from = std::max(begin, r.begin() * kDistanceBatchSize);
            const Index to = std::min(lanesEnd, r.end() * kDistanceBatchSize);
            if (accumulateJacobiBatches<Kernel>(batch, from, to) != to)
              unbatched.store(true, std::memory_order_relaxed);
          },
          tbb::static_partitioner());
      if (unbatched.load()) scalarBegin = begin;  // no lanes after all: the slot path's scalar
    }
    // The rest one by one through the slots, in order, as the gather would add them.
    for (Index c = scalarBegin; c < end; ++c) {
      jacobiOne<Kernel>(pool, c, context, factors, invH);
      for (std::size_t k = 0; k < n; ++k) sum[pool.particle(c, k)] += pool.correction[n * c + k];
    }
  }
  const ParticleIncidence& incidence = pool.incidence;
  Vec3* p = context.particles.p.data();
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, incidence.offset.size() - 1, 2048),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const Index count = incidence.offset[i + 1] - incidence.offset[i];
          if (count == 0) continue;
          p[i] += (Real(1) / Real(count)) * sum[i];
          sum[i].setZero();
        }
      },
      tbb::static_partitioner());
}
}  // namespace sweep_detail

template <class Kernel, unsigned Paths = kApplicablePaths, class Pool>
void solveJacobi(Pool& pool, const SweepContext& context, JacobiPath path = JacobiPath::Automatic) {
  const Real invH = 1 / context.h;
  const Real omega = chebyshevWeight(context.jacobiSweeps.next(&pool), context.chebyshevRho);
  sweep_detail::JacobiFactors factors;
  factors.relaxation = context.relaxation;
  factors.step = omega * context.relaxation;
  factors.carry = omega - 1;
  if constexpr ((Paths & kVertexJacobi) && std::is_same_v<Kernel, DistanceKernel>) {
    if (path == JacobiPath::Automatic && !context.objectRuns && context.optimizedPaths &&
        pool.vertexJacobi) {
      // Every constraint is hard: all are accelerated, unless the history is in the slots.
      const bool carries = factors.carry != 0 && pool.vertexHistory;
      VertexJacobiStep step;
      step.factor = carries ? factors.step : factors.relaxation;
      const Real sheet = context.sheetRelaxation > 0 ? context.sheetRelaxation : context.relaxation;
      step.sheetFactor = carries ? omega * sheet : sheet;
      step.carry = carries ? factors.carry : Real(0);
      solveDistanceJacobiVertex(pool.vertexRows, pool.vertexMove, pool.vertexLaneLambda,
                                context.particles.p, step, pool.vertexLambdaPending);
      pool.vertexHistory = true;
      pool.vertexLambdaPending = true;
      return;
    }
  }
  if constexpr (requires { pool.vertexHistory; }) {
    if (pool.vertexHistory) factors.carry = 0;  // the slots are stale: restart
    pool.vertexHistory = false;
    bookVertexMultipliers(pool);  // the slot path books its own as it goes
  }
  if constexpr (sweep_detail::kAngularKernel<Kernel> && sweep_detail::kBatched<Kernel, Paths>) {
    if (path == JacobiPath::Automatic && !pool.correctionSum.empty() && !context.objectRuns &&
        context.optimizedPaths && pool.undamped &&
        pool.size() >= sweep_detail::kColorJacobiMinimum &&
        sweep_detail::batchesAvailable<Kernel>()) {
      sweep_detail::solveJacobiByColors<Kernel>(pool, context, factors, invH);
      return;
    }
  }
  // Blocks of kDistanceBatchSize constraints from constraint 0, whatever the partitioning: which
  // constraints take the batched path, and hence the rounding, never depends on the thread count.
  const std::size_t blocks = (pool.size() + kDistanceBatchSize - 1) / kDistanceBatchSize;
  // Undamped distance and angular constraints: eight at a time (distance_batch.h,
  // angular_batch.h), in place of the scalar loop below, whose result they equal up to rounding.
  constexpr bool kBatched = sweep_detail::kBatched<Kernel, Paths>;
  bool batched = false;
  JacobiBatch<sweep_detail::kMaxArity<Kernel>> batch;
  if constexpr (kBatched) {
    batched = !context.objectRuns && context.optimizedPaths && pool.undamped &&
              sweep_detail::batchesAvailable<Kernel>();
    batch = sweep_detail::jacobiBatchOf<Kernel>(pool, context, factors, invH);
  }
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, blocks, sweep_detail::kGrain / kDistanceBatchSize),
      [&](const tbb::blocked_range<std::size_t>& r) {
        const std::size_t end = std::min(pool.size(), r.end() * kDistanceBatchSize);
        std::size_t c = r.begin() * kDistanceBatchSize;
        if constexpr (kBatched) {
          if (batched)
            c = sweep_detail::projectJacobiBatches<Kernel>(batch, static_cast<Index>(c),
                                                           static_cast<Index>(end));
        }
        for (; c < end; ++c) sweep_detail::jacobiOne<Kernel>(pool, c, context, factors, invH);
      },
      tbb::static_partitioner());
  gatherJacobiCorrections(pool.incidence, pool.correction, context.particles, Real(1));
}

template <class Kernel, unsigned Paths = kApplicablePaths, class Pool>
void solveColored(Pool& pool, const SweepContext& context) {
  const Real invH = 1 / context.h;
  auto projectOne = [&](Index c) {
    if (sweep_detail::takesPart(pool, c, context))
      sweep_detail::projectInPlace<Kernel>(pool, c, context.particles, invH, context.weighedEnds);
  };
  if constexpr (sweep_detail::kBatched<Kernel, Paths>) {
    // Undamped distance and angular constraints stored in color order: eight at a time.
    if (!context.objectRuns && context.optimizedPaths && pool.undamped && pool.coloring.inPlace &&
        sweep_detail::batchesAvailable<Kernel>()) {
      const auto batch = sweep_detail::inPlaceBatchOf<Kernel>(pool, context, invH);
      forEachColorRange(
          pool.coloring, sweep_detail::kGrain, kDistanceBatchSize,
          [&](Index begin, Index end) {
            for (Index c = sweep_detail::projectBatches<Kernel>(batch, begin, end); c < end; ++c)
              projectOne(c);
          },
          projectOne);
      return;
    }
  }
  forEachColor(pool.coloring, sweep_detail::kGrain, projectOne);
}

// Runs one sweep of the given backend (the generic sweep, or a path of `Paths` where it applies).
template <class Kernel, unsigned Paths = kApplicablePaths, class Pool>
void solveSweep(SolverKind kind, Pool& pool, const SweepContext& context) {
  if (pool.size() == 0) return;
  switch (kind) {
    case SolverKind::Jacobi:
      solveJacobi<Kernel, Paths>(pool, context);
      break;
    case SolverKind::ColoredGaussSeidel:
      solveColored<Kernel, Paths>(pool, context);
      break;
    default:
      solveGaussSeidel<Kernel>(pool, context);
      break;
  }
}

}  // namespace nucleon
