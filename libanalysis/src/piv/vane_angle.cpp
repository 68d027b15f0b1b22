#include "shearzone/piv/vane_angle.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/check.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/sine_fit.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/io/angle_log.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/piv/piv.hpp"

namespace shearzone::piv {

namespace {

/// Variance of the frame under the blade template at angle a.
double variance_under_vane(const cv::Mat& f, double cx, double cy, const core::VaneGeometry& v,
                           double a) {
  double s1 = 0, s2 = 0;
  std::size_t n = 0;
  for (int k = 0; k < v.blades; ++k) {
    const double ang = a + 2.0 * std::numbers::pi * k / v.blades;
    const double ex = std::cos(ang), ey = -std::sin(ang);
    // Sample the blade on a 1 px lattice in its own frame (along, across).
    for (double along = v.half_width_px; along <= v.radius_px; along += 1.0)
      for (double across = -v.half_width_px + 0.5; across <= v.half_width_px - 0.5; across += 1.0) {
        const int x = static_cast<int>(std::lround(cx + along * ex - across * ey));
        const int y = static_cast<int>(std::lround(cy + along * ey + across * ex));
        if (x < 0 || y < 0 || x >= f.cols || y >= f.rows) continue;
        const double val = f.at<float>(y, x);
        s1 += val;
        s2 += val * val;
        ++n;
      }
  }
  if (n < 2) return std::numeric_limits<double>::infinity();
  const double m = s1 / n;
  return s2 / n - m * m;
}

}  // namespace

double estimate_vane_angle(const cv::Mat& frame, double cx, double cy,
                           const core::VaneGeometry& vane, double a_lo, double a_hi) {
  SHEARZONE_CHECK(vane.blades > 0 && a_hi > a_lo);
  const cv::Mat f = to_unit_float(frame);
  const double step = 0.25 * std::numbers::pi / 180.0;
  const int n = static_cast<int>(std::ceil((a_hi - a_lo) / step)) + 1;
  std::vector<double> var(static_cast<std::size_t>(n));
#pragma omp parallel for schedule(static)
  for (int k = 0; k < n; ++k) var[static_cast<std::size_t>(k)] = variance_under_vane(f, cx, cy, vane, a_lo + k * step);
  const int best = static_cast<int>(std::min_element(var.begin(), var.end()) - var.begin());
  double a = a_lo + best * step;
  if (best > 0 && best + 1 < n) {
    const double l = var[static_cast<std::size_t>(best - 1)], c = var[static_cast<std::size_t>(best)],
                 r = var[static_cast<std::size_t>(best + 1)];
    const double den = l - 2 * c + r;
    if (den > 0) a += step * std::clamp(0.5 * (l - r) / den, -0.5, 0.5);
  }
  return a;
}

double interpolate_log(const std::vector<double>& t, const std::vector<double>& a, double x) {
  SHEARZONE_CHECK(t.size() == a.size() && !t.empty());
  const auto it = std::upper_bound(t.begin(), t.end(), x);
  const std::size_t hi = std::min<std::size_t>(static_cast<std::size_t>(it - t.begin()), t.size() - 1);
  const std::size_t lo = hi == 0 ? 0 : hi - 1;
  if (hi == lo) return a[lo];
  const double w = std::clamp((x - t[lo]) / (t[hi] - t[lo]), 0.0, 1.0);
  return (1 - w) * a[lo] + w * a[hi];
}

double best_log_offset(const std::vector<double>& ft, const std::vector<double>& va,
                       const std::vector<double>& lt, const std::vector<double>& la, double step_s) {
  SHEARZONE_CHECK(ft.size() == va.size() && lt.size() == la.size() && !ft.empty() && lt.size() >= 2);
  const double lo = lt.front() - ft.front(), hi = lt.back() - ft.back();
  if (hi < lo) return core::kUnset;
  auto cost = [&](double o) {
    double s = 0;
    for (std::size_t k = 0; k < ft.size(); ++k) {
      const double d = va[k] - interpolate_log(lt, la, ft[k] + o);
      s += d * d;
    }
    return s;
  };
  double best = lo, best_cost = std::numeric_limits<double>::infinity();
  for (double o = lo; o <= hi + 1e-12; o += step_s) {
    const double c = cost(o);
    if (c < best_cost) {
      best_cost = c;
      best = o;
    }
  }
  const double fine = step_s / 20.0;
  for (double o = std::max(lo, best - step_s); o <= std::min(hi, best + step_s); o += fine) {
    const double c = cost(o);
    if (c < best_cost) {
      best_cost = c;
      best = o;
    }
  }
  return best;
}

VanePhaseFit fit_vane_phase(const std::vector<double>& t, const std::vector<double>& y, double f_Hz) {
  VanePhaseFit out;
  const std::size_t n = std::min(t.size(), y.size());
  if (n < 4 || !(f_Hz > 0) || !((t[n - 1] - t[0]) * f_Hz >= 0.25)) {
    out.phase_rad = std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  const double w = 2.0 * std::numbers::pi * f_Hz;
  // A sin wt + B cos wt = R sin(w t + phase), phase = atan2(B, A); the common length only.
  const core::SineAt s =
      t.size() == y.size()
          ? core::fit_sine_at(t, y, w, 0.0, false)
          : core::fit_sine_at(std::vector<double>(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(n)),
                              std::vector<double>(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(n)), w, 0.0,
                              false);
  out.amplitude_rad = std::hypot(s.A, s.B);
  out.phase_rad = std::atan2(s.B, s.A);
  out.offset_rad = s.C;
  out.rms_rad = std::sqrt(s.rss / static_cast<double>(n));
  return out;
}

VaneDrive::VaneDrive(Options o) : o_(std::move(o)) {
  if (o_.log_path.empty()) return;
  io::AngleLog log = io::read_angle_log(o_.log_path, 2);
  time_ = std::move(log.time_s);
  angle_ = std::move(log.angle_rad);
}

double VaneDrive::at(double t_s, const std::string& frame_label) const {
  const double angle0 = o_.angle0_deg * std::numbers::pi / 180.0;
  if (time_.empty()) return angle0 + o_.phi0_rad * std::sin(2.0 * std::numbers::pi * o_.f_Hz * t_s + o_.phase_rad);
  const double tl = t_s + o_.log_offset_s;
  if (tl < time_.front() || tl > time_.back())
    throw InputError(fmt::format("{}: frame {} at t = {} s (log time {} s) is outside the angle log's range [{}, {}] "
                                 "s; check --log-offset-s",
                                 o_.log_path, frame_label, io::format_number(t_s), io::format_number(tl),
                                 io::format_number(time_.front()), io::format_number(time_.back())));
  return angle0 + interpolate_log(time_, angle_, tl);
}

}  // namespace shearzone::piv
