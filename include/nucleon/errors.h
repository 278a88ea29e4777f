// Exceptions the public API throws besides std::invalid_argument.
#pragma once

#include <stdexcept>

namespace nucleon {

// A mesh that no simplicial complex can be built from: out-of-range or repeated indices, a
// simplex given twice, nothing but degenerate simplices, an unreadable mesh file.
class MeshError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace nucleon
