// Closed-form LAOS cases (the table of docs/laos.md, "Accuracy") through the whole
// stage: sine fit (or arcsin phase), cycles, weighted least squares, derived measures.
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "laos/laos_test_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/laos/analysis.hpp"

using namespace shearzone;
using namespace shearzone::laos;
using testutil::kPi;

namespace {
/// Models inside the fitted basis: everything exact up to round-off of the sine fit
/// and the QR solve (1e-9 relative, the bound in docs/laos.md, "Accuracy").
constexpr double kExact = 1e-9;
/// Maxwell after the transient has decayed below 1e-10 of the signal (bound 1e-8).
constexpr double kMaxwell = 1e-8;
/// Coulomb and elastic-plastic loops at 1e5 samples per cycle (bound <= 1e-4).
constexpr double kLoop = 1e-4;

bool rel_close(double a, double b, double tol) { return std::abs(a - b) <= tol * std::abs(b); }

AmplitudeResult one(const Waveform& w, AnalysisOptions o = {}) {
  const RecordResult r = analyse_record(w, o, "synthetic");
  REQUIRE(r.amplitudes.size() == 1);
  return r.amplitudes[0];
}
}  // namespace

TEST_CASE("Hookean, Newtonian and Kelvin-Voigt are exact", "[laos]") {
  const double x0 = 0.3, omega = 2.0, G = 100.0, eta = 10.0;
  const int N = 1000;
  struct Case {
    double G, eta;
  };
  for (const Case c : {Case{G, 0.0}, Case{0.0, eta}, Case{G, eta}}) {
    const auto w = testutil::timed(x0, omega, N, 4, [&](double th, double) {
      return c.G * x0 * std::sin(th) + c.eta * x0 * omega * std::cos(th);
    });
    const auto A = one(w);
    const auto& m = A.measures;
    INFO("G = " << c.G << ", eta = " << c.eta);
    CHECK(std::string(amplitude_status_name(A.status)) == "ok");
    CHECK(A.M == 9);
    CHECK(rel_close(A.omega, omega, kExact));
    CHECK(rel_close(A.x0, x0, kExact));
    const double scale = std::hypot(c.G, c.eta * omega);
    CHECK(std::abs(m.K1p - c.G) <= kExact * scale);
    CHECK(std::abs(m.K1pp - c.eta * omega) <= kExact * scale);
    testutil::note(c.G > 0 ? (c.eta > 0 ? "Kelvin-Voigt K'1,K''1 abs err / |K*|" : "Hookean K'1,K''1 abs err / |K*|") : "Newtonian K'1,K''1 abs err / |K*|",
                   std::max(std::abs(m.K1p - c.G), std::abs(m.K1pp - c.eta * omega)) / scale);
    for (int n = 2; n <= A.M; ++n) CHECK(m.I_over_I1[n] <= kExact);
    CHECK(std::abs(m.K_M - c.G) <= kExact * scale);
    CHECK(std::abs(m.K_L - c.G) <= kExact * scale);
    CHECK(std::abs(m.eta_M - c.eta) <= kExact * scale / omega);
    CHECK(std::abs(m.eta_L - c.eta) <= kExact * scale / omega);
    if (c.G > 0) CHECK(std::abs(m.S) <= kExact);
    if (c.eta > 0) {
      CHECK(std::abs(m.T) <= kExact);
      if (c.G > 0) CHECK(rel_close(m.tan_delta, c.eta * omega / c.G, kExact));
      // Trapezoid loop area of an ellipse sampled at step h in θ is exactly
      // π x0² K'' sin(h)/h (the elastic part telescopes to zero).
      const double h = 2 * kPi / N;
      CHECK(rel_close(A.E_d, kPi * x0 * x0 * c.eta * omega * std::sin(h) / h, kExact));
      CHECK(rel_close(A.E_d_ratio, std::sin(h) / h, kExact));
    } else {
      CHECK(std::abs(A.E_d) <= kExact * scale * x0 * x0);
    }
  }
}

TEST_CASE("cubic elastic: e3 = G3 x0^2/4, S = 1/3, I3/I1 = 1/11, Phi3 = pi", "[laos]") {
  const double G1 = 100, G3 = 50, x0 = 1, omega = 2;
  const auto A = one(testutil::timed(x0, omega, 512, 3, [&](double th, double) {
    const double x = x0 * std::sin(th);
    return G1 * x + G3 * x * x * x;
  }));
  const auto& m = A.measures;
  CHECK(rel_close(m.e[1], 137.5, kExact));
  CHECK(rel_close(m.e[3], 12.5, kExact));
  CHECK(rel_close(A.fit.Kp[3], -12.5, kExact));
  CHECK(rel_close(m.K_M, 100, kExact));
  CHECK(rel_close(m.K_L, 150, kExact));
  CHECK(rel_close(m.S, 1.0 / 3.0, kExact));
  CHECK(rel_close(m.I3_over_I1, 12.5 / 137.5, kExact));
  CHECK(rel_close(m.e3_over_e1, 12.5 / 137.5, kExact));
  CHECK(rel_close(m.Phi[3], kPi, kExact));
  testutil::note("cubic elastic worst rel err (e1, e3, K_M, K_L, S, I3/I1)",
                 std::max({testutil::rel_err(m.e[1], 137.5), testutil::rel_err(m.e[3], 12.5),
                           testutil::rel_err(m.K_M, 100), testutil::rel_err(m.K_L, 150),
                           testutil::rel_err(m.S, 1.0 / 3), testutil::rel_err(m.I3_over_I1, 1.0 / 11)}));
  CHECK(std::abs(m.K1pp) <= kExact * 137.5);
}

TEST_CASE("cubic viscous: v1 = 16, v3 = 2, eta_M = 10, eta_L = 18, T = 4/9", "[laos]") {
  const double e1 = 10, e3 = 2, x0 = 1, omega = 2;
  const auto A = one(testutil::timed(x0, omega, 512, 3, [&](double th, double) {
    const double rate = x0 * omega * std::cos(th);
    return e1 * rate + e3 * rate * rate * rate;
  }));
  const auto& m = A.measures;
  CHECK(rel_close(m.v[1], 16, kExact));
  CHECK(rel_close(m.v[3], 2, kExact));
  CHECK(rel_close(m.v3_over_v1, 2.0 / 16.0, kExact));
  CHECK(rel_close(m.eta_M, 10, kExact));
  CHECK(rel_close(m.eta_L, 18, kExact));
  CHECK(rel_close(m.T, 4.0 / 9.0, kExact));
  testutil::note("cubic viscous worst rel err (v1, v3, eta_M, eta_L, T)",
                 std::max({testutil::rel_err(m.v[1], 16), testutil::rel_err(m.v[3], 2),
                           testutil::rel_err(m.eta_M, 10), testutil::rel_err(m.eta_L, 18),
                           testutil::rel_err(m.T, 4.0 / 9)}));
}

TEST_CASE("delta-phi-uniform sampling without time (the logger) is exact", "[laos]") {
  const double x0 = 0.05, dx = 1e-3, omega = 2;
  const auto w = testutil::angle_sampled(x0, dx, 3, [&](double th) {
    const double x = x0 * std::sin(th);
    return 100 * x + 5e4 * x * x * x + 20 * x0 * omega * std::cos(th);
  });
  AnalysisOptions o;
  o.omega_rad_per_s = omega;
  o.max_harmonic = 20;
  const auto A = one(w, o);
  CHECK(A.phase_method == "arcsin");
  CHECK(A.M_cap == 15);  // floor(π/√(2Δφ/φ0)) = floor(π/0.2)
  CHECK(A.M == 15);
  CHECK(A.cycles.size() == 3);
  CHECK(A.fit.samples == 3 * 200 + 1);  // 4 φ0/Δφ per cycle
  CHECK(rel_close(A.fit.Kp[1], 193.75, kExact));
  CHECK(rel_close(A.fit.Kp[3], -31.25, kExact));
  CHECK(rel_close(A.fit.Kpp[1], 40, kExact));
  for (int n = 2; n <= A.M; ++n)
    if (n != 3) CHECK(std::hypot(A.fit.Kp[n], A.fit.Kpp[n]) <= kExact * 193.75);
  CHECK(rel_close(A.measures.eta_L, 20, kExact));
  testutil::note("delta-phi sampling worst rel err (K'1, K'3, K''1)",
                 std::max({testutil::rel_err(A.fit.Kp[1], 193.75), testutil::rel_err(A.fit.Kp[3], -31.25),
                           testutil::rel_err(A.fit.Kpp[1], 40)}));
}

TEST_CASE("sign-flipped strain gives the same moduli", "[laos]") {
  const double x0 = 0.1, omega = 3.16, G = 7, eta = 2;
  // x = −x0 sin ωt: the sine fit finds ψ = π, so θ = ωt + π and x = x0 sin θ.
  const auto w = testutil::timed(
      x0, omega, 1024, 3,
      [&](double th, double) { return -(G * x0 * std::sin(th) + eta * x0 * omega * std::cos(th)); },
      -1.0);
  const auto A = one(w);
  CHECK(rel_close(A.measures.K1p, G, kExact));
  CHECK(rel_close(A.measures.K1pp, eta * omega, kExact));
  CHECK(rel_close(A.x0, x0, kExact));
  testutil::note("sign-flipped worst rel err", std::max(testutil::rel_err(A.measures.K1p, G),
                                                        testutil::rel_err(A.measures.K1pp, eta * omega)));
}

TEST_CASE("linear torque drift: the drift column removes the -2c/(n omega x0) bias", "[laos]") {
  const double x0 = 1, omega = 2, G = 100, eta = 5, c = 0.5;
  const auto w = testutil::timed(x0, omega, 1000, 4, [&](double th, double t) {
    return G * x0 * std::sin(th) + eta * x0 * omega * std::cos(th) + c * t;
  });
  const auto A = one(w);
  CHECK(rel_close(A.measures.K1p, G, kExact));
  CHECK(rel_close(A.measures.K1pp, eta * omega, kExact));
  CHECK(std::abs(A.fit.Kp[3]) <= kExact * G);
  // Drift per cycle: c T.
  CHECK(rel_close(A.fit.drift_per_cycle, c * 2 * kPi / omega, kExact));
  testutil::note("drift with column worst rel err", std::max(testutil::rel_err(A.measures.K1p, G),
                                                             testutil::rel_err(A.measures.K1pp, eta * omega)));
  // Without the column the in-phase terms are biased by −2c/(n ω x0) (the cos terms are
  // not); the discrete sawtooth projection matches it to O(h²).
  constexpr double kBiasTol = 1e-4;
  AnalysisOptions o;
  o.drift = false;
  o.all_cycles = true;
  const auto B = one(w, o);
  CHECK(std::abs(B.measures.K1p - (G - 2 * c / (omega * x0))) <= kBiasTol * G);
  CHECK(std::abs(B.fit.Kp[3] - (-2 * c / (3 * omega * x0))) <= kBiasTol * G);
  CHECK(rel_close(B.measures.K1pp, eta * omega, kExact));
}

TEST_CASE("an added even harmonic is reported and leaves the odd measures alone", "[laos]") {
  const double x0 = 0.5, omega = 1.5, G1 = 40, G3 = 8, eta = 3, a2 = 4, b2 = -2;
  auto model = [&](double th, bool even) {
    const double x = x0 * std::sin(th);
    double r = G1 * x + G3 * x * x * x + eta * x0 * omega * std::cos(th);
    if (even) r += x0 * (a2 * std::sin(2 * th) + b2 * std::cos(2 * th));
    return r;
  };
  const auto A = one(testutil::timed(x0, omega, 600, 3, [&](double th, double) { return model(th, true); }));
  const auto B = one(testutil::timed(x0, omega, 600, 3, [&](double th, double) { return model(th, false); }));
  const double K1 = std::hypot(A.measures.K1p, A.measures.K1pp);
  CHECK(rel_close(A.measures.I2_over_I1, std::hypot(a2, b2) / K1, kExact));
  CHECK(rel_close(A.fit.Kp[2], a2, kExact));
  CHECK(rel_close(A.fit.Kpp[2], b2, kExact));
  testutil::note("even harmonic rel err (I2/I1)", testutil::rel_err(A.measures.I2_over_I1, std::hypot(a2, b2) / K1));
  CHECK(B.measures.I2_over_I1 <= kExact);
  for (auto [a, b] : {std::pair{A.measures.K_M, B.measures.K_M}, {A.measures.K_L, B.measures.K_L},
                      {A.measures.eta_M, B.measures.eta_M}, {A.measures.eta_L, B.measures.eta_L},
                      {A.measures.S, B.measures.S}, {A.measures.T, B.measures.T},
                      {A.measures.e3_over_e1, B.measures.e3_over_e1}}) {
    INFO(a << " vs " << b);
    CHECK(std::abs(a - b) <= kExact * std::max(1.0, std::abs(b)));  // T = 0 here
  }
}

TEST_CASE("Maxwell from rest: steady cycles recover G' and G'', the transient biases", "[laos]") {
  const double G = 5, lambda = 0.7, omega = 2, x0 = 0.2;
  const double wl = omega * lambda;
  const double Gp = G * wl * wl / (1 + wl * wl), Gpp = G * wl / (1 + wl * wl);
  REQUIRE(rel_close(Gp, 3.31081, 1e-5));
  REQUIRE(rel_close(Gpp, 2.36486, 1e-5));
  const auto w = testutil::timed(x0, omega, 1000, 10, [&](double th, double t) {
    return x0 * (Gp * std::sin(th) + Gpp * std::cos(th)) - x0 * Gpp * std::exp(-t / lambda);
  });
  // Discard cycles until e^(−t/λ) < 1e-10: t > λ ln 1e10 = 16.1 s; cycle k starts at
  // (k − 1)π, so cycles 7..10.
  AnalysisOptions o;
  o.cycles = {7, 8, 9, 10};
  REQUIRE(std::exp(-6 * kPi / lambda) < 1e-10);
  const auto A = one(w, o);
  CHECK(rel_close(A.measures.K1p, Gp, kMaxwell));
  CHECK(rel_close(A.measures.K1pp, Gpp, kMaxwell));
  testutil::note("Maxwell cycles 7-10 worst rel err", std::max(testutil::rel_err(A.measures.K1p, Gp),
                                                               testutil::rel_err(A.measures.K1pp, Gpp)));
  // Default: the steady-state rule drops the start-up cycles.
  const auto D = one(w);
  CHECK(std::string(amplitude_status_name(D.status)) == "ok");
  CHECK(D.first_steady_cycle > 1);
  CHECK_FALSE(D.cycles[0].steady);
  CHECK(rel_close(D.measures.K1pp, Gpp, 0.02));
  // Analysing from t = 0 shows the bias.
  AnalysisOptions all;
  all.all_cycles = true;
  const auto B = one(w, all);
  CHECK(std::abs(B.measures.K1p - Gp) > 1e-3 * Gp);
}

namespace {
/// Coulomb square wave r = σ_y sgn(cos θ) sampled so that the jumps fall midway
/// between samples (N = 4m + 2); returns the worst relative error of I_n/I_1 = 1/n (n = 3, 5, 7, 9) and
/// K''_1 = 4σ_y/(π x0).
struct CoulombErr {
  double In = 0, K1 = 0, phi_d = 0;
};
CoulombErr coulomb(int per_cycle) {
  const double x0 = 0.4, omega = 2, sy = 3;
  const auto w = testutil::timed(x0, omega, per_cycle, 2, [&](double th, double) {
    return std::cos(th) >= 0 ? sy : -sy;
  });
  AnalysisOptions o;
  o.all_cycles = true;
  const auto A = one(w, o);
  CoulombErr e;
  for (int n = 3; n <= 9; n += 2) e.In = std::max(e.In, std::abs(A.measures.I_over_I1[n] * n - 1));
  e.K1 = std::abs(A.measures.K1pp / (4 * sy / (kPi * x0)) - 1);
  e.phi_d = std::abs(A.phi_d - 1);
  return e;
}
}  // namespace

TEST_CASE("Coulomb square wave: I_n/I_1 = 1/n, phi_d = 1, second-order convergence", "[laos]") {
  // 1e5 + 2 samples per cycle (not a multiple of 4: the jumps fall between samples).
  const auto e5 = coulomb(100002);
  CHECK(e5.In <= kLoop);
  CHECK(e5.K1 <= kLoop);
  CHECK(e5.phi_d <= kLoop);
  // A jump midway between samples is integrated to O(h²) by the linear interpolant
  // (the two half-gap errors cancel to first order): 10x more samples, ~100x less error.
  const auto e3 = coulomb(1002), e4 = coulomb(10002);
  INFO("errors " << e3.In << " " << e4.In << " " << e5.In);
  testutil::note("Coulomb In*n-1 worst at 1e3/1e4/1e5 per cycle", e3.In);
  testutil::note("  1e4", e4.In);
  testutil::note("  1e5", e5.In);
  testutil::note("  1e5 K''1, phi_d", std::max(e5.K1, e5.phi_d));
  CHECK(e3.In / e4.In > 50);
  CHECK(e4.In / e5.In > 50);
}

namespace {
struct EppErr {
  double K1p = 0, K1pp = 0, E_d = 0, phi_d = 0;
};
EppErr elastic_plastic(int per_cycle, bool drift) {
  const double G = 10, sy = 3, x0 = 1, omega = 2;
  const double r = sy / G / x0, ts = std::asin(2 * r - 1);
  const double Gp = G / kPi * (kPi / 2 + ts + std::sin(ts) * std::cos(ts));
  const double Gpp = 4 * G / kPi * r * (1 - r);
  REQUIRE(rel_close(Gp, 2.52316, 1e-5));
  REQUIRE(rel_close(Gpp, 2.67380, 1e-5));
  // Steady parallelogram: loading branch (θ in [−π/2, π/2] mod 2π) min(σy, −σy + G(x + x0)),
  // unloading branch max(−σy, σy − G(x0 − x)).
  const auto w = testutil::timed(x0, omega, per_cycle, 2, [&](double th, double) {
    const double x = x0 * std::sin(th);
    return std::cos(th) >= 0 ? std::min(sy, -sy + G * (x + x0)) : std::max(-sy, sy - G * (x0 - x));
  });
  AnalysisOptions o;
  o.all_cycles = true;
  o.drift = drift;
  const auto A = one(w, o);
  return {std::abs(A.measures.K1p / Gp - 1), std::abs(A.measures.K1pp / Gpp - 1),
          std::abs(A.E_d / 8.4 - 1), std::abs(A.phi_d / 0.7 - 1)};
}
}  // namespace

TEST_CASE("elastic-perfectly-plastic parallelogram: G'_1, G''_1, E_d = 4 sy (x0 - xy), phi_d = 1 - r",
          "[laos]") {
  const auto e5 = elastic_plastic(100002, false);
  CHECK(e5.K1p <= kLoop);
  CHECK(e5.K1pp <= kLoop);
  CHECK(e5.E_d <= kLoop);
  CHECK(e5.phi_d <= kLoop);
  // With the drift column the truncated series (M = 9) leaks into it: the sawtooth θ
  // is not orthogonal to the sin nθ terms above M, a 4e-4 bias on K'_1 (K''_1, E_d
  // and φ_d are unaffected: the parallelogram's cos terms are orthogonal to it).
  constexpr double kDriftLeak = 1e-3;
  const auto d5 = elastic_plastic(100002, true);
  CHECK(d5.K1p <= kDriftLeak);
  CHECK(d5.K1pp <= kLoop);
  CHECK(d5.E_d <= kLoop);
  // The kinks are integrated to O(h²): 10x more samples, ~100x less loop-area error.
  const auto e3 = elastic_plastic(1002, false), e4 = elastic_plastic(10002, false);
  INFO("E_d errors " << e3.E_d << " " << e4.E_d);
  testutil::note("EPP 1e5 worst (K'1, K''1, E_d, phi_d), no drift column",
                 std::max({e5.K1p, e5.K1pp, e5.E_d, e5.phi_d}));
  testutil::note("EPP 1e5 K'1 with drift column", d5.K1p);
  testutil::note("EPP E_d err 1e3/1e4", e3.E_d);
  testutil::note("  1e4", e4.E_d);
  CHECK(e3.E_d / e4.E_d > 50);
}
