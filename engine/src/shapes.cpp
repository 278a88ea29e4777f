#include "nucleon/shapes.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>

namespace nucleon {
namespace {
void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}
}  // namespace

ObjectDef gridCloth(const GridSpec& spec) {
  const int nx = spec.resolution[0], ny = spec.resolution[1];
  require(nx >= 2 && ny >= 2 && nx <= 8192 && ny <= 8192,
          "grid resolution must be in [2, 8192] vertices per side");
  require(spec.size[0] > 0 && spec.size[1] > 0 && std::isfinite(spec.size[0]) &&
              std::isfinite(spec.size[1]),
          "grid size must be positive and finite");
  require(spec.center.allFinite(), "grid center must be finite");
  ObjectDef def;
  def.vertices.reserve(static_cast<std::size_t>(nx) * ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const Real u = spec.size[0] * (Real(i) / Real(nx - 1) - Real(0.5));
      const Real s = spec.size[1] * (Real(j) / Real(ny - 1) - Real(0.5));
      def.vertices.push_back(spec.center + (spec.vertical ? Vec3(u, -s, 0) : Vec3(u, 0, s)));
    }
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const Index a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
      // Counter-clockwise seen from +y (horizontal); the vertical grid is the same one rotated
      // by 90° about x, so its normal is +z.
      if ((i + j) % 2 == 0) {
        def.triangles.push_back({a, c, d});
        def.triangles.push_back({a, d, b});
      } else {
        def.triangles.push_back({a, c, b});
        def.triangles.push_back({b, c, d});
      }
    }
  return def;
}

ObjectDef polylineRope(const std::vector<Vec3>& points) {
  require(points.size() >= 2, "a rope needs at least two points");
  ObjectDef def;
  def.vertices = points;
  for (Index i = 0; i + 1 < points.size(); ++i) def.edges.push_back({i, i + 1});
  return def;
}

ObjectDef polylineRope(const Vec3& from, const Vec3& to, int segments) {
  require(segments >= 1 && segments <= 1000000, "rope segments must be in [1, 1000000]");
  require(from.allFinite() && to.allFinite(), "rope end points must be finite");
  std::vector<Vec3> points;
  for (int i = 0; i <= segments; ++i) points.push_back(from + (to - from) * (Real(i) / segments));
  return polylineRope(points);
}

ObjectDef icosphere(const Vec3& center, Real radius, int subdivisions) {
  require(radius > 0 && std::isfinite(radius), "sphere radius must be positive and finite");
  require(subdivisions >= 0 && subdivisions <= 7, "sphere subdivisions must be in [0, 7]");
  require(center.allFinite(), "sphere center must be finite");
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                          {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                          {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<Index, 3>> f = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& p : v) p.normalize();
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<Index, Index>, Index> midpoint;
    auto mid = [&](Index a, Index b) {
      const auto key = std::minmax(a, b);
      auto [it, inserted] = midpoint.try_emplace({key.first, key.second}, 0);
      if (inserted) {
        it->second = static_cast<Index>(v.size());
        v.push_back((v[a] + v[b]).normalized());
      }
      return it->second;
    };
    std::vector<std::array<Index, 3>> next;
    next.reserve(f.size() * 4);
    for (const auto& [a, b, c] : f) {
      const Index ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      next.push_back({a, ab, ca});
      next.push_back({b, bc, ab});
      next.push_back({c, ca, bc});
      next.push_back({ab, bc, ca});
    }
    f = std::move(next);
  }
  ObjectDef def;
  for (const auto& p : v) def.vertices.push_back(center + (radius * p).cast<Real>());
  def.triangles = std::move(f);
  return def;
}

ObjectDef tube(const TubeSpec& spec) {
  const int around = spec.resolution[0], rings = spec.resolution[1];
  require(around >= 3 && around <= 100000 && rings >= 2 && rings <= 100000 &&
              static_cast<long long>(around) * rings <= 100000000,
          "tube resolution must be in [3, 100000] vertices around and [2, 100000] rings along, "
          "1e8 vertices at most");
  require(std::isfinite(spec.length) && spec.length > 0, "tube length must be positive and finite");
  require(std::isfinite(spec.radiusBottom) && spec.radiusBottom > 0 &&
              std::isfinite(spec.radiusTop) && spec.radiusTop > 0,
          "tube radii must be positive and finite");
  require(spec.center.allFinite(), "tube center must be finite");
  const Vec3d axisD = spec.axis.cast<double>();
  require(axisD.allFinite() && axisD.norm() > 1e-12, "tube axis must be finite and not zero");
  const Vec3d axis = axisD.normalized();
  // The reference direction of vertex 0: the world axis least aligned with `axis` (the first in
  // a tie), made perpendicular to it.
  int least = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(axis[k]) < std::abs(axis[least])) least = k;
  const Vec3d u = (Vec3d::Unit(least) - axis[least] * axis).normalized();
  const Vec3d v = axis.cross(u);
  const Vec3d center = spec.center.cast<double>();
  const double length = spec.length;
  ObjectDef def;
  def.vertices.reserve(static_cast<std::size_t>(around) * rings + (spec.caps ? 2 : 0));
  for (int k = 0; k < rings; ++k) {
    const double f = double(k) / double(rings - 1);
    const double radius = (1 - f) * double(spec.radiusBottom) + f * double(spec.radiusTop);
    const Vec3d ringCenter = center + (f - 0.5) * length * axis;
    for (int j = 0; j < around; ++j) {
      const double phi = 2 * std::numbers::pi * double(j) / double(around);
      def.vertices.push_back(
          (ringCenter + radius * (std::cos(phi) * u + std::sin(phi) * v)).cast<Real>());
    }
  }
  auto at = [&](int k, int j) { return static_cast<Index>(k * around + (j % around)); };
  for (int k = 0; k + 1 < rings; ++k)
    for (int j = 0; j < around; ++j) {
      const Index a = at(k, j), b = at(k, j + 1), c = at(k + 1, j), d = at(k + 1, j + 1);
      // b follows a round the axis (right-handed), c is above a along it: (b − a) × (c − a)
      // points outwards.
      if ((j + k) % 2 == 0) {
        def.triangles.push_back({a, b, d});
        def.triangles.push_back({a, d, c});
      } else {
        def.triangles.push_back({a, b, c});
        def.triangles.push_back({b, d, c});
      }
    }
  if (spec.caps) {
    const Index bottom = static_cast<Index>(around * rings), top = bottom + 1;
    def.vertices.push_back((center - 0.5 * length * axis).cast<Real>());
    def.vertices.push_back((center + 0.5 * length * axis).cast<Real>());
    for (int j = 0; j < around; ++j) {
      def.triangles.push_back({bottom, at(0, j + 1), at(0, j)});               // facing −axis
      def.triangles.push_back({top, at(rings - 1, j), at(rings - 1, j + 1)});  // facing +axis
    }
  }
  return def;
}

ObjectDef boxSurface(const Vec3& center, const Vec3& size, int cells) {
  require(size.allFinite() && size.minCoeff() > 0, "box size must be positive and finite");
  require(center.allFinite(), "box center must be finite");
  require(cells >= 1 && cells <= 512, "box cells must be in [1, 512]");
  ObjectDef def;
  // Lattice points (i, j, k) ∈ [0, cells]³ on the surface, numbered as first met.
  std::vector<Index> number(std::size_t(cells + 1) * (cells + 1) * (cells + 1), ~Index(0));
  auto vertex = [&](const std::array<int, 3>& c) {
    Index& n = number[(std::size_t(c[2]) * (cells + 1) + c[1]) * (cells + 1) + c[0]];
    if (n == ~Index(0)) {
      n = static_cast<Index>(def.vertices.size());
      const Vec3 u(Real(c[0]) / cells - Real(0.5), Real(c[1]) / cells - Real(0.5),
                   Real(c[2]) / cells - Real(0.5));
      def.vertices.push_back(center + u.cwiseProduct(size));
    }
    return n;
  };
  // Face normal to axis a at side 0 or cells; (b, c) the other axes in cyclic order, so that
  // e_b × e_c = e_a: a quad (u, w) → (u + 1, w) → (u + 1, w + 1) runs counterclockwise seen from
  // +a, which faces out at the far side and in at the near one.
  for (int a = 0; a < 3; ++a)
    for (int side : {0, cells}) {
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      for (int u = 0; u < cells; ++u)
        for (int w = 0; w < cells; ++w) {
          auto at = [&](int du, int dw) {
            std::array<int, 3> p{};
            p[a] = side, p[b] = u + du, p[c] = w + dw;
            return vertex(p);
          };
          const Index q0 = at(0, 0), q1 = at(1, 0), q2 = at(1, 1), q3 = at(0, 1);
          if (side == cells) {
            def.triangles.push_back({q0, q1, q2});
            def.triangles.push_back({q0, q2, q3});
          } else {
            def.triangles.push_back({q0, q2, q1});
            def.triangles.push_back({q0, q3, q2});
          }
        }
    }
  return def;
}

ObjectDef tetBox(const Vec3& center, const Vec3& size, const std::array<int, 3>& cells) {
  require(size.allFinite() && size.minCoeff() > 0, "box size must be positive and finite");
  require(center.allFinite(), "box center must be finite");
  for (int n : cells) require(n >= 1 && n <= 512, "box cells must be in [1, 512] per axis");
  const int nx = cells[0] + 1, ny = cells[1] + 1, nz = cells[2] + 1;
  ObjectDef def;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const Vec3 u(Real(i) / cells[0] - Real(0.5), Real(j) / cells[1] - Real(0.5),
                     Real(k) / cells[2] - Real(0.5));
        def.vertices.push_back(center + u.cwiseProduct(size));
      }
  auto id = [&](int i, int j, int k) { return static_cast<Index>((k * ny + j) * nx + i); };
  // Kuhn subdivision: the six paths from corner 0 to corner 7 along the three axes in every order.
  const int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i)
        for (const auto& order : orders) {
          int c[3] = {i, j, k};
          std::array<Index, 4> tet;
          tet[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[order[s]];
            tet[s + 1] = id(c[0], c[1], c[2]);
          }
          const Vec3& a = def.vertices[tet[0]];
          const Real volume = (def.vertices[tet[1]] - a)
                                  .cross(def.vertices[tet[2]] - a)
                                  .dot(def.vertices[tet[3]] - a);
          if (volume < 0) std::swap(tet[2], tet[3]);
          def.tets.push_back(tet);
        }
  return def;
}

ObjectDef particleBlock(const Vec3& center, const Vec3& size, Real spacing) {
  if (!(spacing > 0) || !std::isfinite(spacing))
    throw std::invalid_argument("a particle block's spacing must be positive");
  std::array<int, 3> count;
  double total = 1;
  for (int a = 0; a < 3; ++a) {
    if (!(size[a] > 0)) throw std::invalid_argument("a particle block's size must be positive");
    count[a] = std::max(1, static_cast<int>(std::lround(double(size[a]) / double(spacing))));
    total *= count[a];
  }
  if (total > 1e7) throw std::invalid_argument("a particle block holds at most 10 million points");
  ObjectDef def;
  def.vertices.reserve(static_cast<std::size_t>(total));
  for (int k = 0; k < count[2]; ++k)
    for (int j = 0; j < count[1]; ++j)
      for (int i = 0; i < count[0]; ++i)
        def.vertices.push_back(center + spacing * Vec3(Real(i) - Real(count[0] - 1) / 2,
                                                       Real(j) - Real(count[1] - 1) / 2,
                                                       Real(k) - Real(count[2] - 1) / 2));
  return def;
}

}  // namespace nucleon
