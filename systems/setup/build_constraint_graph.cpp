#include "systems/setup/build_constraint_graph.h"

#include <bit>
#include <cstdint>

namespace nucleon {

namespace {
constexpr int kMaxColors = 64;  // one bit per color in a particle's mask
}

ParticleIncidence buildIncidence(const ParticleTuples& constraints, std::size_t particleCount) {
  const std::size_t n = constraints.arity;
  ParticleIncidence out;
  out.offset.assign(particleCount + 1, 0);
  for (std::size_t c = 0; c < constraints.size(); ++c)
    for (Index i : constraints[c]) ++out.offset[i + 1];
  for (std::size_t i = 0; i < particleCount; ++i) out.offset[i + 1] += out.offset[i];
  out.slot.resize(constraints.size() * n);
  std::vector<Index> fill(out.offset.begin(), out.offset.end() - 1);
  for (std::size_t c = 0; c < constraints.size(); ++c)  // increasing slot order per particle
    for (std::size_t k = 0; k < n; ++k)
      out.slot[fill[constraints[c][k]]++] = static_cast<Index>(c * n + k);
  return out;
}

ConstraintColoring colorConstraints(const ParticleTuples& constraints, std::size_t particleCount,
                                    std::span<const Real> inverseMass) {
  auto fixed = [&](Index i) { return !inverseMass.empty() && inverseMass[i] == 0; };
  std::vector<std::uint64_t> used(particleCount, 0);
  std::vector<std::size_t> size;
  std::vector<int> color(constraints.size(), kMaxColors);
  for (std::size_t c = 0; c < constraints.size(); ++c) {
    std::uint64_t taken = 0;
    for (Index i : constraints[c])
      if (!fixed(i)) taken |= used[i];
    int best = -1;
    for (int k = 0; k < static_cast<int>(size.size()); ++k)
      if (!(taken >> k & 1) && (best < 0 || size[k] < size[best])) best = k;
    if (best < 0 && size.size() < kMaxColors) {
      best = static_cast<int>(size.size());
      size.push_back(0);
    }
    if (best < 0) continue;  // overflow
    color[c] = best;
    ++size[best];
    for (Index i : constraints[c]) used[i] |= std::uint64_t{1} << best;
  }
  ConstraintColoring out;
  const int colors = static_cast<int>(size.size());
  out.colorOffset.push_back(0);
  for (int k = 0; k <= colors; ++k) {  // k == colors collects the overflow
    const int key = k == colors ? kMaxColors : k;
    for (std::size_t c = 0; c < constraints.size(); ++c)
      if (color[c] == key) out.order.push_back(static_cast<Index>(c));
    if (k < colors || out.order.size() > out.colorOffset.back()) {
      out.overflow = k == colors;
      out.colorOffset.push_back(static_cast<Index>(out.order.size()));
    }
  }
  return out;
}

bool validateColoring(const ConstraintColoring& coloring, const ParticleTuples& constraints,
                      std::size_t particleCount, std::span<const Real> inverseMass) {
  if (coloring.order.size() != constraints.size()) return false;
  std::vector<char> seen(constraints.size(), 0);
  std::vector<std::size_t> stamp(particleCount, SIZE_MAX);
  const std::size_t colors = coloring.colorCount() - (coloring.overflow ? 1 : 0);
  for (std::size_t k = 0; k < coloring.colorCount(); ++k)
    for (Index o = coloring.colorOffset[k]; o < coloring.colorOffset[k + 1]; ++o) {
      const Index c = coloring.order[o];
      if (c >= constraints.size() || seen[c]) return false;
      seen[c] = 1;
      if (k >= colors) continue;  // the serial overflow range may share particles
      for (Index i : constraints[c]) {
        if (!inverseMass.empty() && inverseMass[i] == 0) continue;  // never written
        if (stamp[i] == k) return false;
        stamp[i] = k;
      }
    }
  return true;
}

}  // namespace nucleon
