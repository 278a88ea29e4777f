#include "systems/stretch_solve.h"

namespace nucleon {

void solveStretchGaussSeidel(StretchConstraints& constraints, ParticlePool& particles, Real h) {
  const Real invH2 = Real(1) / (h * h);
  Vec3* p = particles.p.data();
  const Real* w = particles.w.data();
  for (std::size_t c = 0; c < constraints.size(); ++c) {
    const auto [i, j] = constraints.particles[c];
    const StretchCorrection k = stretchCorrection(
        p[i], p[j], w[i], w[j], constraints.restLength[c], constraints.stretchCompliance[c],
        constraints.compressionCompliance[c], constraints.lambda[c], invH2);
    p[i] += k.dxi;
    p[j] += k.dxj;
    constraints.lambda[c] += k.dLambda;
  }
}

}  // namespace nucleon
