#include "shearzone/core/stats.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include "shearzone/core/check.hpp"
#include "shearzone/core/unset.hpp"

namespace shearzone::core {

namespace {

template <class T>
T upper_median_of(std::span<T> v) {
  if (v.empty()) return std::numeric_limits<T>::quiet_NaN();
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

double median_inplace(std::span<double> v) {
  const std::size_t n = v.size();
  if (n == 0) return core::kUnset;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(n / 2);
  std::nth_element(v.begin(), mid, v.end());
  double m = *mid;
  if (n % 2 == 0) {
    // The lower middle value is the largest of the lower half nth_element left.
    const double lo = *std::max_element(v.begin(), mid);
    m = 0.5 * (m + lo);
  }
  return m;
}

double upper_median_inplace(std::span<double> v) { return upper_median_of(v); }

float upper_median_inplace(std::span<float> v) { return upper_median_of(v); }

double percentile(std::vector<double> v, double q) {
  SHEARZONE_DCHECK(q >= 0 && q <= 1);
  if (v.empty()) return core::kUnset;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace shearzone::core
