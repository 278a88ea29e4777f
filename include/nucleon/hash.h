// 64-bit FNV-1a (Fowler, Noll and Vo), the one hash nucleon prints and compares: the state hash
// (World::stateHash), the command line's run label and a checkpoint's structure fingerprint. Not
// for security; a fast, stable fingerprint of bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace nucleon {

struct Fnv1a {
  std::uint64_t value = 14695981039346656037ull;  // the offset basis

  void add(const void* data, std::size_t bytes) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < bytes; ++k) value = (value ^ b[k]) * 1099511628211ull;
  }
  void add(std::string_view text) { add(text.data(), text.size()); }
};

}  // namespace nucleon
