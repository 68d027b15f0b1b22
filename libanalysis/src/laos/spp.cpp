#include "shearzone/laos/spp.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/laos/harmonics.hpp"

namespace shearzone::laos {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2.0 * kPi;
/// Phases per cycle on which the cycle measures are searched (and refined between).
constexpr int kGrid = 4096;
/// The truncation error at M bounded from the change between M and about M/2: an error
/// falling as M^(-1/2) is the change times 1/(sqrt(2) - 1). (The yield stresses of the
/// closed-form yielding responses fall as 1/M, docs/laos.md: the bound is conservative.)
constexpr double kTruncationErrorPerChange = 1.0 / (std::numbers::sqrt2 - 1.0);

int largest_odd_at_most(int m) { return m % 2 == 1 ? m : m - 1; }

/// Lanczos' σ factor of harmonic n for a series cut after M, relative to the
/// fundamental's (a linear response keeps its moduli exactly).
double sigma_factor(int n, int M) {
  auto sinc = [](double x) { return x == 0 ? 1.0 : std::sin(kPi * x) / (kPi * x); };
  const double m = static_cast<double>(M + 2);
  return sinc(n / m) / sinc(1.0 / m);
}

std::vector<int> odd_up_to(int M) {
  std::vector<int> n;
  for (int k = 1; k <= M; k += 2) n.push_back(k);
  return n;
}

/// The odd harmonics n <= M and a table of sin nθ_k, cos nθ_k on the measure grid.
/// (Sized in the initialisers: GCC 12 at -O3 sees a possible null pointer in a vector
/// grown by resize().)
struct Grid {
  std::vector<int> n;            ///< the odd harmonics
  std::vector<double> s, c;      ///< [k * n.size() + j]
  std::vector<double> theta;
  explicit Grid(int M)
      : n(odd_up_to(M)), s(static_cast<std::size_t>(kGrid) * n.size()), c(s.size()),
        theta(static_cast<std::size_t>(kGrid)) {
    for (int k = 0; k < kGrid; ++k) {
      theta[static_cast<std::size_t>(k)] = kTwoPi * k / kGrid;
      for (std::size_t j = 0; j < n.size(); ++j) {
        const double a = n[j] * theta[static_cast<std::size_t>(k)];
        s[static_cast<std::size_t>(k) * n.size() + j] = std::sin(a);
        c[static_cast<std::size_t>(k) * n.size() + j] = std::cos(a);
      }
    }
  }
};

/// The response and its first three θ-derivatives summed over odd harmonics n, each
/// a_n sin nθ + b_n cos nθ; and the transient quantities they give at θ.
struct Derivatives {
  double r0 = 0, r1 = 0, r2 = 0, r3 = 0;
  void add(double n, double an, double bn, double sn, double cn) {
    const double even = an * sn + bn * cn, odd = an * cn - bn * sn;
    r0 += even;
    r1 += n * odd;
    r2 -= n * n * even;
    r3 -= n * n * n * odd;
  }
  double Gp(double st, double ct, double x0) const { return (ct * r1 - st * r2) / x0; }
  double Gpp(double st, double ct, double x0) const { return -(st * r1 + ct * r2) / x0; }
  double dGp(double st, double x0) const { return -st * (r1 + r3) / x0; }
  double dGpp(double ct, double x0) const { return -ct * (r1 + r3) / x0; }
};

struct Curve {
  std::vector<double> r, Gp, dGp;
};

/// σ, G'_t and dG'_t/dθ on the grid for odd coefficients a, b (index n).
Curve curve(const Grid& g, const std::vector<double>& a, const std::vector<double>& b, double x0) {
  Curve cv{std::vector<double>(kGrid), std::vector<double>(kGrid), std::vector<double>(kGrid)};
  const std::size_t J = g.n.size();
  for (std::size_t k = 0; k < static_cast<std::size_t>(kGrid); ++k) {
    Derivatives d;
    for (std::size_t j = 0; j < J; ++j) {
      const auto n = static_cast<std::size_t>(g.n[j]);
      d.add(static_cast<double>(n), a[n], b[n], g.s[k * J + j], g.c[k * J + j]);
    }
    const double st = g.s[k * J], ct = g.c[k * J];  // n = 1: sin θ, cos θ
    cv.r[k] = d.r0;
    cv.Gp[k] = d.Gp(st, ct, x0);
    cv.dGp[k] = d.dGp(st, x0);
  }
  return cv;
}

struct CycleMeasures {
  double cage = core::kUnset, static_yield = core::kUnset, dynamic_yield = core::kUnset;
};

/// The phase offset in (−½, ½) grid steps of the vertex of the parabola through
/// (k − 1, k, k + 1) of y, at a local minimum k (0 where the three do not curve up).
double parabola_offset(double ym, double y0, double yp) {
  const double den = ym - 2 * y0 + yp;
  return den > 0 ? std::clamp(0.5 * (ym - yp) / den, -0.5, 0.5) : 0.0;
}

/// A lobe of G'_t <= 0 no wider than this many kernel widths 2π/(M + 2) is a kink the
/// series cannot resolve: the σ factors spread the kink of an elastic–plastic response
/// (G'_t = −r″ sin θ / x0 there, r″ a δ) into a lobe 1.3-1.6 kernel widths wide at M =
/// 19-639, centred on it (docs/laos.md, "Within the cycle").
constexpr double kKinkLobeWidths = 2.0;

/// One loading branch: sign +1 from an upward zero crossing of σ to its maximum, −1
/// from a downward crossing to its minimum. Values as magnitudes.
CycleMeasures branch(const Curve& cv, int sign, int M) {
  CycleMeasures m;
  const auto K = static_cast<long>(kGrid);
  auto at = [&](const std::vector<double>& v, long k) { return v[static_cast<std::size_t>(((k % K) + K) % K)]; };
  auto r = [&](long k) { return sign * at(cv.r, k); };
  // σ at grid phase k moved by a parabola's offset (in grid steps) towards its neighbour.
  auto r_at = [&](long k, double off) { return r(k) + std::abs(off) * (r(off >= 0 ? k + 1 : k - 1) - r(k)); };
  long peak = 0;
  for (long k = 1; k < K; ++k)
    if (r(k) > r(peak)) peak = k;
  if (!(r(peak) > 0)) return m;
  long start = peak;  // the last phase before the peak with σ < 0 (sign-adjusted)
  while (start > peak - K && r(start) >= 0) --start;
  if (start == peak - K) return m;  // σ never changes sign
  // Cage modulus: G'_t at the zero of σ between start and start + 1.
  const double f0 = -r(start) / (r(start + 1) - r(start));
  m.cage = at(cv.Gp, start) + f0 * (at(cv.Gp, start + 1) - at(cv.Gp, start));
  // Static yield: where G'_t changes sign (+ to −), read in the lobe of G'_t <= 0 that
  // holds the branch's lowest G'_t (ringing ahead of a kink can make small lobes of its
  // own). A lobe no wider than kKinkLobeWidths kernel widths is an unresolved kink: its
  // deepest point (the parabola's vertex) is the kink, while its leading zero sits where
  // the kernel's tail first outweighs the elastic slope, ahead of the kink (the closed-
  // form elastic–perfectly-plastic loop: −25 % at M = 39, −2.3 % at 639). A wider lobe is
  // resolved, and its leading zero is the sign change.
  long kmin = start + 1;
  for (long k = start + 1; k <= peak; ++k)
    if (at(cv.Gp, k) < at(cv.Gp, kmin)) kmin = k;
  if (at(cv.Gp, kmin) <= 0) {
    long k0 = kmin;  // the last phase before the lobe (G'_t > 0 there, unless the branch starts in it)
    while (k0 > start && at(cv.Gp, k0) <= 0) --k0;
    long k1 = kmin;  // the lobe's last phase
    while (k1 < peak && at(cv.Gp, k1 + 1) <= 0) ++k1;
    if (at(cv.Gp, k0) > 0) {
      const double kernel_width = kGrid / (M + 2.0);  // 2π/(M + 2) in grid steps
      if (static_cast<double>(k1 - k0) <= kKinkLobeWidths * kernel_width) {
        m.static_yield = r_at(kmin, parabola_offset(at(cv.Gp, kmin - 1), at(cv.Gp, kmin), at(cv.Gp, kmin + 1)));
      } else {
        const double f = at(cv.Gp, k0) / (at(cv.Gp, k0) - at(cv.Gp, k0 + 1));
        m.static_yield = r(k0) + f * (r(k0 + 1) - r(k0));
      }
    }
  }
  // Dynamic yield: σ at the smallest dG'_t/dθ, the minimum refined by a parabola; only
  // where the branch loses at least half of the cage modulus (no yield otherwise: a
  // linear response's rate is rounding noise, and its minimum anywhere).
  if (!(m.cage > 0) || !(at(cv.Gp, kmin) <= 0.5 * m.cage)) return m;
  long low = start + 1;
  for (long k = start + 1; k <= peak; ++k)
    if (at(cv.dGp, k) < at(cv.dGp, low)) low = k;
  m.dynamic_yield = r_at(low, parabola_offset(at(cv.dGp, low - 1), at(cv.dGp, low), at(cv.dGp, low + 1)));
  return m;
}

/// The measures of the series a, b weighted for a cut at M (M <= the grid's harmonics).
CycleMeasures measures(const Grid& g, const std::vector<double>& a, const std::vector<double>& b, double x0,
                       int M) {
  const Curve cv = curve(g, a, b, x0);
  const CycleMeasures up = branch(cv, +1, M), down = branch(cv, -1, M);
  auto mean = [](double u, double v) { return std::isnan(u) || std::isnan(v) ? core::kUnset : 0.5 * (u + v); };
  return {mean(up.cage, down.cage), mean(up.static_yield, down.static_yield),
          mean(up.dynamic_yield, down.dynamic_yield)};
}

/// Odd coefficients r = Σ a_n sin nθ + b_n cos nθ of the fit, weighted for a cut at M.
void weighted(const HarmonicFit& fit, int M, std::vector<double>& a, std::vector<double>& b) {
  a.assign(static_cast<std::size_t>(M + 1), 0.0);
  b.assign(a.size(), 0.0);
  for (int n = 1; n <= M; n += 2) {
    const double w = sigma_factor(n, M) * fit.amplitude;
    a[static_cast<std::size_t>(n)] = w * fit.Kp[static_cast<std::size_t>(n)];
    b[static_cast<std::size_t>(n)] = w * fit.Kpp[static_cast<std::size_t>(n)];
  }
}

SppMeasure judge(double estimate, double at_check, const std::vector<double>& draws, double tolerance) {
  SppMeasure m;
  m.estimate = estimate;
  if (std::isnan(estimate)) return m;  // not_found
  m.truncation_change = estimate - at_check;
  double s = 0, s2 = 0;
  std::size_t k = 0, missing = 0;
  for (double v : draws) {
    if (std::isnan(v)) {
      ++missing;
      continue;
    }
    s += v;
    s2 += v * v;
    ++k;
  }
  const double mean = k > 0 ? s / static_cast<double>(k) : 0.0;
  m.noise_sd = k > 1 ? std::sqrt(std::max(0.0, (s2 - static_cast<double>(k) * mean * mean) /
                                                   static_cast<double>(k - 1)))
                     : core::kUnset;
  const double limit = tolerance * std::abs(estimate);
  // A redraw that loses the crossing counts against the measure as a large spread.
  if (std::isnan(m.noise_sd) || m.noise_sd > limit || missing * 20 > draws.size())
    m.status = SppStatus::kNoiseLimited;
  else if (std::isnan(at_check) || kTruncationErrorPerChange * std::abs(m.truncation_change) > limit)
    m.status = SppStatus::kTruncationLimited;
  else {
    m.status = SppStatus::kOk;
    m.value = estimate;
  }
  return m;
}

}  // namespace

void SppOptions::validate() const {
  if (max_harmonic < 3 || max_harmonic > 999)
    throw ConfigError(fmt::format("--spp-harmonics {}: expected 3..999", max_harmonic));
  if (bootstrap < 20 || bootstrap > 100000)
    throw ConfigError(fmt::format("SPP redraws {}: expected 20..100000", bootstrap));
  if (!(max_relative_change > 0 && max_relative_change < 1))
    throw ConfigError(fmt::format("--spp-tolerance {}: expected a fraction in (0, 1)", max_relative_change));
}

const char* spp_status_name(SppStatus s) {
  switch (s) {
    case SppStatus::kOk: return "ok";
    case SppStatus::kNoiseLimited: return "noise_limited";
    case SppStatus::kTruncationLimited: return "truncation_limited";
    case SppStatus::kNotFound: return "not_found";
  }
  return "unknown";
}

SppPoint spp_point(const std::vector<double>& a, const std::vector<double>& b, double x0, double theta,
                   const std::vector<double>* a_se, const std::vector<double>* b_se) {
  const double st = std::sin(theta), ct = std::cos(theta);
  Derivatives d;
  double var_p = 0, var_pp = 0;
  for (std::size_t n = 1; n < a.size(); n += 2) {
    const double nn = static_cast<double>(n), sn = std::sin(nn * theta), cn = std::cos(nn * theta);
    d.add(nn, a[n], b[n], sn, cn);
    if (a_se != nullptr && b_se != nullptr) {
      // G'_t x0 = ct r1 − st r2 and −G''_t x0 = st r1 + ct r2 are linear in a_n, b_n.
      const double dp_da = ct * nn * cn + st * nn * nn * sn, dp_db = -ct * nn * sn + st * nn * nn * cn;
      const double dpp_da = st * nn * cn - ct * nn * nn * sn, dpp_db = -st * nn * sn - ct * nn * nn * cn;
      const double sa = (*a_se)[n], sb = (*b_se)[n];
      var_p += dp_da * dp_da * sa * sa + dp_db * dp_db * sb * sb;
      var_pp += dpp_da * dpp_da * sa * sa + dpp_db * dpp_db * sb * sb;
    }
  }
  SppPoint p;
  if (a_se != nullptr && b_se != nullptr) {
    p.Gp_se = std::sqrt(var_p) / x0;
    p.Gpp_se = std::sqrt(var_pp) / x0;
  }
  p.theta = theta;
  p.x = x0 * st;
  p.rate = x0 * ct;
  p.r = d.r0;
  p.Gp = d.Gp(st, ct, x0);
  p.Gpp = d.Gpp(st, ct, x0);
  p.delta = std::atan(p.Gpp / p.Gp) + (p.Gp < 0 ? kPi : 0.0);
  p.dGp = d.dGp(st, x0);
  p.dGpp = d.dGpp(ct, x0);
  p.r_d = d.r0 - p.Gp * p.x - p.Gpp * p.rate;
  p.x_eq = p.Gp != 0 ? p.x - p.r_d / p.Gp : core::kUnset;
  return p;
}

namespace {

/// The three cycle measures of one fit, with their checks; a, b and their standard
/// errors (σ-weighted, index n) into the last four arguments.
struct Judged {
  SppMeasure cage, static_yield, dynamic_yield;
};
Judged judge_fit(const HarmonicFit& fit, int M, int M_check, double x0, const SppOptions& o, const Grid& grid,
                 std::vector<double>& ra, std::vector<double>& rb, std::vector<double>& ra_se,
                 std::vector<double>& rb_se) {
  weighted(fit, M, ra, rb);
  ra_se.assign(ra.size(), 0.0);
  rb_se.assign(rb.size(), 0.0);
  for (int n = 1; n <= M; n += 2) {
    const auto i = static_cast<std::size_t>(n);
    const double w = sigma_factor(n, M) * fit.amplitude;
    ra_se[i] = w * fit.Kp_se[i];
    rb_se[i] = w * fit.Kpp_se[i];
  }
  const CycleMeasures est = measures(grid, ra, rb, x0, M);
  std::vector<double> ca, cb;
  weighted(fit, M_check, ca, cb);
  ca.resize(ra.size(), 0.0);
  cb.resize(rb.size(), 0.0);
  const CycleMeasures chk = measures(grid, ca, cb, x0, M_check);
  // The noise check: the odd harmonics redrawn from their standard errors.
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> z(0.0, 1.0);
  std::vector<double> dc, ds, dd;
  std::vector<double> a(ra.size()), b(rb.size());
  for (int k = 0; k < o.bootstrap; ++k) {
    for (int n = 1; n <= M; n += 2) {
      const auto i = static_cast<std::size_t>(n);
      a[i] = ra[i] + ra_se[i] * z(rng);
      b[i] = rb[i] + rb_se[i] * z(rng);
    }
    const CycleMeasures m = measures(grid, a, b, x0, M);
    dc.push_back(m.cage);
    ds.push_back(m.static_yield);
    dd.push_back(m.dynamic_yield);
  }
  return {judge(est.cage, chk.cage, dc, o.max_relative_change),
          judge(est.static_yield, chk.static_yield, ds, o.max_relative_change),
          judge(est.dynamic_yield, chk.dynamic_yield, dd, o.max_relative_change)};
}

}  // namespace

SppResult analyse_spp(const AmplitudeResult& A, const SppOptions& o, const std::string& context) {
  o.validate();
  SppResult R;
  R.M = largest_odd_at_most(std::min(o.max_harmonic, A.M_cap));
  if (R.M < 3)
    throw InputError(fmt::format("{}: SPP needs the odd harmonics up to at least n = 3; the sampling allows "
                                 "M = {} (samples per cycle or angle steps too coarse)",
                                 context, A.M_cap));
  R.M_check = largest_odd_at_most((R.M + 1) / 2);
  R.x0 = A.x0;
  R.omega = A.omega;
  HarmonicFitOptions fo;
  fo.max_harmonic = R.M;
  fo.drift = o.drift && A.status != AmplitudeStatus::kClosedCycle;
  const HarmonicFit fit = fit_harmonics(A.theta, A.response, A.weight, A.x0, fo);
  const Grid grid(R.M);
  const Judged all = judge_fit(fit, R.M, R.M_check, R.x0, o, grid, R.a, R.b, R.a_se, R.b_se);
  R.cage_modulus = all.cage;
  R.static_yield = all.static_yield;
  R.dynamic_yield = all.dynamic_yield;
  R.points.reserve(A.theta.size());
  for (double th : A.theta) R.points.push_back(spp_point(R.a, R.b, R.x0, th, &R.a_se, &R.b_se));

  // Each used cycle on its own, where there are several: the same fit over that cycle's
  // phases only (its trapezoid weights), the same checks.
  const int first = A.sample_cycle.empty() ? 0 : A.sample_cycle.front();
  const int last = A.sample_cycle.empty() ? 0 : A.sample_cycle.back();
  if (last > first) {
    for (int c = first; c <= last; ++c) {
      // The cycle's span, clamped to the samples as the analysis clamps its cycles (a
      // record may start within its slack after the first cycle's start).
      const double a0 = A.theta_origin + kTwoPi * (c - 1);
      const double a = std::max(a0, A.theta.front()), b = std::min(a0 + kTwoPi, A.theta.back());
      if (!(b - a > 0.99 * kTwoPi)) continue;
      std::vector<double> w(A.theta.size(), 0.0);
      add_trapezoid_weights(A.theta, a, b, w);
      const auto rows = std::count_if(w.begin(), w.end(), [](double v) { return v > 0; });
      SppCycle sc;
      sc.cycle = c;
      if (rows < 2 * R.M + 3 + (fo.drift ? 1 : 0)) {
        R.cycles.push_back(sc);  // too few samples for M on one cycle: not_found
        continue;
      }
      const HarmonicFit fc = fit_harmonics(A.theta, A.response, w, A.x0, fo);
      std::vector<double> ca, cb, ca_se, cb_se;
      const Judged j = judge_fit(fc, R.M, R.M_check, R.x0, o, grid, ca, cb, ca_se, cb_se);
      sc.cage_modulus = j.cage;
      sc.static_yield = j.static_yield;
      sc.dynamic_yield = j.dynamic_yield;
      R.cycles.push_back(sc);
    }
  }
  return R;
}

}  // namespace shearzone::laos
