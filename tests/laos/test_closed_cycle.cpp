// One stored period per measuring point (Anton Paar): analyse_closed_cycle against
// closed forms, and the laos job on the French look-alike export of tests/data/logs.
#include <cmath>
#include <numbers>
#include <string>

#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/laos/analysis.hpp"
#include "shearzone/pipeline/laos_job.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using shearzone::testing::TempDir;

namespace {
constexpr double kTwoPi = 2 * std::numbers::pi;
/// Exact samples: the DFT of a band-limited period returns its coefficients to round-off.
constexpr double kExact = 1e-10;
/// The look-alike file holds 6 significant digits: coefficients to ~1e-5 relative.
constexpr double kRoundingRel = 2e-5;

/// N + 1 samples of one period: x = x0 sin θ + c, r = x0 Σ (K'_n sin nθ + K''_n cos nθ),
/// θ_k = 2πk/N + ψ.
core::Waveform period(int N, double x0, double c, double psi, double K1p, double K1pp,
                      double K3p, double K3pp) {
  core::Waveform w;
  for (int k = 0; k <= N; ++k) {
    const double th = kTwoPi * (k % N) / N + psi;
    w.drive.push_back(x0 * std::sin(th) + c);
    w.response.push_back(x0 * (K1p * std::sin(th) + K1pp * std::cos(th) + K3p * std::sin(3 * th) +
                               K3pp * std::cos(3 * th)));
  }
  return w;
}
/// Runs the laos job with default options on tests/data/logs/<name> into <dir>/out.
pipeline::LaosJobSummary run_sample_log(const std::string& name, const TempDir& dir) {
  pipeline::LaosJobOptions o;
  o.inputs = {std::filesystem::path(SHEARZONE_TEST_DATA_DIR) / "logs" / name};
  o.output = dir / "out";
  return pipeline::run_laos_job(o, core::standard_metadata("test"));
}
}  // namespace

TEST_CASE("closed cycle: the DFT of one period gives the harmonics exactly", "[laos]") {
  const auto w = period(128, 0.2, 0.01, 2.5, 3.0, 1.5, 0.4, -0.2);
  laos::AnalysisOptions o;
  o.max_harmonic = 5;
  const auto A = laos::analyse_closed_cycle(w, o, kTwoPi * 0.5, "synthetic");
  CHECK(A.status == laos::AmplitudeStatus::kClosedCycle);
  CHECK(A.phase_method == "closed_cycle_dft");
  CHECK(A.x0 == Approx(0.2).epsilon(kExact));
  CHECK(A.x_offset == Approx(0.01).epsilon(kExact));
  CHECK(A.M == 5);
  CHECK(A.M_cap == 63);
  CHECK(A.fit.Kp[1] == Approx(3.0).epsilon(kExact));
  CHECK(A.fit.Kpp[1] == Approx(1.5).epsilon(kExact));
  CHECK(A.fit.Kp[3] == Approx(0.4).epsilon(kExact));
  CHECK(A.fit.Kpp[3] == Approx(-0.2).epsilon(kExact));
  CHECK(std::abs(A.fit.Kp[2]) < kExact);
  CHECK(A.omega == Approx(kTwoPi * 0.5));
  CHECK(A.measures.tan_delta == Approx(0.5).epsilon(kExact));
  // Loop area of the first harmonic: π x0² K''_1 (higher odd harmonics add nothing).
  CHECK(A.E_d == Approx(std::numbers::pi * 0.04 * 1.5).epsilon(1e-3));  // trapezoid on 128 samples
  REQUIRE(A.cycles.size() == 1);
  CHECK(A.cycles[0].used);
  CHECK(A.theta.size() == 128);
  CHECK(A.theta.front() >= 0);
  CHECK(A.theta.back() < kTwoPi);
}

TEST_CASE("closed cycle: an open record, too few samples and a flat drive are refused", "[laos]") {
  laos::AnalysisOptions o;
  auto w = period(64, 0.1, 0, 0, 1, 1, 0, 0);
  w.drive.back() += 0.01;  // not the first sample again
  CHECK_THROWS_WITH(laos::analyse_closed_cycle(w, o, core::kUnset, "p"),
                    Catch::Contains("not a closed cycle"));
  const auto few = period(6, 0.1, 0, 0, 1, 1, 0, 0);
  CHECK_THROWS_AS(laos::analyse_closed_cycle(few, o, core::kUnset, "p"), InputError);
  auto flat = period(64, 0.1, 0, 0, 1, 1, 0, 0);
  for (auto& x : flat.drive) x = 0.5;
  CHECK_THROWS_AS(laos::analyse_closed_cycle(flat, o, core::kUnset, "p"), InputError);
}

TEST_CASE("laos job: a RheoCompass export with one period per point needs no options", "[laos]") {
  TempDir dir("laos-ap-points");
  const auto sum = run_sample_log("anton_paar_fr_points_utf16.txt", dir);
  CHECK(sum.stress_strain);
  REQUIRE(sum.rows.size() == 3);
  const auto t = io::read_csv(dir / "out" / "summary.csv");
  const auto h = io::read_csv(dir / "out" / "harmonics.csv");
  // make_logs.py, POINTS_FR: gamma0, G'1, G''1, G'3, G''3.
  const double pts[3][5] = {{0.01, 50, 9, 0, 0}, {0.1, 40, 10, 0.5, 0.2}, {1.0, 20, 12, 2, -1}};
  for (std::size_t p = 0; p < 3; ++p) {
    INFO("point " << p + 1);
    CHECK(t.rows[p][t.column_index("status")] == "closed_cycle");
    CHECK(t.number(p, t.column_index("gamma0")) == Approx(pts[p][0]).epsilon(kRoundingRel));
    CHECK(t.number(p, t.column_index("G1_prime_Pa")) == Approx(pts[p][1]).epsilon(kRoundingRel));
    CHECK(t.number(p, t.column_index("G1_dprime_Pa")) == Approx(pts[p][2]).epsilon(kRoundingRel));
    CHECK(t.number(p, t.column_index("omega_rad_per_s")) == Approx(kTwoPi * 0.3));
    CHECK(t.number(p, t.column_index("instrument_G_prime_Pa")) ==
          Approx(1.003 * pts[p][1]).epsilon(kRoundingRel));
    CHECK(t.number(p, t.column_index("instrument_f_Hz")) == Approx(0.3));
    // Third harmonic, relative to the first-harmonic scale.
    const std::size_t row = p * 9 + 2;  // M = 9 rows per point; n = 3
    REQUIRE(h.number(row, h.column_index("n")) == 3);
    CHECK(std::abs(h.number(row, h.column_index("G_prime_n_Pa")) - pts[p][3]) <= kRoundingRel * pts[p][1]);
    CHECK(std::abs(h.number(row, h.column_index("G_dprime_n_Pa")) - pts[p][4]) <= kRoundingRel * pts[p][1]);
  }
}

TEST_CASE("laos job: a Malvern rSpace export with a creeping angle gives K' and K''", "[laos]") {
  // make_logs.py malvern(): torque-controlled, K' = 0.06, K'' = 0.005 N m/rad, the angle
  // creeping by 3 % of phi0 per cycle (removed by the drift term of the drive's sine fit).
  TempDir dir("laos-malvern");
  run_sample_log("malvern_rspace.csv", dir);
  const auto t = io::read_csv(dir / "out" / "summary.csv");
  REQUIRE(t.num_rows() == 1);
  // Samples printed with 4 significant digits: 5e-4 per sample, averaged over 1440.
  constexpr double kFourDigits = 1e-3;
  CHECK(t.number(0, t.column_index("K1_prime_N_m_per_rad")) == Approx(0.06).epsilon(kFourDigits));
  CHECK(std::abs(t.number(0, t.column_index("K1_dprime_N_m_per_rad")) - 0.005) <= kFourDigits * 0.06);
  CHECK(t.number(0, t.column_index("instrument_f_Hz")) == Approx(0.04));
  CHECK(t.rows[0][t.column_index("segment")] == "Oscillation Single Frequency");
}

TEST_CASE("laos job: German RheoCompass angle/torque points, a closed period and a timed one",
          "[laos]") {
  // make_logs.py anton_paar_de_points(): the first interval's waveform (phi0 = 0.05 rad,
  // torque = K phi + C dphi/dt at 0.1 Hz); point 1 one closed period, point 2 two periods
  // with its own "Periodenzeit" from 0; two columns named "Drehmoment".
  TempDir dir("laos-ap-de-points");
  const auto sum = run_sample_log("anton_paar_de_points.txt", dir);
  CHECK_FALSE(sum.stress_strain);
  const auto t = io::read_csv(dir / "out" / "summary.csv");
  REQUIRE(t.num_rows() == 2);
  constexpr double kK = 4e-3, kC = 2e-3, kOmega = 2 * std::numbers::pi * 0.1;
  for (std::size_t p = 0; p < 2; ++p) {
    INFO("point " << p + 1);
    CHECK(t.rows[p][t.column_index("segment")] == "LAOS 1 / interval 2 / point " + std::to_string(p + 1));
    CHECK(t.number(p, t.column_index("phi0_rad")) == Approx(0.05).epsilon(kRoundingRel));
    CHECK(t.number(p, t.column_index("K1_prime_N_m_per_rad")) == Approx(kK).epsilon(kRoundingRel * 10));
    CHECK(t.number(p, t.column_index("K1_dprime_N_m_per_rad")) == Approx(kC * kOmega).epsilon(kRoundingRel * 10));
  }
  CHECK(t.rows[0][t.column_index("status")] == "closed_cycle");
  CHECK(t.rows[1][t.column_index("phase_method")] == "sine_fit");  // timed by Periodenzeit
}
