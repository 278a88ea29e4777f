// Chebyshev semi-iterative acceleration of the Jacobi sweep (Wang 2015, "A Chebyshev
// semi-iterative approach for accelerating projective and position-based dynamics", eq. 12):
//   q^{k+1} = ω_{k+1} (γ (q̂^{k+1} − q^k) + q^k − q^{k−1}) + q^{k−1},
//   ω_1 = 1,  ω_2 = 2 / (2 − ρ²),  ω_{k+1} = 4 / (4 − ρ² ω_k),
// where q̂^{k+1} is the plain (averaged, mass-split) Jacobi result from q^k, γ the under-relaxation
// (the `relaxation` setting) and ρ an estimate of the plain iteration's spectral radius. The move
// of sweep k is then
//   q^{k+1} − q^k = ω γ Δ^k + (ω − 1) (q^k − q^{k−1}),
// the Jacobi step scaled by ω plus ω − 1 times the previous move. Each constraint keeps its own
// share of that previous move in its correction slots (the per-slot form of the same recurrence:
// the gather averages the slots, so averaging u = ω γ Δx + (ω − 1) u_prev over a particle's slots
// gives exactly the move above), so the slot path needs no per-particle history. The
// vertex-centric sweep of hard distance constraints (jacobi_vertex.h) writes no slots and keeps
// that average itself, the previous move, per particle.
#pragma once

#include <array>
#include <cstddef>

#include "nucleon/types.h"

namespace nucleon {

// The spectral radius estimate ρ. The Jacobi iteration of a hard cloth has ρ within 10⁻³ of 1
// (its slowest mode is the whole sheet stretching under gravity), and the closer the estimate,
// the faster that mode converges: at 10 sweeps a hanging 256² cloth is left with mean strain
// 0.21 at ρ = 0.98 and 0.05 at ρ = 0.995. But the recurrence extrapolates hardest where a sweep's
// correction is least reliable, at contacts: a free cloth dropped on a sphere needed 10 to 72
// contact repairs from ρ = 0.99 up and none at 0.98 or below, so ρ = 0.98 (ω ≤ 1.93; Wang 2015
// §5 likewise lowers ρ for triangle meshes). Measurements: ARCHITECTURE.md §3, jacobi. The
// default of SolverSettings::chebyshevRho (scene key `chebyshev_rho`).
constexpr Real kChebyshevSpectralRadius = Real(0.98);
// Plain sweeps before ω_1 (Wang 2015 §4.3 delays the acceleration while a nonlinear solve is far
// from its linear regime). One: the first extrapolated sweep is then the third, so a schedule of
// two sweeps per substep stays plain Jacobi; with no delay its second sweep extrapolates by
// ω_2 ≈ 1.92 with nothing after it to correct the overshoot, and a hanging cloth gained energy.
constexpr int kChebyshevDelay = 1;

// ω for the sweep with 0-based index `sweep` within a substep: 1 for the first `delay` + 1 sweeps
// (the delay, then ω_1 = 1), then Wang's recurrence from ω_2 on.
inline Real chebyshevWeight(int sweep, Real rho = kChebyshevSpectralRadius,
                            int delay = kChebyshevDelay) {
  const int k = sweep - delay;  // k = 0 is ω_1
  if (k <= 0) return 1;
  const Real rho2 = rho * rho;
  Real omega = 2 / (2 - rho2);
  // The recurrence converges to 2 / (1 + √(1 − ρ²)) within a few dozen steps; capping the loop
  // keeps the cost bounded for long schedules without changing ω beyond rounding.
  for (int j = 2; j <= k && j < 64; ++j) omega = 4 / (4 - rho2 * omega);
  return omega;
}

// Counts the Jacobi sweeps of each pool within one solve (one substep): the Chebyshev weight
// depends on the sweep's index. Fixed capacity (the world has seven pools), no allocation.
class JacobiSweepCounter {
 public:
  // The 0-based index of this sweep of `pool`; -1 when the table is full (then the sweep runs
  // unaccelerated).
  int next(const void* pool) {
    for (std::size_t k = 0; k < used_; ++k)
      if (pools_[k] == pool) return counts_[k]++;
    if (used_ == pools_.size()) return -1;
    pools_[used_] = pool;
    counts_[used_] = 1;
    ++used_;
    return 0;
  }

 private:
  static constexpr std::size_t kCapacity = 16;
  std::array<const void*, kCapacity> pools_{};
  std::array<int, kCapacity> counts_{};
  std::size_t used_ = 0;
};

}  // namespace nucleon
