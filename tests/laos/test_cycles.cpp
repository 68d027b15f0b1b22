// Amplitudes, cycles, steady state, M cap, noise standard errors and bad input.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "laos/laos_test_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/laos/analysis.hpp"

using namespace shearzone;
using namespace shearzone::laos;
using testutil::kPi;

namespace {
constexpr double kExact = 1e-9;  // models in the basis (see test_closed_form.cpp)
bool rel_close(double a, double b, double tol) { return std::abs(a - b) <= tol * std::abs(b); }
}  // namespace

TEST_CASE("white noise: reported SEs match sigma sqrt(2/N)/x0 over 200 seeds", "[laos]") {
  // White noise σ on uniform θ: SE(K'_n) ≈ σ √(2/N)/x0. Uniform θ over 4 cycles,
  // N = 4000 samples (+1 closing sample).
  const double x0 = 0.1, sigma = 0.01, G = 50;
  const int N = 4000;
  std::vector<double> th(N + 1), w(N + 1, 0.0);
  for (int i = 0; i <= N; ++i) th[static_cast<std::size_t>(i)] = 8 * kPi * i / N;
  add_trapezoid_weights(th, 0.0, 8 * kPi, w);
  const double expected = sigma * std::sqrt(2.0 / N) / x0;
  // The SE of one fit scatters by about 1/√(2(N − p)) = 1.1 % around its mean; 10 %
  // (the bound in docs/laos.md, "Accuracy") is 9 such widths.
  constexpr double kSeTol = 0.10;
  // The scatter of 200 estimates has a relative error of about 1/√400 = 5 %; 20 % is 4σ.
  constexpr double kScatterTol = 0.20;
  double worst = 0, sum = 0, sum2 = 0;
  for (std::uint32_t seed = 1; seed <= 200; ++seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    std::vector<double> r(th.size());
    for (std::size_t i = 0; i < th.size(); ++i) r[i] = G * x0 * std::sin(th[i]) + noise(rng);
    const auto f = fit_harmonics(th, r, w, x0, {});
    for (int n = 1; n <= 9; ++n) {
      worst = std::max(worst, std::abs(f.Kp_se[n] / expected - 1));
      worst = std::max(worst, std::abs(f.Kpp_se[n] / expected - 1));
    }
    sum += f.Kp[3];
    sum2 += f.Kp[3] * f.Kp[3];
  }
  INFO("worst SE deviation " << worst);
  testutil::note("noise: worst |SE/(sigma sqrt(2/N)/x0) - 1| over 200 seeds, n = 1..9", worst);
  CHECK(worst <= kSeTol);
  const double sd = std::sqrt((sum2 - sum * sum / 200) / 199);
  CHECK(std::abs(sd / expected - 1) <= kScatterTol);
  testutil::note("noise: scatter of K'3 / predicted SE - 1", sd / expected - 1);
}

TEST_CASE("two amplitudes in one record split at a 5 % change", "[laos]") {
  const double omega = 2, G = 30, eta = 4;
  Waveform w;
  const int per = 400;
  for (int i = 0; i <= per * 8; ++i) {
    const double t = 2 * kPi / omega * i / per;
    const double x0 = i < per * 4 ? 0.1 : 0.3;  // switches at an upward crossing
    const double th = omega * t;
    w.time_s.push_back(t);
    // Phase reduced to one cycle so that the switching sample is exactly 0.
    w.drive.push_back(x0 * std::sin(2 * kPi * (i % per) / per));
    w.response.push_back(G * x0 * std::sin(th) + eta * x0 * omega * std::cos(th));
  }
  const auto r = analyse_record(w, {}, "synthetic");
  REQUIRE(r.amplitudes.size() == 2);
  CHECK(rel_close(r.amplitudes[0].x0, 0.1, kExact));
  CHECK(rel_close(r.amplitudes[1].x0, 0.3, kExact));
  for (const auto& A : r.amplitudes) {
    CHECK(A.cycles.size() >= 3);
    CHECK(rel_close(A.measures.K1p, G, kExact));
    CHECK(rel_close(A.measures.K1pp, eta * omega, kExact));
  }
}

TEST_CASE("partial cycles are dropped and counted, --cycles selects", "[laos]") {
  const double x0 = 0.2;  // ω = 1
  // Start a quarter cycle late and stop a quarter cycle early: 3 complete, 2 partial.
  Waveform w;
  for (int i = 100; i <= 400 * 4 - 100; ++i) {
    const double t = 2 * kPi * i / 400.0;
    w.time_s.push_back(t);
    w.drive.push_back(x0 * std::sin(t));
    w.response.push_back(5 * x0 * std::sin(t));
  }
  AnalysisOptions o;
  o.cycles = {2};
  const auto A = analyse_record(w, o, "synthetic").amplitudes.at(0);
  CHECK(A.cycles.size() == 2);
  CHECK(A.partial_cycles == 2);
  CHECK(std::string(amplitude_status_name(A.status)) == "cycles_selected");
  CHECK_FALSE(A.cycles[0].used);
  CHECK(A.cycles[1].used);
  CHECK(rel_close(A.cycles[1].t_start_s, 2 * kPi * 2, kExact));
  o.cycles = {3};
  CHECK_THROWS_AS(analyse_record(w, o, "synthetic"), ConfigError);
}

TEST_CASE("timed M cap is (samples per cycle - 1)/2 and is recorded", "[laos]") {
  const auto w = testutil::timed(0.1, 1.0, 12, 3, [](double th, double) { return std::sin(th); });
  AnalysisOptions o;
  o.max_harmonic = 9;
  const auto A = analyse_record(w, o, "synthetic").amplitudes.at(0);
  CHECK(A.M_cap == 5);
  CHECK(A.M == 5);
  CHECK(A.M_requested == 9);
}

TEST_CASE("a record without time and without omega reports rates as unavailable", "[laos]") {
  const auto w = testutil::angle_sampled(0.05, 1e-3, 2, [](double th) { return 3 * std::cos(th); });
  const auto A = analyse_record(w, {}, "synthetic").amplitudes.at(0);
  CHECK(std::isnan(A.omega));
  CHECK(std::isnan(A.measures.eta_L));
  CHECK(std::isnan(A.measures.v[1]));
  CHECK(rel_close(A.measures.K1pp, 3 / 0.05, kExact));
  CHECK(std::abs(A.measures.T) <= kExact);  // a ratio: available without ω
}

TEST_CASE("inertia subtraction removes I phi-double-dot", "[laos]") {
  const double x0 = 0.1, omega = 5, I = 2e-3, K = 1.5;
  // Measured torque = sample torque + I φ̈ = K φ − I ω² φ.
  const auto w = testutil::timed(x0, omega, 500, 3, [&](double th, double) {
    return (K - I * omega * omega) * x0 * std::sin(th);
  });
  AnalysisOptions o;
  o.inertia = I;
  CHECK(rel_close(analyse_record(w, o, "synthetic").amplitudes.at(0).measures.K1p, K, kExact));
  // Without time or ω the subtraction is impossible: a configuration error.
  auto a = testutil::angle_sampled(0.05, 1e-3, 2, [](double th) { return std::sin(th); });
  CHECK_THROWS_AS(analyse_record(a, o, "synthetic"), ConfigError);
}

TEST_CASE("bad records: zero amplitude and less than one cycle name the lines", "[laos]") {
  Waveform w;
  const std::string ctx = "log.csv: segment \"1\"";
  for (int i = 0; i < 50; ++i) {
    w.time_s.push_back(i * 0.1);
    w.drive.push_back(0.0);
    w.response.push_back(1.0);
    w.line.push_back(static_cast<std::size_t>(i) + 3);
  }
  CHECK_THROWS_WITH(analyse_record(w, {}, ctx),
                    Catch::Contains("log.csv: segment \"1\": lines 3-52: drive amplitude is zero"));
  for (int i = 0; i < 50; ++i) w.drive[static_cast<std::size_t>(i)] = std::sin(0.1 * i);  // 0.8 cycle
  CHECK_THROWS_AS(analyse_record(w, {}, ctx), InputError);
  CHECK_THROWS_WITH(analyse_record(w, {}, ctx), Catch::Contains("lines 3-52"));
}

TEST_CASE("guards: a drive that is no steady oscillation, or a meaningless fit, is exit 3",
          "[laos]") {
  // A chirp (0.5 Hz to 2 Hz): one amplitude, but no single frequency.
  Waveform chirp;
  for (int i = 0; i < 1200; ++i) {
    const double t = i * 0.005;
    chirp.time_s.push_back(t);
    chirp.drive.push_back(0.1 * std::sin(2 * std::numbers::pi * (0.5 * t + 0.125 * t * t)));
    chirp.response.push_back(2.0 * chirp.drive.back());
  }
  CHECK_THROWS_WITH(analyse_record(chirp, {}, "chirp"), Catch::Contains("not a steady oscillation"));
  CHECK_THROWS_AS(analyse_record(chirp, {}, "chirp"), NoResultError);
  AnalysisOptions loose;
  loose.max_drive_misfit = 10;  // the limit is an option
  CHECK_NOTHROW(analyse_record(chirp, loose, "chirp"));

  // A response that does not follow the drive: noise 100x the elastic part.
  Waveform noisy =
      testutil::timed(0.1, 2 * std::numbers::pi, 100, 4, [](double th, double) { return 1e-4 * std::sin(th); });
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (auto& r : noisy.response) r += 10.0 * noise(rng);
  CHECK_THROWS_WITH(analyse_record(noisy, {}, "noisy"), Catch::Contains("harmonic fit is meaningless"));
}

TEST_CASE("guards: --no-split over several amplitudes is refused unless forced", "[laos]") {
  auto kelvin = [](double x0) {
    return [x0](double th, double) { return x0 * (std::sin(th) + 0.1 * std::cos(th)); };
  };
  Waveform a = testutil::timed(0.05, 2 * std::numbers::pi, 100, 3, kelvin(0.05));
  const Waveform b = testutil::timed(0.1, 2 * std::numbers::pi, 100, 3, kelvin(0.1));
  const double t_end = a.time_s.back();
  for (std::size_t i = 1; i < b.drive.size(); ++i) {
    a.time_s.push_back(t_end + b.time_s[i]);
    a.drive.push_back(b.drive[i]);
    a.response.push_back(b.response[i]);
  }
  AnalysisOptions o;
  o.split_amplitudes = false;
  CHECK_THROWS_WITH(analyse_record(a, o, "two"), Catch::Contains("--no-split over several amplitudes"));
  CHECK_THROWS_AS(analyse_record(a, o, "two"), NoResultError);
  o.split_amplitudes = true;
  CHECK(analyse_record(a, o, "two").amplitudes.size() == 2);
}

// Issue 34: the simulated cup's tau_max was one impulsive contact (6.0 mN m against a
// 99th percentile of 1.3). tau_max is now min(the largest sample, the largest value of
// the cycle's odd-harmonic reconstruction); the raw largest sample is kept beside it.
TEST_CASE("tau_max ignores a single spike and keeps a plateau, the raw maximum keeps the spike", "[laos]") {
  const double x0 = 0.3, omega = 2 * kPi * 0.5;
  const double G1 = 0.01, G3 = 0.002;  // torque per rad: elastic first and third harmonic
  auto model = [&](double th, double) { return x0 * (G1 * std::sin(th) + G3 * std::sin(3 * th)); };
  Waveform w = testutil::timed(x0, omega, 400, 4, model);
  double exact = 0;  // the exact maximum over a period
  for (int k = 0; k < 100000; ++k) exact = std::max(exact, std::abs(model(2 * kPi * k / 100000.0, 0)));
  // 400 samples per cycle: the sampled peak misses the exact one by < 1e-4.
  constexpr double kSampledPeak = 1e-4;
  const auto clean = analyse_record(w, {}, "synthetic").amplitudes.at(0);
  CHECK(clean.r_max == Approx(exact).epsilon(kSampledPeak));
  CHECK(clean.r_max_raw == Approx(exact).epsilon(kSampledPeak));
  // One sample in the last cycle 5x the torque amplitude.
  w.response[w.response.size() - 150] += 5 * exact;
  const auto spiked = analyse_record(w, {}, "synthetic").amplitudes.at(0);
  INFO("tau_max " << spiked.r_max << ", raw " << spiked.r_max_raw << ", exact " << exact);
  // The spike s leaks into each of the 5 odd harmonics (n <= 9) by at most 2 s/N: 12.5 %
  // of the peak in its cycle for s = 5 peaks and N = 400, less in the mean over cycles.
  constexpr double kLeakage = 5 * 2 * 5.0 / 400;
  CHECK(spiked.r_max == Approx(exact).epsilon(kLeakage));
  CHECK(spiked.r_max_raw > 1.5 * exact);  // the raw maximum carries it
  // A square wave (Coulomb friction): the plateau, not the reconstruction's overshoot.
  const double ty = 0.004;
  Waveform sq = testutil::timed(x0, omega, 400, 4, [&](double th, double) { return std::cos(th) > 0 ? ty : -ty; });
  const auto square = analyse_record(sq, {}, "synthetic").amplitudes.at(0);
  CHECK(square.r_max == Approx(ty).epsilon(1e-12));
}
