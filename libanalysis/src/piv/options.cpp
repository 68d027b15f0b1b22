#include "shearzone/piv/options.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "shearzone/core/check.hpp"
#include "shearzone/core/enum_names.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::piv {
namespace {
using io::format_number;
}  // namespace

const char* interpolation_name(Interpolation i) {
  switch (i) {
    case Interpolation::kBilinear: return "bilinear";
    case Interpolation::kBicubic: return "bicubic";
    case Interpolation::kBSpline: return "bspline";
    case Interpolation::kBSpline5: return "bspline5";
  }
  return "?";
}

Interpolation interpolation_from_name(const std::string& name) {
  return core::enum_from_name(
      name, {Interpolation::kBilinear, Interpolation::kBicubic, Interpolation::kBSpline, Interpolation::kBSpline5},
      interpolation_name, "interpolation");
}

const char* subpixel_name(Subpixel s) { return s == Subpixel::kGauss3 ? "gauss3" : "gauss2d"; }

Subpixel subpixel_from_name(const std::string& name) {
  return core::enum_from_name(name, {Subpixel::kGauss3, Subpixel::kGauss2D}, subpixel_name, "sub-pixel method");
}

const char* residual_name(Residual r) { return r == Residual::kPeak ? "peak" : "gradient"; }

Residual residual_from_name(const std::string& name) {
  return core::enum_from_name(name, {Residual::kPeak, Residual::kGradient}, residual_name, "residual estimator");
}

const char* predictor_fit_name(PredictorFit f) { return f == PredictorFit::kGaussian ? "gaussian" : "quadratic"; }

std::vector<double> quadratic_fit_weights(int half_width) {
  SHEARZONE_CHECK_OP(half_width, >=, 2);
  const double m = half_width;
  const double norm = (2 * m + 1) * (4 * m * m + 4 * m - 3);
  std::vector<double> w;
  w.reserve(static_cast<std::size_t>(2 * half_width + 1));
  for (int i = -half_width; i <= half_width; ++i)
    w.push_back(3.0 * (3 * m * m + 3 * m - 1 - 5.0 * i * i) / norm);
  return w;
}

PredictorFit predictor_fit_from_name(const std::string& name) {
  return core::enum_from_name(name, {PredictorFit::kGaussian, PredictorFit::kQuadratic}, predictor_fit_name,
                              "predictor smoothing fit");
}

int PivOptions::step_px(std::size_t pass) const {
  const int w = windows_px.at(pass);
  return std::max(1, static_cast<int>(std::lround(w * (1.0 - overlap))));
}

int PivOptions::predictor_fit_half_width() const {
  return std::max(2, static_cast<int>(std::lround(2.0 * predictor_smoothing)));
}

void PivOptions::validate() const {
  if (windows_px.empty()) throw ConfigError("PivOptions::windows_px: at least one pass is needed");
  // Each pass costs a full correlation of the pair: more than 8 passes refine nothing
  // (use --repeats for extra final passes) and only add time.
  if (windows_px.size() > 8)
    throw ConfigError(fmt::format("PivOptions::windows_px (--windows) has {} passes: expected 1 to 8",
                                  windows_px.size()));
  for (std::size_t p = 0; p < windows_px.size(); ++p) {
    const int w = windows_px[p];
    if (w < 8 || w > 256 || (w & (w - 1)) != 0)
      throw ConfigError(fmt::format(
          "PivOptions::windows_px[{}] = {}: must be a power of two from 8 to 256", p, w));
    if (p > 0 && w > windows_px[p - 1])
      throw ConfigError(fmt::format(
          "PivOptions::windows_px = {}: windows must not grow from pass to pass",
          fmt::join(windows_px, ",")));
  }
  auto range = [](const char* what, double v, double lo, double hi, const char* rule) {
    if (!(v >= lo && v <= hi))
      throw ConfigError(fmt::format("PivOptions::{} = {}: {}", what, format_number(v), rule));
  };
  range("overlap", overlap, 0.0, 0.875, "must satisfy 0 <= overlap <= 0.875");
  range("final_pass_repeats", final_pass_repeats, 0, 10, "must satisfy 0 <= repeats <= 10");
  range("restricted_search", restricted_search, 0.05, 0.5, "must satisfy 0.05 <= r <= 0.5");
  range("predictor_smoothing", predictor_smoothing, 0.0, 5.0, "must satisfy 0 <= s <= 5");
  range("median_radius", median_radius, 1, 3, "must be 1, 2 or 3 (3x3 to 7x7)");
  range("median_epsilon_px", median_epsilon_px, 0.0, 10.0, "must satisfy 0 <= epsilon <= 10");
  range("median_threshold", median_threshold, -1e9, 1e9, "must be a number");
  range("std_threshold", std_threshold, -1e9, 1e9, "must be a number");
  if (!(max_displacement_px > 0))
    throw ConfigError(fmt::format("PivOptions::max_displacement_px = {}: must be > 0",
                                  format_number(max_displacement_px)));
  range("min_peak", min_peak, 0.0, 1.0, "must satisfy 0 <= min_peak <= 1");
  range("min_peak_relative", min_peak_relative, 0.0, 1.0, "must satisfy 0 <= min_peak_relative <= 1 (0: off)");
  range("min_peak_ratio", min_peak_ratio, 1.0, 100.0, "must satisfy 1 <= min_peak_ratio <= 100");
  range("min_window_std", min_window_std, 0.0, 0.5, "must satisfy 0 <= min_window_std <= 0.5");
  range("mask_fraction", mask_fraction, 0.0, 1.0, "must satisfy 0 <= mask_fraction <= 1");
}

core::Metadata PivOptions::to_metadata() const {
  return {{"piv_windows_px", fmt::format("{}", fmt::join(windows_px, ","))},
          {"piv_overlap", format_number(overlap)},
          {"piv_final_pass_repeats", std::to_string(final_pass_repeats)},
          {"piv_deformation", deform ? std::string("symmetric, ") + interpolation_name(interpolation)
                                     : std::string("off")},
          {"piv_subpixel", subpixel_name(subpixel)},
          {"piv_residual", deform ? residual_name(residual) : "peak"},
          {"piv_restricted_search", format_number(restricted_search)},
          {"piv_predictor_smoothing_steps", format_number(predictor_smoothing)},
          {"piv_predictor_smoothing_fit",
           predictor_smoothing <= 0 ? std::string("none")
           : predictor_fit == PredictorFit::kGaussian
               ? fmt::format("gaussian, sigma {} grid steps", format_number(predictor_smoothing))
               : fmt::format("quadratic least squares over +-{} grid steps along each axis",
                             predictor_fit_half_width())},
          {"piv_coarse_estimate",
           coarse_estimate
               ? fmt::format("on: templates of {} px matched at half resolution within +-{} px; the "
                             "coarse field is the first pass's predictor where its largest valid "
                             "displacement exceeds {} px",
                             windows_px.empty() ? 0 : windows_px.front(),
                             windows_px.empty() ? 0 : windows_px.front(),
                             windows_px.empty() ? 0 : windows_px.front() / 4)
               : std::string("off")},
          {"piv_median_test",
           fmt::format("radius {}, epsilon {} px, threshold {}", median_radius,
                       format_number(median_epsilon_px), format_number(median_threshold))},
          {"piv_std_threshold", format_number(std_threshold)},
          {"piv_max_displacement_px", format_number(max_displacement_px)},
          {"piv_min_peak", format_number(min_peak)},
          {"piv_min_peak_relative", format_number(min_peak_relative)},
          {"piv_min_peak_ratio", format_number(min_peak_ratio)},
          {"piv_min_window_std", format_number(min_window_std)},
          {"piv_mask_fraction", format_number(mask_fraction)},
          {"piv_window_centre", "a window covering pixels [s, s+W-1] has its centre at s + (W-1)/2"}};
}

void PivPreset::apply(PivOptions& o) const {
  o.windows_px = windows_px;
  o.interpolation = interpolation;
  o.subpixel = subpixel;
  o.final_pass_repeats = final_pass_repeats;
  o.predictor_smoothing = predictor_smoothing;
}

bool PivPreset::matches(const PivOptions& o) const {
  return o.windows_px == windows_px && o.interpolation == interpolation && o.subpixel == subpixel &&
         o.final_pass_repeats == final_pass_repeats && o.predictor_smoothing == predictor_smoothing;
}

const std::vector<PivPreset>& piv_presets() {
  static const std::vector<PivPreset> presets = {
      {"accurate", "64-32-16 px, quintic B-spline, 3-point Gaussian peak fit, 2 repeats", {64, 32, 16},
       Interpolation::kBSpline5, Subpixel::kGauss3, 2, 1.0},
      {"default", "64-32-16 px, quintic B-spline, 3-point Gaussian peak fit, 1 repeat", {64, 32, 16},
       Interpolation::kBSpline5, Subpixel::kGauss3, 1, 1.0},
      {"fast", "32-16 px (displacements below 16 px), quintic B-spline, 3-point Gaussian, no repeat",
       {32, 16}, Interpolation::kBSpline5, Subpixel::kGauss3, 0, 1.0},
      // Radial profiles of beads average thousands of vectors: their bias matters, not
      // their scatter. 3 repeats finish the sub-pixel shift of cusped bead peaks (a
      // 0.2 px shift of 10 px beads read 2.4 % low with 1 repeat, 1.3 % with 3) and an
      // unsmoothed predictor does not over-read a decay over one bead (12-16 % high at
      // the crossing with smoothing 1): the demo study's r_c 0.40 -> 0.09 mm RMS.
      {"profile",
       "64-32-16 px, quintic B-spline, 3-point Gaussian, 3 repeats, no predictor smoothing (least "
       "bias for velocity profiles and r_c; more scatter per vector)",
       {64, 32, 16}, Interpolation::kBSpline5, Subpixel::kGauss3, 3, 0.0},
  };
  return presets;
}

const PivPreset& piv_preset(const std::string& name) {
  for (const auto& p : piv_presets())
    if (name == p.name) return p;
  std::string names;
  for (const auto& p : piv_presets()) names += (names.empty() ? "" : ", ") + std::string(p.name);
  throw ConfigError(fmt::format("unknown PIV preset \"{}\"; expected one of: {}", name, names));
}

}  // namespace shearzone::piv
