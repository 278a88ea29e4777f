#include "systems/diagnostics/triangle_intersections.h"

#include <algorithm>
#include <array>
#include <bit>
#include <climits>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace nucleon {

namespace {

// ---------------------------------------------------------------------------------------------
// Exact arithmetic: signed integers of fixed capacity.
//
// A finite double is odd · 2^e with an odd integer below 2^53 and −1074 ≤ e ≤ 971. Scaled by
// 2^−E, E the smallest e among one predicate's inputs, every input is an integer of at most
// 53 + 2045 bits (33 words); a difference takes one bit more, a product of three differences
// and a sum of six of them fit in 3 · 34 + 1 words.
class ExactInt {
 public:
  static constexpr int kCapacity = 112;  // 64-bit words (104 needed)

  ExactInt() = default;

  // (negative ? −1 : 1) · odd · 2^shift.
  static ExactInt shifted(std::uint64_t odd, int shift, bool negative) {
    ExactInt r;
    const int word = shift / 64, bit = shift % 64;
    for (int i = 0; i < word; ++i) r.words_[i] = 0;
    r.words_[word] = odd << bit;
    r.size_ = word + 1;
    if (bit != 0 && (odd >> (64 - bit)) != 0) r.words_[r.size_++] = odd >> (64 - bit);
    r.negative_ = negative;
    return r;
  }

  int sign() const { return size_ == 0 ? 0 : (negative_ ? -1 : 1); }

  friend ExactInt operator+(const ExactInt& a, const ExactInt& b) { return combine(a, b, false); }
  friend ExactInt operator-(const ExactInt& a, const ExactInt& b) { return combine(a, b, true); }

  friend ExactInt operator*(const ExactInt& a, const ExactInt& b) {
    ExactInt r;
    if (a.size_ == 0 || b.size_ == 0) return r;
    r.size_ = a.size_ + b.size_;
    for (int i = 0; i < r.size_; ++i) r.words_[i] = 0;
    for (int i = 0; i < a.size_; ++i) {
      std::uint64_t carry = 0;
      for (int j = 0; j < b.size_; ++j) {
        const unsigned __int128 t =
            static_cast<unsigned __int128>(a.words_[i]) * b.words_[j] + r.words_[i + j] + carry;
        r.words_[i + j] = static_cast<std::uint64_t>(t);
        carry = static_cast<std::uint64_t>(t >> 64);
      }
      r.words_[i + b.size_] = carry;
    }
    r.trim();
    r.negative_ = a.negative_ != b.negative_;
    return r;
  }

 private:
  void copyFrom(const ExactInt& x, bool negative) {
    std::copy_n(x.words_.begin(), x.size_, words_.begin());
    size_ = x.size_;
    negative_ = negative;
  }

  void trim() {
    while (size_ > 0 && words_[size_ - 1] == 0) --size_;
  }

  static int compareMagnitude(const ExactInt& a, const ExactInt& b) {
    if (a.size_ != b.size_) return a.size_ < b.size_ ? -1 : 1;
    for (int i = a.size_ - 1; i >= 0; --i)
      if (a.words_[i] != b.words_[i]) return a.words_[i] < b.words_[i] ? -1 : 1;
    return 0;
  }

  // a ± b by magnitudes: add when the effective signs agree, else subtract the smaller.
  static ExactInt combine(const ExactInt& a, const ExactInt& b, bool subtract) {
    const bool bNegative = b.negative_ != subtract;
    ExactInt r;
    if (b.size_ == 0) {
      r.copyFrom(a, a.negative_);
      return r;
    }
    if (a.size_ == 0) {
      r.copyFrom(b, bNegative);
      return r;
    }
    if (a.negative_ == bNegative) {
      const ExactInt& big = a.size_ >= b.size_ ? a : b;
      const ExactInt& small = a.size_ >= b.size_ ? b : a;
      std::uint64_t carry = 0;
      for (int i = 0; i < big.size_; ++i) {
        const std::uint64_t s = i < small.size_ ? small.words_[i] : 0;
        const std::uint64_t t = big.words_[i] + s;
        const std::uint64_t c1 = t < s ? 1 : 0;
        r.words_[i] = t + carry;
        carry = c1 + (r.words_[i] < carry ? 1 : 0);
      }
      r.size_ = big.size_;
      if (carry != 0) r.words_[r.size_++] = carry;
      r.negative_ = a.negative_;
      return r;
    }
    const int order = compareMagnitude(a, b);
    if (order == 0) return r;  // zero
    const ExactInt& big = order > 0 ? a : b;
    const ExactInt& small = order > 0 ? b : a;
    std::uint64_t borrow = 0;
    for (int i = 0; i < big.size_; ++i) {
      const std::uint64_t s = i < small.size_ ? small.words_[i] : 0;
      const std::uint64_t d = big.words_[i] - s;
      const std::uint64_t b1 = big.words_[i] < s ? 1 : 0;
      r.words_[i] = d - borrow;
      borrow = b1 + (d < borrow ? 1 : 0);
    }
    r.size_ = big.size_;
    r.trim();
    r.negative_ = order > 0 ? a.negative_ : bNegative;
    return r;
  }

  // Only the first size_ words are meaningful (and ever read); the rest is left uninitialised,
  // since filling a thousand bytes per temporary would dominate the cost.
  std::array<std::uint64_t, kCapacity> words_;
  int size_ = 0;
  bool negative_ = false;
};

// |x| = odd · 2^exponent for a finite non-zero double.
struct Dyadic {
  std::uint64_t odd = 0;
  int exponent = 0;
};
Dyadic decompose(double x) {
  int e = 0;
  const double f = std::frexp(std::fabs(x), &e);  // |x| = f · 2^e, f in [1/2, 1)
  const auto m = static_cast<std::uint64_t>(std::ldexp(f, 53));
  const int zeros = std::countr_zero(m);
  return {m >> zeros, e - 53 + zeros};
}

// The inputs of one predicate as integers, all scaled by the same power of two 2^−E: an
// orientation determinant is homogeneous in the coordinates, so the positive factor leaves its
// sign unchanged.
template <std::size_t N>
std::array<ExactInt, N> toScaledIntegers(const std::array<double, N>& x) {
  std::array<Dyadic, N> parts;
  int lowest = INT_MAX;
  for (std::size_t i = 0; i < N; ++i)
    if (x[i] != 0) {
      parts[i] = decompose(x[i]);
      lowest = std::min(lowest, parts[i].exponent);
    }
  std::array<ExactInt, N> r;
  for (std::size_t i = 0; i < N; ++i)
    if (x[i] != 0) r[i] = ExactInt::shifted(parts[i].odd, parts[i].exponent - lowest, x[i] < 0);
  return r;
}

// The common case of the exact path: every scaled input below 2^40 (e.g. float coordinates of
// a scene whose smallest non-zero coordinate is within 2^16 of its largest): differences stay
// below 2^41, a product of three below 2^123 and a sum of six below 2^126, inside a signed
// 128-bit integer.
using Int128 = __int128;
constexpr int kSmallBits = 40;

template <std::size_t N>
bool toSmallScaledIntegers(const std::array<double, N>& x, std::array<Int128, N>& r) {
  std::array<Dyadic, N> parts;
  int lowest = INT_MAX;
  for (std::size_t i = 0; i < N; ++i)
    if (x[i] != 0) {
      parts[i] = decompose(x[i]);
      lowest = std::min(lowest, parts[i].exponent);
    }
  for (std::size_t i = 0; i < N; ++i) {
    r[i] = 0;
    if (x[i] == 0) continue;
    const int shift = parts[i].exponent - lowest;
    if (shift + std::bit_width(parts[i].odd) > kSmallBits) return false;
    r[i] = static_cast<Int128>(parts[i].odd << shift);
    if (x[i] < 0) r[i] = -r[i];
  }
  return true;
}

int signOf128(Int128 x) {
  return (x > 0) - (x < 0);
}

int exactOrient2d(double ax, double ay, double bx, double by, double cx, double cy) {
  const std::array<double, 6> in = {ax, ay, bx, by, cx, cy};
  std::array<Int128, 6> s;
  if (toSmallScaledIntegers(in, s))
    return signOf128((s[2] - s[0]) * (s[5] - s[1]) - (s[3] - s[1]) * (s[4] - s[0]));
  const auto v = toScaledIntegers(in);
  const ExactInt ux = v[2] - v[0], uy = v[3] - v[1], wx = v[4] - v[0], wy = v[5] - v[1];
  return (ux * wy - uy * wx).sign();
}

int exactOrient3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const std::array<double, 12> in = {a.x(), a.y(), a.z(), b.x(), b.y(), b.z(),
                                     c.x(), c.y(), c.z(), d.x(), d.y(), d.z()};
  std::array<Int128, 12> s;
  if (toSmallScaledIntegers(in, s)) {
    const Int128 ux = s[3] - s[0], uy = s[4] - s[1], uz = s[5] - s[2];
    const Int128 vx = s[6] - s[0], vy = s[7] - s[1], vz = s[8] - s[2];
    const Int128 wx = s[9] - s[0], wy = s[10] - s[1], wz = s[11] - s[2];
    return signOf128(ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) +
                     uz * (vx * wy - vy * wx));
  }
  const auto v = toScaledIntegers(in);
  const ExactInt ux = v[3] - v[0], uy = v[4] - v[1], uz = v[5] - v[2];
  const ExactInt vx = v[6] - v[0], vy = v[7] - v[1], vz = v[8] - v[2];
  const ExactInt wx = v[9] - v[0], wy = v[10] - v[1], wz = v[11] - v[2];
  return (ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx)).sign();
}

// ---------------------------------------------------------------------------------------------
// Filters. Shewchuk's error bounds (1997, §4.3: ccwerrboundA, o3derrboundA) hold when no
// product underflows or overflows; requiring every non-zero difference in [2^−300, 2^300]
// keeps products of up to three of them normal. Float input always passes.

constexpr double kEpsilon = 0x1p-53;  // half an ulp of 1: the rounding unit
constexpr double kOrient2dBound = (3 + 16 * kEpsilon) * kEpsilon;
constexpr double kOrient3dBound = (7 + 56 * kEpsilon) * kEpsilon;

bool inFilterRange(double difference) {
  const double m = std::fabs(difference);
  return m == 0 || (m >= 0x1p-300 && m <= 0x1p+300);
}

int signOf(double x) {
  return (x > 0) - (x < 0);
}

// The sign of a sum of monomials when the exact signs of its terms already settle it: none of
// one sign (a rounded difference is zero, or has the sign of the exact one, so a monomial's
// exact sign is the product of its factors' signs). Returns 2 when they do not.
int signFromTermSigns(std::initializer_list<int> terms) {
  bool positive = false, negative = false;
  for (int t : terms) {
    positive |= t > 0;
    negative |= t < 0;
  }
  if (positive && negative) return 2;
  return positive ? 1 : (negative ? -1 : 0);
}

// Which of the three coordinates a projection drops, and the two it keeps, in cyclic order.
struct Projection {
  int i = 0, j = 1;
  explicit Projection(int dropped) : i((dropped + 1) % 3), j((dropped + 2) % 3) {}
};

}  // namespace

int orient2d(double ax, double ay, double bx, double by, double cx, double cy) {
  // Shewchuk's evaluation: det[a − c; b − c].
  const double acx = ax - cx, bcy = by - cy, acy = ay - cy, bcx = bx - cx;
  const int quick = signFromTermSigns({signOf(acx) * signOf(bcy), -signOf(acy) * signOf(bcx)});
  if (quick != 2) return quick;
  if (inFilterRange(acx) && inFilterRange(bcy) && inFilterRange(acy) && inFilterRange(bcx)) {
    const double left = acx * bcy, right = acy * bcx;
    const double det = left - right;
    const double bound = kOrient2dBound * (std::fabs(left) + std::fabs(right));
    if (det > bound || -det > bound) return signOf(det);
  }
  return exactOrient2d(ax, ay, bx, by, cx, cy);
}

int orient3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  // det[u; v; w] with u = b − a, v = c − a, w = d − a, summed as Shewchuk's orient3d sums it.
  const Vec3d u = b - a, v = c - a, w = d - a;
  const int su[3] = {signOf(u.x()), signOf(u.y()), signOf(u.z())};
  const int sv[3] = {signOf(v.x()), signOf(v.y()), signOf(v.z())};
  const int sw[3] = {signOf(w.x()), signOf(w.y()), signOf(w.z())};
  const int quick =
      signFromTermSigns({su[0] * sv[1] * sw[2], -su[0] * sv[2] * sw[1], su[1] * sv[2] * sw[0],
                         -su[1] * sv[0] * sw[2], su[2] * sv[0] * sw[1], -su[2] * sv[1] * sw[0]});
  if (quick != 2) return quick;
  bool inRange = true;
  for (int k = 0; k < 3; ++k)
    inRange = inRange && inFilterRange(u[k]) && inFilterRange(v[k]) && inFilterRange(w[k]);
  if (inRange) {
    const double vywz = v.y() * w.z(), vzwy = v.z() * w.y();
    const double vzwx = v.z() * w.x(), vxwz = v.x() * w.z();
    const double vxwy = v.x() * w.y(), vywx = v.y() * w.x();
    const double det = u.x() * (vywz - vzwy) + u.y() * (vzwx - vxwz) + u.z() * (vxwy - vywx);
    const double permanent = std::fabs(u.x()) * (std::fabs(vywz) + std::fabs(vzwy)) +
                             std::fabs(u.y()) * (std::fabs(vzwx) + std::fabs(vxwz)) +
                             std::fabs(u.z()) * (std::fabs(vxwy) + std::fabs(vywx));
    const double bound = kOrient3dBound * permanent;
    if (det > bound || -det > bound) return signOf(det);
  }
  return exactOrient3d(a, b, c, d);
}

namespace {

int orient2dProjected(const Vec3d& a, const Vec3d& b, const Vec3d& c, Projection p) {
  return orient2d(a[p.i], a[p.j], b[p.i], b[p.j], c[p.i], c[p.j]);
}

// A coordinate axis along which projecting the triangle keeps its area (the exact orientation
// of the projection is non-zero), preferring the largest component of the normal; −1 when the
// triangle is degenerate (all three projections are, exactly, of zero area).
int projectionAxis(const Triangle3d& t) {
  const Vec3d n = (t[1] - t[0]).cross(t[2] - t[0]);
  std::array<int, 3> axes = {0, 1, 2};
  std::sort(axes.begin(), axes.end(),
            [&](int a, int b) { return std::fabs(n[a]) > std::fabs(n[b]); });
  for (int axis : axes)
    if (orient2dProjected(t[0], t[1], t[2], Projection(axis)) != 0) return axis;
  return -1;
}

bool strictlyOpposite(int a, int b) {
  return a * b < 0;
}

// ---- Coplanar, non-degenerate: separating axis theorem in the plane. Two disjoint closed
// convex polygons have a strictly separating line parallel to an edge of one of them, so the
// triangles are disjoint iff for some edge the other triangle's three vertices are all strictly
// on the side away from the edge's own triangle.
bool separatedByAnEdgeOf(const Triangle3d& a, const Triangle3d& b, Projection p) {
  const int inside = orient2dProjected(a[0], a[1], a[2], p);  // non-zero
  for (int e = 0; e < 3; ++e) {
    const Vec3d& from = a[e];
    const Vec3d& to = a[(e + 1) % 3];
    bool allOutside = true;
    for (int k = 0; k < 3 && allOutside; ++k)
      allOutside = strictlyOpposite(orient2dProjected(from, to, b[k], p), inside);
    if (allOutside) return true;
  }
  return false;
}

bool coplanarTrianglesIntersect(const Triangle3d& a, const Triangle3d& b, int axis) {
  const Projection p(axis);
  return !separatedByAnEdgeOf(a, b, p) && !separatedByAnEdgeOf(b, a, p);
}

// ---- Guigue and Devillers (2003), non-degenerate triangles.

// Of a triangle's three orientations against the other triangle's plane (not all of one strict
// sign, not all zero), the vertex alone on its side: index i and side σ = ±1 with σ s[i] ≥ 0 and
// σ s[k] ≤ 0 for the other two, chosen so that the two edges from vertex i meet the plane in the
// ends of the triangle's segment in it (§3 of the paper: a strict vertex whose companions are on
// the plane or across it, else the vertex on the plane between two on the same side).
std::pair<int, int> vertexAlone(const std::array<int, 3>& s) {
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    if (s[i] != 0 && s[j] * s[i] <= 0 && s[k] * s[i] <= 0) return {i, s[i]};
  }
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    if (s[i] == 0 && s[j] == s[k]) return {i, -s[j]};  // flipped: the other two become ≤ 0
  }
  return {0, 1};  // unreachable for valid input
}

bool allSameStrictSign(const std::array<int, 3>& s) {
  return (s[0] > 0 && s[1] > 0 && s[2] > 0) || (s[0] < 0 && s[1] < 0 && s[2] < 0);
}

bool guigueDevillers(const Triangle3d& t1, const Triangle3d& t2, int axis2) {
  const std::array<int, 3> s1 = {orient3d(t2[0], t2[1], t2[2], t1[0]),
                                 orient3d(t2[0], t2[1], t2[2], t1[1]),
                                 orient3d(t2[0], t2[1], t2[2], t1[2])};
  if (allSameStrictSign(s1)) return false;
  if (s1[0] == 0 && s1[1] == 0 && s1[2] == 0) return coplanarTrianglesIntersect(t1, t2, axis2);
  const std::array<int, 3> s2 = {orient3d(t1[0], t1[1], t1[2], t2[0]),
                                 orient3d(t1[0], t1[1], t1[2], t2[1]),
                                 orient3d(t1[0], t1[1], t1[2], t2[2])};
  if (allSameStrictSign(s2)) return false;
  // s2 is not all zero: t2 in the plane of t1 would make the planes equal and s1 zero.

  // Rotate each triangle so that its lone vertex comes first (rotations keep orientation), then
  // swap the other triangle's last two vertices where needed so that the lone vertex is on the
  // positive side of the other's plane and its companions on the non-positive side.
  const auto [i1, side1] = vertexAlone(s1);
  const auto [i2, side2] = vertexAlone(s2);
  const Vec3d& p1 = t1[i1];
  const Vec3d* q1 = &t1[(i1 + 1) % 3];
  const Vec3d* r1 = &t1[(i1 + 2) % 3];
  const Vec3d& p2 = t2[i2];
  const Vec3d* q2 = &t2[(i2 + 1) % 3];
  const Vec3d* r2 = &t2[(i2 + 2) % 3];
  if (side1 < 0) std::swap(q2, r2);
  if (side2 < 0) std::swap(q1, r1);
  // Both triangles now cross the line L of the two planes in segments [i, j] (t1: on edges
  // p1q1, p1r1) and [k, l] (t2: on p2q2, p2r2); they overlap iff k is not past j and i not past
  // l along L, which the paper reduces to two orientations (§3, eq. (2)).
  return orient3d(p1, *q1, p2, *q2) <= 0 && orient3d(p1, *r1, *r2, p2) <= 0;
}

// ---- Segments and degenerate triangles (edge criterion).

// Closed segments [a, b] and [c, d] in the plane (either may be a point).
bool segmentsMeet2d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d, Projection p) {
  const int o1 = orient2dProjected(a, b, c, p), o2 = orient2dProjected(a, b, d, p);
  const int o3 = orient2dProjected(c, d, a, p), o4 = orient2dProjected(c, d, b, p);
  if (o1 * o2 > 0 || o3 * o4 > 0) return false;
  if (o1 != 0 || o2 != 0 || o3 != 0 || o4 != 0) return true;
  // All four collinear (or points): they meet iff their extents overlap along both axes.
  for (int k : {p.i, p.j})
    if (std::max(a[k], b[k]) < std::min(c[k], d[k]) || std::max(c[k], d[k]) < std::min(a[k], b[k]))
      return false;
  return true;
}

// Closed triangle (projected, possibly degenerate) and closed segment in the plane.
bool segmentMeetsTriangle2d(const Vec3d& a, const Vec3d& b, const Triangle3d& t, Projection p) {
  for (int e = 0; e < 3; ++e)
    if (segmentsMeet2d(a, b, t[e], t[(e + 1) % 3], p)) return true;
  // Otherwise the segment is inside or outside as a whole: test one endpoint.
  const int s0 = orient2dProjected(t[0], t[1], a, p), s1 = orient2dProjected(t[1], t[2], a, p),
            s2 = orient2dProjected(t[2], t[0], a, p);
  const bool positive = s0 > 0 || s1 > 0 || s2 > 0, negative = s0 < 0 || s1 < 0 || s2 < 0;
  return !(positive && negative);
}

// Coplanar sets meet iff their projections meet along every axis: one of the three projections
// is one-to-one on the plane (or line) holding them, and the others never lose a common point.
template <typename Test>
bool meetInAllProjections(Test test) {
  return test(Projection(0)) && test(Projection(1)) && test(Projection(2));
}

bool segmentsMeet3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  if (orient3d(a, b, c, d) != 0) return false;
  return meetInAllProjections([&](Projection p) { return segmentsMeet2d(a, b, c, d, p); });
}

bool segmentMeetsTriangle(const Vec3d& a, const Vec3d& b, const Triangle3d& t, bool degenerate) {
  if (degenerate) {  // the triangle is the union of its edges
    for (int e = 0; e < 3; ++e)
      if (segmentsMeet3d(a, b, t[e], t[(e + 1) % 3])) return true;
    return false;
  }
  const int oa = orient3d(t[0], t[1], t[2], a), ob = orient3d(t[0], t[1], t[2], b);
  if (oa * ob > 0) return false;
  if (oa == 0 && ob == 0)
    return meetInAllProjections([&](Projection p) { return segmentMeetsTriangle2d(a, b, t, p); });
  // The line ab crosses the plane once, inside [a, b]; the crossing is in the closed triangle iff
  // the line passes no edge on opposite sides (Plücker-style orientations of the line with each
  // edge).
  const int e0 = orient3d(a, b, t[0], t[1]), e1 = orient3d(a, b, t[1], t[2]),
            e2 = orient3d(a, b, t[2], t[0]);
  const bool positive = e0 > 0 || e1 > 0 || e2 > 0, negative = e0 < 0 || e1 < 0 || e2 < 0;
  return !(positive && negative);
}

bool anEdgeMeets(const Triangle3d& edgesOf, const Triangle3d& other, bool otherDegenerate) {
  for (int e = 0; e < 3; ++e)
    if (segmentMeetsTriangle(edgesOf[e], edgesOf[(e + 1) % 3], other, otherDegenerate)) return true;
  return false;
}

// axis: projectionAxis of each triangle (−1 when degenerate).
bool classifiedTrianglesIntersect(const Triangle3d& t1, int axis1, const Triangle3d& t2,
                                  int axis2) {
  // A degenerate triangle is the union of its edges, so some edge of it meets the other.
  if (axis1 < 0) return anEdgeMeets(t1, t2, axis2 < 0);
  if (axis2 < 0) return anEdgeMeets(t2, t1, false);
  return guigueDevillers(t1, t2, axis2);
}

}  // namespace

bool isDegenerate(const Triangle3d& t) {
  return projectionAxis(t) < 0;
}

bool trianglesIntersect(const Triangle3d& t1, const Triangle3d& t2) {
  return classifiedTrianglesIntersect(t1, projectionAxis(t1), t2, projectionAxis(t2));
}

bool trianglesIntersectByEdges(const Triangle3d& t1, const Triangle3d& t2) {
  return anEdgeMeets(t1, t2, isDegenerate(t2)) || anEdgeMeets(t2, t1, isDegenerate(t1));
}

// ---------------------------------------------------------------------------------------------
// Broad phase: a hierarchical grid. Level ℓ has cubic cells of side 2^ℓ; a triangle belongs to
// the smallest level whose side is at least its box's largest extent, so its box covers at most
// two cells per axis there and at every coarser level. It is entered as an owner in its cells at
// its own level and as a visitor in its cells at every coarser level that has owners. Pairs are
// taken within a cell, owner with owner or owner with visitor, so every pair whose boxes overlap
// meets in a cell of the coarser triangle's level; it is counted only in the first such cell
// (the lowest corner of the two boxes' common cell range), hence exactly once.

namespace {

struct Box {
  Vec3d lo, hi;
};

bool overlap(const Box& a, const Box& b) {  // closed boxes; exact comparisons
  for (int k = 0; k < 3; ++k)
    if (a.hi[k] < b.lo[k] || b.hi[k] < a.lo[k]) return false;
  return true;
}

constexpr int kMaxLevels = 32;         // distinct levels kept; finer ones are merged upward
constexpr int kCellBits = 19;          // cell coordinates kept in a key (they wrap around)
constexpr double kCellClamp = 0x1p62;  // cell indices are clamped to ±2^62 (they stay int64)

// Levels are kept in [−1000, 1024] (a coarser level is always allowed), so 2^−ℓ is a finite
// non-zero double and x · 2^−ℓ is x scaled exactly, or rounded monotonically where it leaves the
// normal range, which keeps cell ranges consistent between triangles.
constexpr int kFinestLevel = -1000;

std::int64_t cellIndex(double x, double inverseCellSize) {
  const double scaled = std::floor(x * inverseCellSize);
  return static_cast<std::int64_t>(std::clamp(scaled, -kCellClamp, kCellClamp));
}

// A cell's key: level index (5 bits), then the low kCellBits bits of each cell index. Keys of
// distinct cells may coincide (wrap-around); a triangle's own cells never do, since it spans at
// most two per axis, so a pair still meets once per key and is counted where the key matches
// its first common cell.
std::uint64_t cellKey(int levelIndex, std::int64_t x, std::int64_t y, std::int64_t z) {
  constexpr std::uint64_t mask = (std::uint64_t{1} << kCellBits) - 1;
  return (static_cast<std::uint64_t>(levelIndex) << (3 * kCellBits)) |
         ((static_cast<std::uint64_t>(x) & mask) << (2 * kCellBits)) |
         ((static_cast<std::uint64_t>(y) & mask) << kCellBits) |
         (static_cast<std::uint64_t>(z) & mask);
}

// Smallest ℓ with 2^ℓ ≥ extent > 0.
int levelFor(double extent) {
  int e = 0;
  const double f = std::frexp(extent, &e);  // extent = f 2^e, f in [1/2, 1)
  return f == 0.5 ? e - 1 : e;
}

struct Entry {
  std::uint64_t key;
  std::uint64_t order;  // visitor << 32 | triangle; visitor: entered from a finer level
  static constexpr std::uint64_t kVisitor = std::uint64_t{1} << 32;
  std::uint32_t triangle() const { return static_cast<std::uint32_t>(order); }
  bool visitor() const { return order >= kVisitor; }
};

// Least-significant-digit radix sort on the key (stable; 11-bit digits, a pass skipped where
// every key has the same digit): linear time, where comparison sorts dominated the broad phase.
void sortByKey(std::vector<Entry>& entries, std::vector<Entry>& scratch) {
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
  scratch.resize(entries.size());
  std::vector<std::size_t> start(kBuckets);
  for (int shift = 0; shift < 64; shift += kDigitBits) {
    std::fill(start.begin(), start.end(), 0);
    for (const Entry& e : entries) ++start[(e.key >> shift) & (kBuckets - 1)];
    if (std::find(start.begin(), start.end(), entries.size()) != start.end()) continue;
    std::size_t at = 0;
    for (std::size_t& b : start) at += std::exchange(b, at);
    for (const Entry& e : entries) scratch[start[(e.key >> shift) & (kBuckets - 1)]++] = e;
    entries.swap(scratch);
  }
}

struct Candidate {
  Triangle3d v;
  Box box;
  std::array<Index, 3> indices;
  int axis = -1;  // projectionAxis, −1: degenerate
  int level = 0;  // level index (into the distinct levels), not the exponent
};

struct Workspace {
  std::vector<Candidate> candidates;
  std::vector<int> exponent;
  std::vector<std::size_t> offset, runStart;
  std::vector<Entry> entries, scratch;
};

bool shareVertex(const std::array<Index, 3>& a, const std::array<Index, 3>& b) {
  for (Index i : a)
    if (i == b[0] || i == b[1] || i == b[2]) return true;
  return false;
}

}  // namespace

std::size_t countTriangleIntersections(std::span<const std::array<Index, 3>> triangles,
                                       std::span<const Vec3> positions) {
  for (const auto& t : triangles)
    for (Index i : t)
      if (i >= positions.size())
        throw std::out_of_range("countTriangleIntersections: vertex index out of range");

  // Candidates: finite triangles with their boxes and exponent levels.
  // The buffers outlive the call, one set per calling thread: the count runs every frame, and
  // fresh multi-megabyte buffers would cost page faults every time, a large part of the total.
  // A thread that starts another count while waiting inside this one (task stealing) gets fresh
  // buffers instead.
  thread_local Workspace cached;
  thread_local bool cachedInUse = false;
  Workspace fresh;
  const bool useCached = !cachedInUse;
  Workspace& workspace = useCached ? cached : fresh;
  struct Claim {
    bool active;
    ~Claim() {
      if (active) cachedInUse = false;
    }
  } claim{useCached};
  if (useCached) cachedInUse = true;
  std::vector<Candidate>& candidates = workspace.candidates;
  std::vector<int>& exponent = workspace.exponent;  // INT_MIN for a point (zero extent)
  candidates.clear();
  for (const auto& t : triangles) {
    const Vec3d a = positions[t[0]].cast<double>(), b = positions[t[1]].cast<double>(),
                c = positions[t[2]].cast<double>();
    if (!a.allFinite() || !b.allFinite() || !c.allFinite()) continue;
    Candidate k;
    k.v = {a, b, c};
    k.box = {a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c)};
    k.indices = t;
    candidates.push_back(k);
  }
  const std::size_t n = candidates.size();
  if (n < 2) return 0;
  exponent.resize(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      Candidate& k = candidates[i];
      k.axis = projectionAxis(k.v);
      const double extent = (k.box.hi - k.box.lo).maxCoeff();
      exponent[i] = extent > 0 ? std::max(levelFor(extent), kFinestLevel) : INT_MIN;
    }
  });

  // Distinct levels, at most kMaxLevels: finer ones move up to the finest kept (a coarser cell
  // than needed only costs time). A point takes the finest level.
  std::vector<int> levels;
  for (int e : exponent)
    if (e != INT_MIN) levels.push_back(e);
  std::sort(levels.begin(), levels.end());
  levels.erase(std::unique(levels.begin(), levels.end()), levels.end());
  if (levels.empty()) levels.push_back(0);
  if (levels.size() > kMaxLevels)
    levels.erase(levels.begin(), levels.end() - static_cast<std::ptrdiff_t>(kMaxLevels));
  for (std::size_t i = 0; i < n; ++i) {
    const int e = std::max(exponent[i], levels.front());
    candidates[i].level =
        static_cast<int>(std::lower_bound(levels.begin(), levels.end(), e) - levels.begin());
  }
  // Every level in the list has owners.
  const int levelCount = static_cast<int>(levels.size());
  std::vector<double> inverseCellSize(levelCount);
  for (int l = 0; l < levelCount; ++l) inverseCellSize[l] = std::ldexp(1.0, -levels[l]);

  // Cell range of a box at a level.
  auto cellRange = [&](const Box& box, int levelIndex, std::array<std::int64_t, 3>& lo,
                       std::array<std::int64_t, 3>& hi) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = cellIndex(box.lo[a], inverseCellSize[levelIndex]);
      hi[a] = cellIndex(box.hi[a], inverseCellSize[levelIndex]);
    }
  };
  auto cellsAt = [&](const Box& box, int levelIndex) {
    std::array<std::int64_t, 3> lo, hi;
    cellRange(box, levelIndex, lo, hi);
    return static_cast<std::size_t>((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) *
                                    (hi[2] - lo[2] + 1));
  };

  // Entries: count, offsets, fill (each triangle writes its own slots).
  std::vector<std::size_t>& offset = workspace.offset;
  offset.assign(n + 1, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      std::size_t count = 0;
      for (int l = candidates[i].level; l < levelCount; ++l) count += cellsAt(candidates[i].box, l);
      offset[i + 1] = count;
    }
  });
  for (std::size_t i = 0; i < n; ++i) offset[i + 1] += offset[i];
  std::vector<Entry>& entries = workspace.entries;
  entries.resize(offset[n]);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      std::size_t at = offset[i];
      const Candidate& k = candidates[i];
      for (int l = k.level; l < levelCount; ++l) {
        std::array<std::int64_t, 3> lo, hi;
        cellRange(k.box, l, lo, hi);
        for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
          for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
            for (std::int64_t z = lo[2]; z <= hi[2]; ++z)
              entries[at++] = {cellKey(l, x, y, z), (l == k.level ? 0 : Entry::kVisitor) |
                                                        static_cast<std::uint32_t>(i)};
      }
    }
  });
  sortByKey(entries, workspace.scratch);

  // Runs of equal keys.
  std::vector<std::size_t>& runStart = workspace.runStart;
  runStart.clear();
  for (std::size_t e = 0; e < entries.size(); ++e)
    if (e == 0 || entries[e].key != entries[e - 1].key) runStart.push_back(e);
  runStart.push_back(entries.size());

  // Within a cell, a sweep along x over the boxes (sorted by their lower x) finds the pairs whose
  // boxes overlap without looking at every pair of the cell.
  struct Swept {
    Box box;
    std::uint32_t candidate;
    bool visitor;
  };
  auto countInRun = [&](std::size_t begin, std::size_t end, std::vector<Swept>& swept) {
    if (end - begin < 2 || std::none_of(entries.begin() + begin, entries.begin() + end,
                                        [](const Entry& e) { return !e.visitor(); }))
      return std::size_t{0};  // visitors alone: no pair to take
    const std::uint64_t key = entries[begin].key;
    const int level = static_cast<int>(key >> (3 * kCellBits));
    swept.clear();
    for (std::size_t e = begin; e < end; ++e)
      swept.push_back(
          {candidates[entries[e].triangle()].box, entries[e].triangle(), entries[e].visitor()});
    std::sort(swept.begin(), swept.end(), [](const Swept& a, const Swept& b) {
      return a.box.lo.x() != b.box.lo.x() ? a.box.lo.x() < b.box.lo.x() : a.candidate < b.candidate;
    });
    std::size_t count = 0;
    for (std::size_t e = 0; e < swept.size(); ++e) {
      const Swept& sa = swept[e];
      for (std::size_t f = e + 1; f < swept.size() && swept[f].box.lo.x() <= sa.box.hi.x(); ++f) {
        const Swept& sb = swept[f];
        if ((sa.visitor && sb.visitor) || !overlap(sa.box, sb.box)) continue;
        const Candidate& a = candidates[sa.candidate];
        const Candidate& b = candidates[sb.candidate];
        if (shareVertex(a.indices, b.indices)) continue;
        // Count the pair only in the lowest corner of the common cell range at this level.
        std::array<std::int64_t, 3> aLo, aHi, bLo, bHi;
        cellRange(a.box, level, aLo, aHi);
        cellRange(b.box, level, bLo, bHi);
        if (cellKey(level, std::max(aLo[0], bLo[0]), std::max(aLo[1], bLo[1]),
                    std::max(aLo[2], bLo[2])) != key)
          continue;
        if (classifiedTrianglesIntersect(a.v, a.axis, b.v, b.axis)) ++count;
      }
    }
    return count;
  };
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, runStart.size() - 1, 16), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t sum) {
        std::vector<Swept> swept;
        for (std::size_t run = r.begin(); run != r.end(); ++run)
          sum += countInRun(runStart[run], runStart[run + 1], swept);
        return sum;
      },
      [](std::size_t x, std::size_t y) { return x + y; });
}

}  // namespace nucleon
