#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "shearzone/core/stats.hpp"

using shearzone::core::median_inplace;
using shearzone::core::percentile;
using shearzone::core::upper_median_inplace;

TEST_CASE("median_inplace averages the two middle values of an even count", "[core]") {
  std::vector<double> odd{5, 1, 3};
  CHECK(median_inplace(odd) == 3.0);
  std::vector<double> even{4, 1, 3, 2};
  CHECK(median_inplace(even) == 2.5);
  std::vector<double> none;
  CHECK(std::isnan(median_inplace(none)));
}

TEST_CASE("upper_median_inplace takes the upper middle value, never an average", "[core]") {
  std::vector<double> odd{5, 1, 3};
  CHECK(upper_median_inplace(odd) == 3.0);
  std::vector<double> even{4, 1, 3, 2};
  CHECK(upper_median_inplace(even) == 3.0);
  std::vector<float> f{0.5f, 0.25f};
  CHECK(upper_median_inplace(f) == 0.5f);
  std::vector<double> none;
  CHECK(std::isnan(upper_median_inplace(none)));
}

TEST_CASE("percentile interpolates linearly between order statistics", "[core]") {
  const std::vector<double> v{10, 0, 30, 20};
  CHECK(percentile(v, 0.0) == 0.0);
  CHECK(percentile(v, 1.0) == 30.0);
  CHECK(percentile(v, 0.5) == 15.0);
  CHECK(percentile(v, 0.25) == Approx(7.5));
  CHECK(std::isnan(percentile({}, 0.5)));
}
