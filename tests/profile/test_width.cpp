// Shear-zone width r_c: scan, statuses and bootstrap coverage (issue #4, "Width").
#include <cmath>
#include <random>

#include <catch2/catch.hpp>

#include "shearzone/profile/width.hpp"

using namespace shearzone::profile;

namespace {

std::vector<std::size_t> ones(std::size_t n) { return std::vector<std::size_t>(n, 1); }

}  // namespace

TEST_CASE("r_c interpolates linearly between the bracketing bins", "[profile][width]") {
  const std::vector<double> r = {1, 2, 3, 4}, v = {10, 8, 4, 1};
  WidthStatus st;
  CHECK(scan_rc(r, v, ones(4), 6.0, 5.0, st) == Approx(2.5));
  CHECK(st == WidthStatus::kOk);
  CHECK(scan_rc(r, v, ones(4), 0.5, 5.0, st) == 5.0);
  CHECK(st == WidthStatus::kNeverBelow);
  CHECK(scan_rc(r, v, ones(4), 20, 5.0, st) == 1.0);
  CHECK(st == WidthStatus::kBelowAtVane);
  // Empty bins are skipped: bin 2 (r = 3) has no data.
  CHECK(scan_rc(r, v, {1, 1, 0, 1}, 6.0, 5.0, st) == Approx(2 + 2.0 / 7.0 * 2));
  CHECK(std::string(width_status_name(WidthStatus::kNoiseLimited)) == "noise_limited");
}

TEST_CASE("the noise floor overrides the status", "[profile][width]") {
  WidthInput in;
  in.r_m = {1, 2, 3};
  in.v_abs = {10, 5, 1};
  in.v_abs_sem = {0, 0, 0};
  in.n_vectors = ones(3);
  in.v_noise = {1, 1, 1};
  in.R_m = 4;
  WidthOptions o;
  o.bootstrap = 0;
  o.v_c_m_per_s = 2.9;  // < 3 x noise
  CHECK(shear_zone_width(in, o).status == WidthStatus::kNoiseLimited);
  o.v_c_m_per_s = 3.1;
  CHECK(shear_zone_width(in, o).status == WidthStatus::kOk);
}

// Issue #4: 95 % bootstrap CIs over 400 seeded synthetic repetitions cover the truth
// between 91.5 % and 98.5 % of the time. Design: a profile v(r) = V0 exp(-(r - Rv)/L)
// on 0.5 mm bins, measured over 24 cycles whose bin means scatter by 25 % (log-normal,
// independent between cycles, as the cycle-to-cycle variation of the paper's
// profiles). The truth is r_c of the noise-free binned profile (what the estimator
// converges to); the bootstrap resamples the cycles.
TEST_CASE("bootstrap CIs of r_c cover the truth 91.5-98.5 % of the time", "[profile][width]") {
  constexpr int kRepetitions = 400;
  constexpr int kCycles = 24;
  constexpr double kScatter = 0.25;
  const double Rv = 0.011, L = 0.004, V0 = 2e-3, bin = 0.5e-3, R = 0.034;
  std::vector<double> r;
  for (double x = Rv + bin / 2; x < R; x += bin) r.push_back(x);
  const std::size_t nb = r.size();
  std::vector<double> truth_v(nb);
  for (std::size_t k = 0; k < nb; ++k) truth_v[k] = V0 * std::exp(-(r[k] - Rv) / L);
  WidthStatus st;
  const double truth = scan_rc(r, truth_v, ones(nb), 4e-5, R, st);
  REQUIRE(st == WidthStatus::kOk);
  int covered = 0;
  std::mt19937_64 rng(2024);
  std::normal_distribution<double> z(0.0, 1.0);
  for (int rep = 0; rep < kRepetitions; ++rep) {
    WidthInput in;
    in.r_m = r;
    in.R_m = R;
    in.v_abs.assign(nb, 0.0);
    in.v_abs_sem.assign(nb, 0.0);
    in.n_vectors.assign(nb, 0);
    in.v_noise.assign(nb, 1e-6);
    for (int c = 0; c < kCycles; ++c)
      for (std::size_t k = 0; k < nb; ++k) {
        // Median-unbiased log-normal scatter, mean-corrected so E[v] = truth.
        const double v = truth_v[k] * std::exp(kScatter * z(rng) - 0.5 * kScatter * kScatter);
        in.groups.push_back({c, k, v, 100});
        in.v_abs[k] += v / kCycles;
        in.n_vectors[k] += 100;
      }
    WidthOptions o;
    o.bootstrap = 1000;
    o.seed = static_cast<std::uint64_t>(rep) + 1;
    const auto res = shear_zone_width(in, o);
    covered += res.ci_low_m <= truth && truth <= res.ci_high_m;
  }
  const double coverage = static_cast<double>(covered) / kRepetitions;
  INFO("coverage " << coverage);
  CHECK(coverage >= 0.915);
  CHECK(coverage <= 0.985);
}

TEST_CASE("the bootstrap is deterministic for a seed", "[profile][width]") {
  WidthInput in;
  in.r_m = {1, 2, 3, 4};
  in.R_m = 5;
  in.v_abs = {10, 6, 3, 1};
  in.v_abs_sem = {1, 1, 1, 1};
  in.n_vectors = ones(4);
  in.v_noise = {0, 0, 0, 0};
  WidthOptions o;
  o.v_c_m_per_s = 4;
  const auto a = shear_zone_width(in, o), b = shear_zone_width(in, o);
  CHECK(a.ci_low_m == b.ci_low_m);
  CHECK(a.ci_high_m == b.ci_high_m);
  CHECK(a.ci_low_m < a.rc_m);
  CHECK(a.rc_m < a.ci_high_m);
}
