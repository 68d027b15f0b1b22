#include <catch2/catch.hpp>

#include "shearzone/piv/validate.hpp"

using namespace shearzone;
using core::VectorFlag;

namespace {
core::VectorField uniform_field(std::size_t n, float u, float v) {
  core::VectorField f;
  for (std::size_t k = 0; k < n; ++k) {
    f.x_px.push_back(8.0 * k);
    f.y_px.push_back(8.0 * k);
  }
  f.resize_to_grid();
  for (std::size_t k = 0; k < f.size(); ++k) {
    f.u_px[k] = u + 0.01f * static_cast<float>(k % 3);  // a little noise
    f.v_px[k] = v;
  }
  return f;
}
}  // namespace

TEST_CASE("the normalised median test flags a planted outlier and nothing else", "[piv]") {
  auto f = uniform_field(7, 2.0f, -1.0f);
  const std::size_t k = f.index(3, 3);
  f.u_px[k] = 3.5f;
  piv::PivOptions o;
  CHECK(piv::flag_outliers(f, o) == 1);
  CHECK(f.flag[k] == VectorFlag::kReplaced);
  CHECK(f.count(VectorFlag::kValid) == f.size() - 1);
  piv::fill_holes(f, {VectorFlag::kReplaced});
  CHECK(f.u_px[k] == Approx(2.01f).margin(0.02f));
  CHECK(f.flag[k] == VectorFlag::kReplaced);  // the flag stays: the value is interpolated
}

TEST_CASE("masked and invalid neighbours take no part in the median test", "[piv]") {
  auto f = uniform_field(5, 1.0f, 1.0f);
  for (std::size_t j = 0; j < 5; ++j) {
    f.flag[f.index(0, j)] = VectorFlag::kMasked;
    f.u_px[f.index(0, j)] = 0.0f;  // masked vectors are zero; they must not count
  }
  piv::PivOptions o;
  CHECK(piv::flag_outliers(f, o) == 0);
}

TEST_CASE("the displacement limit and std filter flag extreme vectors", "[piv]") {
  auto f = uniform_field(6, 1.0f, 0.0f);
  f.u_px[f.index(5, 5)] = 40.0f;
  piv::PivOptions o;
  o.median_threshold = 0;  // off: only the global limit
  o.max_displacement_px = 10;
  CHECK(piv::flag_outliers(f, o) == 1);
  CHECK(f.flag[f.index(5, 5)] == VectorFlag::kReplaced);
}

TEST_CASE("a lone valid vector among failed windows becomes invalid", "[piv]") {
  auto f = uniform_field(7, 1.0f, 0.0f);
  for (auto& fl : f.flag) fl = VectorFlag::kInvalid;
  f.flag[f.index(3, 3)] = VectorFlag::kValid;
  f.flag[f.index(3, 4)] = VectorFlag::kValid;
  piv::PivOptions o;
  piv::flag_outliers(f, o);
  CHECK(f.count(VectorFlag::kValid) == 0);
}

TEST_CASE("holes are filled from known neighbours, growing inwards", "[piv]") {
  auto f = uniform_field(6, 2.0f, 3.0f);
  for (std::size_t i = 1; i < 5; ++i)
    for (std::size_t j = 1; j < 5; ++j) {
      f.flag[f.index(i, j)] = VectorFlag::kInvalid;
      f.u_px[f.index(i, j)] = -99.0f;
    }
  piv::fill_holes(f, {VectorFlag::kInvalid});
  for (std::size_t k = 0; k < f.size(); ++k) {
    CHECK(f.u_px[k] == Approx(2.01f).margin(0.02f));
    CHECK(f.v_px[k] == Approx(3.0f));
  }
}

TEST_CASE("holes with no known vector anywhere become zero, not NaN", "[piv]") {
  auto f = uniform_field(4, 5.0f, 5.0f);
  for (auto& fl : f.flag) fl = VectorFlag::kInvalid;
  piv::fill_holes(f, {VectorFlag::kInvalid});
  for (std::size_t k = 0; k < f.size(); ++k) {
    CHECK(f.u_px[k] == 0.0f);
    CHECK(f.v_px[k] == 0.0f);
  }
}

TEST_CASE("replacements stay only where the neighbours were measured", "[piv]") {
  auto f = uniform_field(9, 2.0f, -1.0f);
  // An isolated outlier (all 8 neighbours valid) and a 3x3 block of replaced vectors.
  const std::size_t lone = f.index(1, 1);
  f.flag[lone] = VectorFlag::kReplaced;
  for (std::size_t i = 5; i < 8; ++i)
    for (std::size_t j = 5; j < 8; ++j) f.flag[f.index(i, j)] = VectorFlag::kReplaced;
  // A corner of the grid: 3 in-grid neighbours, all valid, is still supported.
  const std::size_t corner = f.index(0, 8);
  f.flag[corner] = VectorFlag::kReplaced;
  CHECK(piv::demote_unsupported_replacements(f) == 9 - 4);  // the block's centre and
  CHECK(f.flag[lone] == VectorFlag::kReplaced);             // its 4 edge-middles (4 of 8
  CHECK(f.flag[corner] == VectorFlag::kReplaced);           // valid) fail; its corners
  CHECK(f.flag[f.index(6, 6)] == VectorFlag::kInvalid);     // (5 of 8 valid) stay
  CHECK(f.flag[f.index(5, 6)] == VectorFlag::kInvalid);
  CHECK(f.flag[f.index(5, 5)] == VectorFlag::kReplaced);
}
