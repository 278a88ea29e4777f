// Scalar and vector types shared by the public API and the solver.
//
// Solver state is float by default: twice the SIMD width and half the memory traffic of double.
// Configure with -DNUCLEON_DOUBLE=ON to make Real a double; the define is part of the exported
// target, so consumers see the same type as the library.
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products

namespace nucleon {

#ifdef NUCLEON_DOUBLE
using Real = double;
#else
using Real = float;
#endif

// Unaligned 3-vector: 12 bytes in float, so an array of them is densely packed (no padding to 16).
using Vec3 = Eigen::Matrix<Real, 3, 1, Eigen::DontAlign>;
using Vec3d = Eigen::Matrix<double, 3, 1, Eigen::DontAlign>;
using Mat3d = Eigen::Matrix<double, 3, 3, Eigen::DontAlign>;

// Index of a particle (0-simplex) or of a higher simplex inside its pool.
using Index = std::uint32_t;

static_assert(sizeof(Vec3) == 3 * sizeof(Real), "Vec3 must be densely packed");

}  // namespace nucleon
