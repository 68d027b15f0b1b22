// tests/fit/fit_test_util.hpp: seeded Gaussian noise for the fit tests (portable:
// mt19937_64 is fully specified, Box–Muller is written out, unlike
// std::normal_distribution whose algorithm differs between standard libraries).
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

namespace shearzone::testing {

class Gauss {
 public:
  explicit Gauss(std::uint64_t seed) : rng_(seed) {}
  double operator()() {
    const double u1 = (static_cast<double>(rng_() >> 11) + 0.5) * 0x1.0p-53;
    const double u2 = static_cast<double>(rng_() >> 11) * 0x1.0p-53;
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::mt19937_64 rng_;
};

}  // namespace shearzone::testing
