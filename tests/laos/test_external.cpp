// External waveforms (tests/data/laos-external, README there): our estimator against
// the reference estimator C (weighted least squares) of that README, at M = 15.
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "laos/laos_test_util.hpp"
#include "shearzone/laos/analysis.hpp"

using namespace shearzone;
using namespace shearzone::laos;

namespace {
/// The agreement bound with estimator C for the robust quantities (docs/laos.md, "Accuracy").
constexpr double kRel = 0.01;
/// Absolute floor, as a fraction of |G*_1| (in the numerator's units for ratios).
constexpr double kFloor = 1e-3;
/// Regression values (K'_M, η'_M, S, T) are this code's own results at M = 15,
/// recorded when the test was written; they guard against unnoticed changes.
constexpr double kRegression = 1e-6;
/// SlugSlime's v3/v1 (a small viscous harmonic of a record holding four amplitudes)
/// differs from C by 4.5 %, 1.5x the floor: a known, documented deviation.
constexpr double kSlugV3 = 0.05;

struct Ref {
  double Gp, Gpp, tan_delta, I3, e3e1, v3v1, E_d;
};

std::string path(const std::string& rel) {
  return std::string(SHEARZONE_TEST_DATA_DIR) + "/laos-external/" + rel;
}

Waveform load(const std::string& rel, bool rheojax) {
  const auto t = testutil::read_table(path(rel));
  Waveform w;
  if (!rheojax) {
    w.time_s = t.cols[0];
    w.drive = t.cols[1];
    w.response = t.cols[2];
    return w;
  }
  // One exact cycle of 1024 points, strain in %: tile it three times (as the README).
  const std::size_t n = t.cols[0].size();
  const double T = (t.cols[0][1] - t.cols[0][0]) * static_cast<double>(n);
  for (int k = 0; k < 3; ++k)
    for (std::size_t i = 0; i < n; ++i) {
      w.time_s.push_back(t.cols[0][i] + k * T);
      w.drive.push_back(t.cols[1][i] / 100.0);
      w.response.push_back(t.cols[3][i]);
    }
  return w;
}

/// A ratio passes within kRel, or when its numerator (ratio × denominator) agrees
/// within the floor kFloor·|G*_1| (ratios with a tiny denominator, e.g. tan δ when
/// G'_1 ≈ 0, whose published reference values are rounded to 2-3 digits).
void check_ratio(const char* what, double got, double got_num, double ref, double ref_num,
                 double G1, double rel = kRel) {
  INFO(what << ": got " << got << ", reference " << ref);
  const bool ok = std::abs(got - ref) <= rel * std::abs(ref) ||
                  std::abs(got_num - ref_num) <= kFloor * G1;
  CHECK(ok);
}

AmplitudeResult run(const std::string& rel, bool rheojax, bool last_only, const Ref& r,
                    bool split = true, double x0_ref = 0, double v3_rel = kRel) {
  const Waveform w = load(rel, rheojax);
  AnalysisOptions o;
  o.max_harmonic = 15;
  o.all_cycles = true;
  o.split_amplitudes = split;
  o.force_one_amplitude = !split;  // the reference estimators take the record as one
  auto A = analyse_record(w, o, rel).amplitudes.at(0);
  if (last_only) {
    o.all_cycles = false;
    o.cycles = {static_cast<int>(A.cycles.size())};
    A = analyse_record(w, o, rel).amplitudes.at(0);
  }
  if (!(x0_ref > 0)) x0_ref = A.x0;
  // Moduli scale as 1/x0: refer them to the reference's amplitude (matters only for
  // a record whose amplitude is ambiguous, see SlugSlime).
  Measures m = A.measures;
  const double k = A.x0 / x0_ref;
  m.K1p *= k, m.K1pp *= k, m.e[3] *= k;
  const double G1 = std::hypot(r.Gp, r.Gpp);
  // LAOS_TEST_PRINT=1 prints the measured values (used to fill in the regressions).
  if (std::getenv("LAOS_TEST_PRINT"))
    std::cout << std::setprecision(10) << rel << ": cycles " << A.fit.samples << " samples, M " << A.M << ", used "
            << std::count_if(A.cycles.begin(), A.cycles.end(), [](auto& c) { return c.used; })
            << " of " << A.cycles.size() << ", x0 " << A.x0 << ", omega " << A.omega << "\n  G'1 "
            << m.K1p << " G''1 " << m.K1pp << " tan " << m.tan_delta << " I3/I1 " << m.I3_over_I1
            << " e3/e1 " << m.e3_over_e1 << " v3/v1 " << m.v3_over_v1 << " E_d " << A.E_d
            << "\n  G'M " << m.K_M << " eta'M " << m.eta_M << " S " << m.S << " T " << m.T
            << " I2/I1 " << m.I2_over_I1 << " phi_d " << A.phi_d << "\n"
            << "  rel: G'1 " << m.K1p / r.Gp - 1 << " G''1 " << m.K1pp / r.Gpp - 1 << " tan "
            << m.tan_delta / r.tan_delta - 1 << " I3 " << m.I3_over_I1 / r.I3 - 1 << " e3/e1 "
            << m.e3_over_e1 / r.e3e1 - 1 << " v3/v1 " << m.v3_over_v1 / r.v3v1 - 1 << " E_d "
            << A.E_d / r.E_d - 1 << "\n";
  const double Ed_scale = 1.0 / (std::acos(-1.0) * A.x0 * A.x0);  // E_d -> K'' units
  const double K1 = std::hypot(m.K1p, m.K1pp);
  check_ratio("G'1", m.K1p, m.K1p, r.Gp, r.Gp, G1);
  check_ratio("G''1", m.K1pp, m.K1pp, r.Gpp, r.Gpp, G1);
  check_ratio("tan delta", m.tan_delta, m.K1pp, r.tan_delta, r.Gpp, G1);
  check_ratio("I3/I1", m.I3_over_I1, m.I3_over_I1 * K1, r.I3, r.I3 * G1, G1);
  check_ratio("e3/e1", m.e3_over_e1, m.e[3], r.e3e1, r.e3e1 * r.Gp, G1);
  check_ratio("v3/v1", m.v3_over_v1, A.fit.Kpp[3] * k, r.v3v1, r.v3v1 * r.Gpp, G1, v3_rel);
  check_ratio("E_d", A.E_d, A.E_d * Ed_scale, r.E_d, r.E_d * Ed_scale, G1);
  return A;
}

void regression(const AmplitudeResult& A, double KM, double etaM, double S, double T) {
  CHECK(A.measures.K_M == Approx(KM).epsilon(kRegression));
  CHECK(A.measures.eta_M == Approx(etaM).epsilon(kRegression));
  CHECK(A.measures.S == Approx(S).epsilon(kRegression));
  CHECK(A.measures.T == Approx(T).epsilon(kRegression));
}
}  // namespace

TEST_CASE("external: RepTate CPyCL (measured, non-uniform dt)", "[laos][external]") {
  const auto A = run("reptate/CPyCL-omega00p30-gam03p1600.laos", false, false,
                     {0.6375, 3.975, 6.235, 0.03246, 0.1822, -0.01506, 123.6});
  regression(A, 0.3601421837, 7.795254003, 0.4845886949, 0.4020542924);
}

TEST_CASE("external: RepTate SlugSlime (angle and torque)", "[laos][external]") {
  // The drive steps through four amplitudes (0.274, 0.301, 0.343, 0.384 rad; about 6
  // cycles each): split by default, one record for the reference estimator.
  const auto r =
      analyse_record(load("reptate/SlugSlime-omega03p00-Run31.laos", false), {}, "SlugSlime");
  REQUIRE(r.amplitudes.size() == 4);
  CHECK(r.amplitudes[0].x0 == Approx(0.2742).epsilon(1e-3));
  CHECK(r.amplitudes[3].x0 == Approx(0.3838).epsilon(1e-3));
  const auto A = run("reptate/SlugSlime-omega03p00-Run31.laos", false, false,
                     {1.316e-4, 2.02e-5, 0.1535, 0.2028, 0.2019, -0.2362, 6.607e-6}, false,
                     0.3202, kSlugV3);
  // With four amplitudes in one record "the" amplitude is a matter of definition: the
  // sine fit over the used cycles gives 0.3202 rad, as C's strain fundamental (the fit
  // over the whole record gave 0.3229). The torque coefficients x0 K are compared
  // (run() rescales), ratios and E_d need no rescaling.
  CHECK(A.x0 == Approx(0.3202).epsilon(1e-3));
  regression(A, 7.244093377e-05, 1.213173855e-05, 0.5572140457, -1.312987985);
  (void)A;
}

TEST_CASE("external: RepTate Giesekus, last cycle", "[laos][external]") {
  const auto A = run("reptate/GiesekusSimulation-omega01p00-gam05p000.laos", false, true,
                     {0.007761, 0.08911, 11.48, 0.03229, 0.2037, -0.02713, 6.961});
  regression(A, 0.003861011905, 0.09657730941, 0.5950369817, -0.1132914464);
}

TEST_CASE("external: rheojax raw signals (one cycle, tiled)", "[laos][external]") {
  regression(
      run("rheojax/raw_signal_0010.txt", true, false, {82.68, 170.3, 2.06, 0.1621, 0.1201, 0.1705, 5.339}),
      26.18300608, 31.02377973, 0.707006956, 0.5159854352);
  regression(
      run("rheojax/raw_signal_0100.txt", true, false, {1.496, 22.5, 15.03, 0.287, 3.061, -0.2032, 70.57}),
      -1.219146, 6.947483075, 1.142187064, -0.2032725347);
  regression(run("rheojax/raw_signal_1000.txt", true, false,
                 {-7.50e-4, 5.106, -6.8e3, 0.1299, -155, -0.1279, 1601}),
             0.05901200209, 2.377444048, 0.9393847497, -0.5920369021);
}
