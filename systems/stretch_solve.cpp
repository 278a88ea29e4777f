#include "systems/stretch_solve.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "systems/colored_sweep.h"
#include "systems/jacobi_gather.h"

namespace nucleon {
namespace {

// Projects constraint c in place (Gauss–Seidel update).
inline void projectInPlace(StretchConstraints& constraints, Vec3* p, const Real* w, std::size_t c,
                           Real invH2) {
  const auto [i, j] = constraints.particles[c];
  const StretchCorrection k = stretchCorrection(
      p[i], p[j], w[i], w[j], constraints.restLength[c], constraints.stretchCompliance[c],
      constraints.compressionCompliance[c], constraints.lambda[c], invH2);
  p[i] += k.dxi;
  p[j] += k.dxj;
  constraints.lambda[c] += k.dLambda;
}

// Constraints per task in the parallel sweeps.
constexpr std::size_t kGrain = 1024;

}  // namespace

void solveStretchGaussSeidel(StretchConstraints& constraints, ParticlePool& particles, Real h) {
  const Real invH2 = Real(1) / (h * h);
  for (std::size_t c = 0; c < constraints.size(); ++c)
    projectInPlace(constraints, particles.p.data(), particles.w.data(), c, invH2);
}

void solveStretchJacobi(StretchConstraints& constraints, ParticlePool& particles, Real h,
                        Real relaxation) {
  const Real invH2 = Real(1) / (h * h);
  const Vec3* p = particles.p.data();
  const Real* w = particles.w.data();
  Vec3* correction = constraints.correction.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, constraints.size(), kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        const auto [i, j] = constraints.particles[c];
                        const StretchCorrection k = stretchCorrection(
                            p[i], p[j], w[i], w[j], constraints.restLength[c],
                            constraints.stretchCompliance[c], constraints.compressionCompliance[c],
                            constraints.lambda[c], invH2);
                        correction[2 * c] = k.dxi;
                        correction[2 * c + 1] = k.dxj;
                        constraints.lambda[c] += k.dLambda;
                      }
                    });
  gatherJacobiCorrections(constraints.incidence, constraints.correction, particles, relaxation);
}

void solveStretchColored(StretchConstraints& constraints, ParticlePool& particles, Real h) {
  const Real invH2 = Real(1) / (h * h);
  Vec3* p = particles.p.data();
  const Real* w = particles.w.data();
  forEachColor(constraints.coloring, kGrain,
               [&](Index c) { projectInPlace(constraints, p, w, c, invH2); });
}

}  // namespace nucleon
