// LAOS analysis of one record: amplitudes, phase, cycles, steady state, measures.
#include "shearzone/laos/analysis.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/check.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/stats.hpp"

namespace shearzone::laos {

namespace {

/// τ_max of a cycle: the smaller of the largest |r| sample and the largest |offset +
/// odd harmonics| of the cycle's harmonic fit (64 points per period of the highest
/// harmonic). A smooth response keeps its sampled maximum (the reconstruction is at
/// least as high); a plateau (a yield torque) keeps it too (the reconstruction overshoots
/// a square wave by Gibbs' 9 %); a single impulsive sample (a contact in a simulated
/// torque log) is left out, up to its leakage into the harmonics, (odd n <= M) x 2/N of
/// its size for N samples per cycle.
double robust_max(double sampled_max, const HarmonicFit& f) {
  const int n = 64 * std::max(1, f.M);
  double m = 0;
  for (int k = 0; k < n; ++k) {
    const double th = 2.0 * std::numbers::pi * k / n;
    m = std::max(m, std::abs(f.offset + f.odd_sin_part(th) + f.odd_cos_part(th)));
  }
  return std::min(sampled_max, m);
}

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2.0 * kPi;
/// Slack on cycle boundaries in θ: a record that starts (or ends) on an upward
/// crossing, up to the round-off of the fitted phase, still has that cycle complete.
/// It is this fraction of the median sample step in θ (at least 1e-9 rad), so the
/// quadrature misses at most 1e-4 of a step (1e-6 of a cycle at 100 samples per
/// cycle): a sine fit's phase error (~1e-8 rad) no longer decides whether a record
/// that starts exactly at φ = 0 keeps its first cycle.
constexpr double kThetaSlackSteps = 1e-4;
constexpr double kThetaSlackMin = 1e-9;
/// Schmitt-trigger hysteresis for raw crossings, fraction of the record's half range.
constexpr double kHysteresis = 0.02;

std::string lines_text(const Waveform& w, std::size_t i0, std::size_t i1) {
  if (w.line.size() == w.drive.size() && !w.line.empty())
    return fmt::format("lines {}-{}", w.line[i0], w.line[i1]);
  return fmt::format("samples {}-{}", i0 + 1, i1 + 1);
}

/// Upward crossings of x through `level` with hysteresis h: index of the first sample
/// at or above the level.
std::vector<std::size_t> upward_crossings(const std::vector<double>& x, double level, double h) {
  std::vector<std::size_t> out;
  bool high = !x.empty() && x[0] >= level;
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::size_t cand = kNone;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (high) {
      if (x[i] < level - h) high = false, cand = kNone;
      continue;
    }
    if (x[i] < level) {
      cand = kNone;
    } else if (cand == kNone) {
      cand = i;
    }
    if (x[i] > level + h && cand != kNone) {
      if (cand > 0) out.push_back(cand);
      high = true;
      cand = kNone;
    }
  }
  return out;
}

/// Value of y at θ = a by linear interpolation on the (non-decreasing) θ samples.
double interp_at(const std::vector<double>& theta, const std::vector<double>& y, double a) {
  auto it = std::lower_bound(theta.begin(), theta.end(), a);
  if (it == theta.begin()) return y.front();
  if (it == theta.end()) return y.back();
  const auto j = static_cast<std::size_t>(it - theta.begin());
  const double t0 = theta[j - 1], t1 = theta[j];
  if (!(t1 > t0)) return y[j];
  const double s = (a - t0) / (t1 - t0);
  return y[j - 1] * (1 - s) + y[j] * s;
}

}  // namespace

void AnalysisOptions::validate() const {
  if (max_harmonic < 1 || max_harmonic > 200)
    throw ConfigError(fmt::format("laos: harmonics M = {}; expected 1..200", max_harmonic));
  if (!(amplitude_change > 0) || amplitude_change >= 1)
    throw ConfigError(fmt::format("laos: amplitude change {}; expected in (0, 1)", amplitude_change));
  if (!(steady_tolerance > 0))
    throw ConfigError(fmt::format("laos: steady tolerance {}; expected > 0", steady_tolerance));
  if (!std::isnan(omega_rad_per_s) && !(omega_rad_per_s > 0 && std::isfinite(omega_rad_per_s)))
    throw ConfigError(fmt::format("laos: omega {} rad/s; expected > 0", omega_rad_per_s));
  if (!std::isfinite(inertia) || inertia < 0)
    throw ConfigError(fmt::format("laos: inertia {}; expected >= 0", inertia));
  for (int c : cycles)
    if (c < 1) throw ConfigError(fmt::format("laos: cycle {}; expected cycle numbers >= 1", c));
  if (!(max_drive_misfit > 0))
    throw ConfigError(fmt::format("laos: drive misfit limit {}; expected > 0", max_drive_misfit));
  if (!(max_amplitude_spread > 0))
    throw ConfigError(fmt::format("laos: amplitude spread limit {}; expected > 0", max_amplitude_spread));
}

int harmonic_cap(const std::vector<double>& drive, double x0, bool timed, double samples_per_cycle) {
  if (timed) return static_cast<int>(std::floor((samples_per_cycle - 1.0) / 2.0));
  std::vector<double> steps;
  for (std::size_t i = 1; i < drive.size(); ++i) {
    const double d = std::abs(drive[i] - drive[i - 1]);
    if (d > 0) steps.push_back(d);
  }
  const double dx = core::upper_median_inplace(steps);  // NaN (no step): cap 0
  if (!(dx > 0)) return 0;
  // Largest phase gap near the turning points is √(2Δx/x0) (θ = arcsin(x/x0) there);
  // the sampling resolves harmonics up to π/gap. A small tolerance keeps exact ratios
  // (π/0.2) from flooring one below.
  return static_cast<int>(std::floor(kPi / std::sqrt(2.0 * dx / x0) * (1 + 1e-12)));
}

std::vector<double> phase_from_drive(const std::vector<double>& x, double c, double x0) {
  const std::size_t n = x.size();
  std::vector<double> th(n);
  bool rising = true;
  // Initial direction: first non-zero step.
  for (std::size_t i = 1; i < n; ++i)
    if (x[i] != x[i - 1]) {
      rising = x[i] > x[i - 1];
      break;
    }
  for (std::size_t i = 0; i < n; ++i) {
    const double d = (i + 1 < n ? x[i + 1] : x[i]) - (i > 0 ? x[i - 1] : x[i]);
    if (d > 0) rising = true;
    if (d < 0) rising = false;
    const double u = std::clamp((x[i] - c) / x0, -1.0, 1.0);
    const double base = rising ? std::asin(u) : kPi - std::asin(u);
    th[i] = i == 0 ? base : base + kTwoPi * std::round((th[i - 1] - base) / kTwoPi);
  }
  return th;
}

namespace {

/// NoResultError when the first harmonic is not resolved by the data: |K*_1| below
/// kMinResolved standard errors (noise alone gives |K*_1|/SE with the χ²₂ law of
/// a two-component estimate: P(> 5) = exp(−12.5) ≈ 4e-6; real logs give thousands).
void check_fit_meaningful(const AmplitudeResult& A, const std::string& where) {
  constexpr double kMinResolved = 5.0;
  const double K1 = std::hypot(A.fit.Kp[1], A.fit.Kpp[1]);
  const double se = std::max(A.fit.Kp_se[1], A.fit.Kpp_se[1]);
  if (!(K1 >= kMinResolved * se))
    throw NoResultError(fmt::format("{}: the harmonic fit is meaningless: |K*_1| = {:.3g} is {:.3g} "
                                    "standard errors; expected at least {:g} (a response that "
                                    "follows the drive)",
                                    where, K1, K1 / se, kMinResolved));
}

/// Analyses samples [i0, i1] of the record. Returns nullopt (and the θ span) when
/// there is no complete cycle.
std::optional<AmplitudeResult> analyse_block(const Waveform& w, const std::string& context,
                                             std::size_t i0, std::size_t i1,
                                             const AnalysisOptions& o, double& theta_span,
                                             const SineFit* given = nullptr) {
  AmplitudeResult A;
  A.first_sample = i0;
  A.last_sample = i1;
  if (w.line.size() == w.drive.size() && !w.line.empty()) {
    A.first_line = w.line[i0];
    A.last_line = w.line[i1];
  }
  const std::string where = fmt::format("{}: {}", context, lines_text(w, i0, i1));
  const auto first = static_cast<std::ptrdiff_t>(i0), last = static_cast<std::ptrdiff_t>(i1) + 1;
  std::vector<double> x(w.drive.begin() + first, w.drive.begin() + last);
  std::vector<double> r(w.response.begin() + first, w.response.begin() + last);
  std::vector<double> t;
  A.timed = !w.time_s.empty();
  if (A.timed) t.assign(w.time_s.begin() + first, w.time_s.begin() + last);
  const std::size_t n = x.size();
  const auto [mn, mx] = std::minmax_element(x.begin(), x.end());
  const double half = 0.5 * (*mx - *mn);
  if (!(half > 1e-12 * std::max(std::abs(*mx), std::abs(*mn))) || !(half > 0))
    throw InputError(fmt::format("{}: drive amplitude is zero (all drive values {}); expected an "
                                 "oscillating drive",
                                 where, *mx));
  std::vector<double> theta;
  if (A.timed) {
    const SineFit sf = given != nullptr ? *given : fit_sine(t, x, o.omega_rad_per_s, where, o.drift);
    if (!(sf.rms <= o.max_drive_misfit * sf.x0))
      throw NoResultError(fmt::format(
          "{}: the drive is not a steady oscillation: its sine fit misses by {:.3g} % of the "
          "amplitude (rms); expected below {:.3g} % (a ramp, a rotation or a changing frequency "
          "has no moduli)",
          where, 100 * sf.rms / sf.x0, 100 * o.max_drive_misfit));
    A.phase_method = "sine_fit";
    A.omega = sf.omega;
    A.x0 = sf.x0;
    A.x_offset = sf.offset;
    A.psi = sf.psi;
    theta.resize(n);
    for (std::size_t i = 0; i < n; ++i) theta[i] = sf.omega * t[i] + sf.psi;
  } else {
    A.phase_method = "arcsin";
    A.omega = o.omega_rad_per_s;
    A.x0 = half;
    A.x_offset = 0.5 * (*mx + *mn);
    theta = phase_from_drive(x, A.x_offset, A.x0);
  }
  // Energies and ratios divide by x0^2: an amplitude far below any instrument's
  // resolution (~1e-7 rad) would give non-finite numbers, never a measurement.
  constexpr double kMinDriveAmplitude = 1e-12;
  if (!(A.x0 > kMinDriveAmplitude) || !std::isfinite(A.x0))
    throw InputError(fmt::format("{}: drive amplitude {:.3g} (SI units): expected more than {:.0e}, far "
                                 "above which rheometers resolve",
                                 where, A.x0, kMinDriveAmplitude));
  if (o.inertia > 0) {
    if (std::isnan(A.omega))
      throw ConfigError(fmt::format("{}: inertia subtraction needs ω; give --f-hz or a log with "
                                    "time or omega",
                                    where));
    for (std::size_t i = 0; i < n; ++i)
      r[i] += o.inertia * A.x0 * A.omega * A.omega * std::sin(theta[i]);
  }
  // Cycles [2πk, 2π(k+1)] fully inside the record.
  double kThetaSlack = kThetaSlackMin;
  if (n >= 3) {
    std::vector<double> steps(n - 1);
    for (std::size_t i = 0; i + 1 < n; ++i) steps[i] = std::abs(theta[i + 1] - theta[i]);
    kThetaSlack = std::max(kThetaSlackMin, kThetaSlackSteps * core::upper_median_inplace(steps));
  }
  const double th0 = theta.front(), th1 = theta.back();
  theta_span = th1 - th0;
  const auto kmin = static_cast<long>(std::ceil((th0 - kThetaSlack) / kTwoPi));
  const auto kend = static_cast<long>(std::floor((th1 + kThetaSlack) / kTwoPi));  // exclusive
  if (kend <= kmin) return std::nullopt;
  const int ncyc = static_cast<int>(kend - kmin);
  A.theta_origin = kTwoPi * static_cast<double>(kmin);
  A.partial_cycles = (th0 < kTwoPi * kmin - kThetaSlack ? 1 : 0) +
                     (th1 > kTwoPi * kend + kThetaSlack ? 1 : 0);
  auto bounds = [&](long k) {
    return std::pair{std::max(kTwoPi * k, th0), std::min(kTwoPi * (k + 1), th1)};
  };
  // Sampling cap on M.
  double spc = 1e300;
  std::vector<std::vector<double>> cyc_w(static_cast<std::size_t>(ncyc));
  for (int c = 0; c < ncyc; ++c) {
    auto& wc = cyc_w[static_cast<std::size_t>(c)];
    wc.assign(n, 0.0);
    const auto ab = bounds(kmin + c);  // (not a structured binding: lambdas below capture it)
    const double a = ab.first, b = ab.second;
    add_trapezoid_weights(theta, a, b, wc);
    // Samples per cycle: those with θ in [a, b) (a closing sample at b is the next
    // cycle's first).
    spc = std::min(spc, static_cast<double>(std::count_if(theta.begin(), theta.end(), [&](double v) {
                     return v >= a - kThetaSlack && v < b - kThetaSlack;
                   })));
  }
  A.M_requested = o.max_harmonic;
  A.M_cap = harmonic_cap(x, A.x0, A.timed, spc);
  A.M = std::min(A.M_requested, A.M_cap);
  if (A.M < 1)
    throw InputError(fmt::format("{}: sampling too coarse for a harmonic fit (cap M = {}); "
                                 "expected at least 4 samples per cycle",
                                 where, A.M_cap));
  HarmonicFitOptions fo;
  fo.max_harmonic = A.M;
  fo.drift = o.drift;
  // Per-cycle metrics.
  for (int c = 0; c < ncyc; ++c) {
    const auto& wc = cyc_w[static_cast<std::size_t>(c)];
    CycleResult cr;
    cr.cycle = c + 1;
    const auto [a, b] = bounds(kmin + c);
    if (A.timed) cr.t_start_s = (kTwoPi * (kmin + c) - A.psi) / A.omega;
    double lo = 1e300, hi = -1e300, rmax = 0;
    std::vector<double> lx{interp_at(theta, x, a)}, lr{interp_at(theta, r, a)};
    for (std::size_t i = 0; i < n; ++i) {
      if (!(wc[i] > 0)) continue;
      lo = std::min(lo, x[i]);
      hi = std::max(hi, x[i]);
      rmax = std::max(rmax, std::abs(r[i]));
      if (theta[i] > a && theta[i] < b) {
        lx.push_back(x[i]);
        lr.push_back(r[i]);
      }
    }
    lx.push_back(interp_at(theta, x, b));
    lr.push_back(interp_at(theta, r, b));
    cr.x0 = 0.5 * (hi - lo);
    cr.r_max_raw = rmax;
    cr.E_d = loop_area(lx, lr);
    HarmonicFitOptions fc = fo;
    // One cycle may hold fewer samples than the block fit's parameters need.
    const auto m = static_cast<int>(std::count_if(wc.begin(), wc.end(), [](double v) { return v > 0; }));
    fc.max_harmonic = std::max(1, std::min(fo.max_harmonic, (m - 4) / 2));
    const HarmonicFit hf = fit_harmonics(theta, r, wc, A.x0, fc);
    // A cycle too short for the block's harmonics cannot reconstruct its peak (a first
    // harmonic alone would read a peaked response low): its largest sample stands.
    cr.r_max = fc.max_harmonic >= fo.max_harmonic ? robust_max(rmax, hf) : rmax;
    cr.K1p = hf.Kp[1];
    cr.K1pp = hf.Kpp[1];
    A.cycles.push_back(cr);
  }
  // Steady state: the tail of cycles whose successive changes are all below tolerance.
  int first_steady = -1;  // 0-based
  if (ncyc >= 2) {
    first_steady = ncyc - 1;
    bool any_small = false;
    for (int c = ncyc - 1; c >= 1; --c) {
      const auto& p = A.cycles[static_cast<std::size_t>(c - 1)];
      const auto& q = A.cycles[static_cast<std::size_t>(c)];
      const double scale = std::hypot(q.K1p, q.K1pp);
      const double d = std::max(std::abs(q.K1p - p.K1p), std::abs(q.K1pp - p.K1pp)) / scale;
      if (!(d < o.steady_tolerance)) break;
      any_small = true;
      first_steady = c - 1;
    }
    if (!any_small) first_steady = -1;
  }
  for (int c = 0; c < ncyc; ++c)
    A.cycles[static_cast<std::size_t>(c)].steady = first_steady >= 0 && c >= first_steady;
  A.first_steady_cycle = first_steady + 1;
  if (!o.cycles.empty()) {
    for (int c : o.cycles) {
      if (c > ncyc)
        throw ConfigError(fmt::format("{}: --cycles {}: this amplitude has {} complete cycle{}",
                                      where, c, ncyc, ncyc == 1 ? "" : "s"));
      A.cycles[static_cast<std::size_t>(c - 1)].used = true;
    }
    A.status = AmplitudeStatus::kCyclesSelected;
  } else if (o.all_cycles) {
    for (auto& c : A.cycles) c.used = true;
    A.status = ncyc == 1 ? AmplitudeStatus::kSingleCycle : AmplitudeStatus::kAllCycles;
  } else if (ncyc == 1) {
    A.cycles[0].used = true;
    A.status = AmplitudeStatus::kSingleCycle;
  } else if (first_steady < 0) {
    A.cycles.back().used = true;
    A.status = AmplitudeStatus::kNotSteady;
  } else {
    for (auto& c : A.cycles) c.used = c.steady;
    A.status = AmplitudeStatus::kOk;
  }
  // Block fit over the used cycles.
  std::vector<double> wsum(n, 0.0);
  double Esum = 0, rsum = 0, rsum_raw = 0;
  int nused = 0;
  for (int c = 0; c < ncyc; ++c) {
    const auto& cr = A.cycles[static_cast<std::size_t>(c)];
    if (!cr.used) continue;
    const auto& wc = cyc_w[static_cast<std::size_t>(c)];
    for (std::size_t i = 0; i < n; ++i) wsum[i] += wc[i];
    Esum += cr.E_d;
    rsum += cr.r_max;
    rsum_raw += cr.r_max_raw;
    ++nused;
  }
  {
    double lo = 1e300, hi = 0;
    for (const auto& cr : A.cycles)
      if (cr.used) lo = std::min(lo, cr.x0), hi = std::max(hi, cr.x0);
    if (!o.force_one_amplitude && !(hi <= (1 + o.max_amplitude_spread) * lo))
      throw NoResultError(fmt::format(
          "{}: the drive amplitude drifts: the used cycles span {:.4g} to {:.4g} ({:.3g} %); "
          "expected within {:.3g} % (one steady amplitude)",
          where, lo, hi, 100 * (hi / lo - 1), 100 * o.max_amplitude_spread));
  }
  A.fit = fit_harmonics(theta, r, wsum, A.x0, fo);
  A.measures = derive_measures(A.fit, A.omega);
  check_fit_meaningful(A, where);
  A.E_d = Esum / nused;
  A.r_max = rsum / nused;
  A.r_max_raw = rsum_raw / nused;
  A.E_d_ratio = A.E_d / (kPi * A.x0 * A.x0 * A.measures.K1pp);
  A.phi_d = A.E_d / (4.0 * A.x0 * A.r_max);
  for (std::size_t i = 0; i < n; ++i) {
    if (!(wsum[i] > 0)) continue;
    const long k = std::clamp(static_cast<long>(std::floor(theta[i] / kTwoPi)), kmin, kend - 1);
    A.sample_cycle.push_back(static_cast<int>(k - kmin + 1));
    A.theta.push_back(theta[i]);
    A.weight.push_back(wsum[i]);
    if (A.timed) A.time_s.push_back(t[i]);
    A.drive.push_back(x[i]);
    A.response.push_back(r[i]);
  }
  return A;
}

}  // namespace

RecordResult analyse_record(const Waveform& w, const AnalysisOptions& o,
                            const std::string& context) {
  o.validate();
  const std::size_t n = w.drive.size();
  SHEARZONE_CHECK(w.response.size() == n);
  SHEARZONE_CHECK(w.time_s.empty() || w.time_s.size() == n);
  if (n < 4)
    throw InputError(fmt::format("{}: {} samples; expected at least one complete drive cycle",
                                 context, n));
  const auto [mn, mx] = std::minmax_element(w.drive.begin(), w.drive.end());
  const double level = 0.5 * (*mn + *mx), half = 0.5 * (*mx - *mn);
  if (!(half > 1e-12 * std::max(std::abs(*mx), std::abs(*mn))) || !(half > 0))
    throw InputError(fmt::format("{}: {}: drive amplitude is zero (all drive values {}); expected "
                                 "an oscillating drive",
                                 context, lines_text(w, 0, n - 1), *mx));
  // Amplitude blocks from raw cycles.
  std::vector<std::size_t> up;
  if (o.split_amplitudes) up = upward_crossings(w.drive, level, kHysteresis * half);
  if (!o.split_amplitudes && !o.force_one_amplitude) {
    // One amplitude asked for: the raw cycles must agree by the splitting rule.
    const auto raw = upward_crossings(w.drive, level, kHysteresis * half);
    double lo = 1e300, hi = 0;
    for (std::size_t j = 0; j + 1 < raw.size(); ++j) {
      const auto b = w.drive.begin();
      const auto [l, h] = std::minmax_element(b + static_cast<std::ptrdiff_t>(raw[j]),
                                              b + static_cast<std::ptrdiff_t>(raw[j + 1]));
      lo = std::min(lo, 0.5 * (*h - *l));
      hi = std::max(hi, 0.5 * (*h - *l));
    }
    if (hi > 0 && hi > (1 + o.amplitude_change) * lo)
      throw NoResultError(fmt::format(
          "{}: {}: --no-split over several amplitudes: raw cycles span {:.4g} to {:.4g} (more "
          "than the {:.3g} % rule); analyse them split, or force one amplitude "
          "(--force-one-amplitude)",
          context, lines_text(w, 0, n - 1), lo, hi, 100 * o.amplitude_change));
  }
  std::vector<std::pair<std::size_t, std::size_t>> blocks;
  std::vector<int> raw_cycles;
  {
    std::size_t start = 0;
    int count = 0;
    double prev_amp = -1;
    for (std::size_t j = 0; j + 1 < up.size(); ++j) {
      const auto b = w.drive.begin();
      const auto [lo, hi] = std::minmax_element(b + static_cast<std::ptrdiff_t>(up[j]),
                                                b + static_cast<std::ptrdiff_t>(up[j + 1]));
      const double amp = 0.5 * (*hi - *lo);
      if (prev_amp > 0 && std::abs(amp - prev_amp) > o.amplitude_change * prev_amp) {
        // The new amplitude starts at the first sample at or above the mid level.
        blocks.emplace_back(start, up[j] - 1);
        raw_cycles.push_back(count);
        start = up[j];
        count = 0;
      }
      ++count;
      prev_amp = amp;
    }
    blocks.emplace_back(start, n - 1);
    raw_cycles.push_back(count);
  }
  RecordResult out;
  double last_span = 0;
  for (std::size_t bi = 0; bi < blocks.size(); ++bi) {
    if (blocks.size() > 1 && raw_cycles[bi] < 2) {  // a ramp between two amplitudes
      ++out.skipped_blocks;
      continue;
    }
    double span = 0;
    auto A = analyse_block(w, context, blocks[bi].first, blocks[bi].second, o, span);
    if (A && A->timed && o.drift) {
      // Second pass: the drive's phase from a sine fit over the used cycles only, where
      // the harmonics are taken (a creeping drive's drift is not linear over a whole
      // block: a phase error of 2e-3 rad moves K''_1 by 2 % at tan δ = 0.1).
      double ta = 1e300, tb = -1e300;
      int used = 0;
      for (const auto& c : A->cycles)
        if (c.used) {
          ++used;
          ta = std::min(ta, c.t_start_s);
          tb = std::max(tb, c.t_start_s + kTwoPi / A->omega);
        }
      std::vector<double> tw, xw;
      for (std::size_t i = blocks[bi].first; i <= blocks[bi].second; ++i)
        if (w.time_s[i] >= ta && w.time_s[i] <= tb) {
          tw.push_back(w.time_s[i]);
          xw.push_back(w.drive[i]);
        }
      // Two periods at least: over one, a drift and ω are not separable from the phase.
      if (used >= 2 && tw.size() >= 8) {
        const SineFit local = fit_sine(tw, xw, A->omega, context, true);
        double span2 = 0;
        auto A2 = analyse_block(w, context, blocks[bi].first, blocks[bi].second, o, span2, &local);
        if (A2) A = std::move(A2);
      }
    }
    if (!A) {
      if (blocks.size() == 1)
        throw InputError(fmt::format("{}: {}: less than one complete drive cycle (phase spans {:.4g} "
                                     "rad); expected at least 2π between two upward zero crossings",
                                     context, lines_text(w, blocks[bi].first, blocks[bi].second),
                                     span));
      ++out.skipped_blocks;
      last_span = span;
      continue;
    }
    out.amplitudes.push_back(std::move(*A));
  }
  if (out.amplitudes.empty())
    throw InputError(fmt::format("{}: {}: no amplitude with a complete drive cycle (last phase span "
                                 "{:.4g} rad); expected at least one complete cycle",
                                 context, lines_text(w, 0, n - 1), last_span));
  return out;
}

AmplitudeResult analyse_closed_cycle(const Waveform& w, const AnalysisOptions& o, double omega,
                                     const std::string& context) {
  o.validate();
  const std::size_t n_all = w.drive.size();
  SHEARZONE_CHECK(w.response.size() == n_all);
  constexpr std::size_t kMinSamples = 9;  // 8 distinct: M >= 3
  if (n_all < kMinSamples)
    throw InputError(fmt::format("{}: {} samples; a closed cycle needs at least {} (the last "
                                 "equal to the first)",
                                 context, n_all, kMinSamples));
  const std::string where = fmt::format("{}: {}", context, lines_text(w, 0, n_all - 1));
  const auto [xmn, xmx] = std::minmax_element(w.drive.begin(), w.drive.end());
  const auto [rmn, rmx] = std::minmax_element(w.response.begin(), w.response.end());
  constexpr double kClosure = 1e-6;  // relative to the range
  if (!(std::abs(w.drive.back() - w.drive.front()) <= kClosure * (*xmx - *xmn)) ||
      !(std::abs(w.response.back() - w.response.front()) <= kClosure * (*rmx - *rmn)))
    throw InputError(fmt::format("{}: not a closed cycle (last sample {}, {} differs from the "
                                 "first {}, {}); expected one stored period",
                                 where, w.drive.back(), w.response.back(), w.drive.front(),
                                 w.response.front()));
  const std::size_t N = n_all - 1;  // the last sample closes the period
  // Fundamental of the drive by its discrete Fourier coefficients: x ≈ c + X sin(2πk/N + ψ).
  double a1 = 0, b1 = 0, c = 0;
  for (std::size_t k = 0; k < N; ++k) {
    const double ph = kTwoPi * static_cast<double>(k) / static_cast<double>(N);
    a1 += w.drive[k] * std::sin(ph);
    b1 += w.drive[k] * std::cos(ph);
    c += w.drive[k];
  }
  a1 *= 2.0 / static_cast<double>(N);
  b1 *= 2.0 / static_cast<double>(N);
  c /= static_cast<double>(N);
  AmplitudeResult A;
  A.first_sample = 0;
  A.last_sample = n_all - 1;
  if (w.line.size() == n_all) {
    A.first_line = w.line.front();
    A.last_line = w.line.back();
  }
  A.timed = false;
  A.phase_method = "closed_cycle_dft";
  A.omega = omega;
  A.x0 = std::hypot(a1, b1);
  A.x_offset = c;
  A.psi = std::atan2(b1, a1);
  constexpr double kMinDriveAmplitude = 1e-12;  // as for analyse_record
  if (!(A.x0 > kMinDriveAmplitude) || !std::isfinite(A.x0))
    throw InputError(fmt::format("{}: drive amplitude {:.3g} (SI units): expected more than {:.0e}",
                                 where, A.x0, kMinDriveAmplitude));
  // Samples in the order of θ from 0: θ_k = 2πk/N + ψ, wrapped into one turn.
  std::vector<std::pair<double, std::size_t>> order(N);
  for (std::size_t k = 0; k < N; ++k) {
    double th = kTwoPi * static_cast<double>(k) / static_cast<double>(N) + A.psi;
    th -= kTwoPi * std::floor(th / kTwoPi);
    order[k] = {th, k};
  }
  std::sort(order.begin(), order.end());
  std::vector<double> theta(N), x(N), r(N);
  for (std::size_t i = 0; i < N; ++i) {
    theta[i] = order[i].first;
    x[i] = w.drive[order[i].second];
    r[i] = w.response[order[i].second];
  }
  if (o.inertia > 0) {
    if (std::isnan(A.omega))
      throw ConfigError(fmt::format("{}: inertia subtraction needs ω; give --f-hz or a log with "
                                    "the frequency",
                                    where));
    for (std::size_t i = 0; i < N; ++i) r[i] += o.inertia * A.x0 * A.omega * A.omega * std::sin(theta[i]);
  }
  A.M_requested = o.max_harmonic;
  A.M_cap = static_cast<int>((N - 1) / 2);
  A.M = std::min(A.M_requested, A.M_cap);
  // Uniform samples over exactly one period: the least-squares fit of offset and
  // harmonics n <= M < N/2 is the discrete Fourier transform (orthogonal columns).
  HarmonicFitOptions fo;
  fo.max_harmonic = A.M;
  fo.drift = false;
  A.fit = fit_harmonics(theta, r, std::vector<double>(N, 1.0), A.x0, fo);
  A.measures = derive_measures(A.fit, A.omega);
  check_fit_meaningful(A, where);
  CycleResult cr;
  cr.cycle = 1;
  cr.x0 = 0.5 * (*xmx - *xmn);
  cr.r_max_raw = std::max(std::abs(*rmn), std::abs(*rmx));
  cr.r_max = robust_max(cr.r_max_raw, A.fit);
  cr.E_d = loop_area(w.drive, w.response);  // the stored samples, closed
  cr.K1p = A.fit.Kp[1];
  cr.K1pp = A.fit.Kpp[1];
  cr.used = true;
  A.cycles.push_back(cr);
  A.status = AmplitudeStatus::kClosedCycle;
  A.E_d = cr.E_d;
  A.r_max = cr.r_max;
  A.r_max_raw = cr.r_max_raw;
  A.E_d_ratio = A.E_d / (kPi * A.x0 * A.x0 * A.measures.K1pp);
  A.phi_d = A.E_d / (4.0 * A.x0 * A.r_max);
  A.sample_cycle.assign(N, 1);
  A.theta = theta;
  A.weight.assign(N, 1.0);
  A.drive = x;
  A.response = r;
  return A;
}

const char* amplitude_status_name(AmplitudeStatus s) {
  switch (s) {
    case AmplitudeStatus::kOk: return "ok";
    case AmplitudeStatus::kNotSteady: return "not_steady";
    case AmplitudeStatus::kSingleCycle: return "single_cycle";
    case AmplitudeStatus::kAllCycles: return "all_cycles";
    case AmplitudeStatus::kCyclesSelected: return "cycles_selected";
    case AmplitudeStatus::kClosedCycle: return "closed_cycle";
  }
  return "unknown";
}

}  // namespace shearzone::laos
