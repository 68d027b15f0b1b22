// shearzone/core/hash.hpp: FNV-1a (64 bit) over bit patterns, the hash of the simulator's
// state (sim::World::state_hash) and of a run's id: the same input, the same value, on
// every run and thread count.
#pragma once

#include <cstddef>
#include <cstdint>

namespace shearzone::core {

struct Fnv1a {
  std::uint64_t h = 1469598103934665603ULL;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t k = 0; k < n; ++k) {
      h ^= c[k];
      h *= 1099511628211ULL;
    }
  }
  void d(double a) { bytes(&a, sizeof a); }
  void u(std::uint64_t a) { bytes(&a, sizeof a); }
};

}  // namespace shearzone::core
