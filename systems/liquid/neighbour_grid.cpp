#include "systems/liquid/neighbour_grid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace nucleon {
namespace {

using Cell = std::array<std::int32_t, 3>;

Cell cellOf(const Vec3& x, Real invCell) {
  // Far-flung particles (a splash thrown away, a non-finite position the update will reset)
  // land in clamped cells: the grid stays valid, and distances decide who is a neighbour.
  auto axis = [&](Real c) {
    const Real f = std::floor(c * invCell);
    return static_cast<std::int32_t>(
        std::clamp(std::isfinite(f) ? f : Real(0), Real(-1e9), Real(1e9)));
  };
  return {axis(x.x()), axis(x.y()), axis(x.z())};
}

// Spatial hash of a cell (Teschner et al. 2003) into a table of a power-of-two size.
std::uint32_t keyOf(const Cell& c, std::uint32_t mask) {
  return (static_cast<std::uint32_t>(c[0]) * 73856093u ^
          static_cast<std::uint32_t>(c[1]) * 19349663u ^
          static_cast<std::uint32_t>(c[2]) * 83492791u) &
         mask;
}

}  // namespace

int neighbourStride(Real kernelScale) {
  const double atRest = 4.0 / 3.0 * std::numbers::pi * std::pow(double(kernelScale), 3);
  const int stride = static_cast<int>(std::ceil(1.6 * atRest / 8.0)) * 8;
  return std::clamp(stride, 16, kMaxLiquidNeighbours);
}

void buildNeighbourLists(LiquidPool& pool, std::span<const Vec3> x, std::span<const Real> w) {
  const std::size_t n = pool.size();
  if (n == 0) return;
  std::uint32_t tableSize = 1024;
  while (tableSize < 2 * n) tableSize *= 2;
  const std::uint32_t mask = tableSize - 1;
  const int stride = pool.neighbourStride;
  pool.cellKey.resize(n);
  pool.slotParticle.resize(n);
  pool.slotObject.resize(n);
  pool.mass.resize(n);
  pool.inverseMass.resize(n);
  pool.position.resize(n);
  pool.velocity.resize(n);
  pool.cellStart.assign(tableSize + 1, 0);
  pool.neighbours.resize(n * stride);
  pool.gradientScale.resize(n * stride);
  pool.tensileTerm.resize(n * stride);
  pool.neighbourCount.resize(n);
  const Real invCell = 1 / pool.kernels.radius;

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n), [&](const auto& range) {
    for (std::size_t i = range.begin(); i < range.end(); ++i)
      pool.cellKey[i] = keyOf(cellOf(x[pool.particle[i]], invCell), mask);
  });
  // Counting sort by key, stable: within a key the particles stay in list order.
  for (std::size_t i = 0; i < n; ++i) ++pool.cellStart[pool.cellKey[i] + 1];
  for (std::uint32_t k = 0; k < tableSize; ++k) pool.cellStart[k + 1] += pool.cellStart[k];
  pool.cellCursor.assign(pool.cellStart.begin(), pool.cellStart.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    pool.slotParticle[pool.cellCursor[pool.cellKey[i]]++] = static_cast<Index>(i);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n), [&](const auto& range) {
    for (std::size_t s = range.begin(); s < range.end(); ++s) {
      const Index i = pool.slotParticle[s], particle = pool.particle[i];
      pool.slotObject[s] = pool.objectOf[i];
      pool.mass[s] = pool.objects[pool.objectOf[i]].particleMass;
      pool.inverseMass[s] = w[particle];
      pool.position[s] = x[particle];
    }
  });

  const Real r2max = pool.kernels.radius2;
  const Vec3* position = pool.position.data();
  pool.droppedNeighbours += tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n), std::uint64_t(0),
      [&](const auto& range, std::uint64_t dropped) {
        // The runs of slots of the 27 keys around the last cell seen: slots are sorted by key, so
        // the particles of a cell mostly follow each other and share them. With each run, the
        // cell's offset from the particle's cell per axis (−1, 0, 1), or a shared flag when two
        // of the 27 cells have its key (then it is always scanned).
        std::array<std::array<Index, 2>, 27> runs;
        std::array<std::array<std::int8_t, 3>, 27> offsets;
        std::array<bool, 27> shared;
        int runCount = 0;
        Cell runsOf = {0, 0, 0};
        bool haveRuns = false;
        const Real cellSize = pool.kernels.radius;
        for (std::size_t s = range.begin(); s < range.end(); ++s) {
          const Vec3 xs = position[s];
          const Cell c = cellOf(xs, invCell);
          if (!haveRuns || c != runsOf) {
            std::array<std::uint32_t, 27> keys;
            std::uint64_t seen = 0;  // bit (key mod 64) of every key taken: most need no search
            runCount = 0;
            for (int dz = -1; dz <= 1; ++dz)
              for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                  const std::uint32_t key = keyOf({c[0] + dx, c[1] + dy, c[2] + dz}, mask);
                  // Two cells of the 27 may share a key: scan each key once.
                  const std::uint64_t bit = std::uint64_t(1) << (key & 63);
                  if ((seen & bit) != 0) {
                    const auto at = std::find(keys.begin(), keys.begin() + runCount, key);
                    if (at != keys.begin() + runCount) {
                      shared[at - keys.begin()] = true;
                      continue;
                    }
                  }
                  seen |= bit;
                  keys[runCount] = key;
                  offsets[runCount] = {std::int8_t(dx), std::int8_t(dy), std::int8_t(dz)};
                  shared[runCount] = false;
                  runs[runCount++] = {pool.cellStart[key], pool.cellStart[key + 1]};
                }
            runsOf = c;
            haveRuns = true;
          }
          // The particle's gaps to its cell's faces: a neighbouring cell whose box is a kernel
          // radius away holds no neighbour (an edge cell is within reach for π/4 of the
          // positions in the cell, a corner cell for π/6), so its run is not scanned.
          Real below[3], above[3];
          for (int a = 0; a < 3; ++a) {
            below[a] = xs[a] - Real(c[a]) * cellSize;
            above[a] = Real(c[a] + 1) * cellSize - xs[a];
          }
          int count = 0;
          Index* out = pool.neighbours.data() + s * stride;
          for (int r = 0; r < runCount; ++r) {
            if (!shared[r]) {
              Real gap2 = 0;
              for (int a = 0; a < 3; ++a) {
                const Real gap = offsets[r][a] < 0 ? below[a] : offsets[r][a] > 0 ? above[a] : 0;
                gap2 += gap * gap;
              }
              if (gap2 >= r2max) continue;
            }
            for (Index t = runs[r][0]; t < runs[r][1]; ++t) {
              if ((position[t] - xs).squaredNorm() >= r2max || t == s) continue;
              if (count < stride)
                out[count++] = t;
              else
                ++dropped;
            }
          }
          pool.neighbourCount[s] = static_cast<std::uint16_t>(count);
        }
        return dropped;
      },
      std::plus<>());
}

}  // namespace nucleon
