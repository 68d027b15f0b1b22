#include "shearzone/piv/piv.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/check.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/stats.hpp"
#include "shearzone/piv/correlate.hpp"
#include "shearzone/piv/deform.hpp"
#include "shearzone/piv/validate.hpp"

namespace shearzone::piv {

using core::VectorField;
using core::VectorFlag;

namespace {

/// Smallest ratio of the eigenvalues of a window's gradient matrix for which the
/// gradient step is used (below it the window sees an edge or a ramp in one direction).
constexpr double kMinGradientConditioning = 0.05;
/// Correlation peaks at least this wide (Gaussian sigma, px) take the gradient step.
/// Seeded particles of 2-4 px correlate to sigma 0.7-1.4 px; shaded beads of 8 px to about 1.6 px.
constexpr double kMinGradientPeakSigmaPx = 1.5;

/// Smallest fraction of a final window's samples inside the frame, in A and in B, for
/// a vector to count (below it, more than a quarter of the window is clamped border).
/// At 16 px windows this starts at displacements of 8 px at the frame's edge; on
/// synthetic beads shifted 40 px, the vectors it removes were 1.6-3.7 px off.
constexpr double kMinInsideFraction = 0.75;

struct Grid {
  int window = 0, step = 0, nx = 0, ny = 0;
  double x0 = 0, y0 = 0;  // centre of the first window
};

Grid make_grid(cv::Size size, int window, int step) {
  Grid g;
  g.window = window;
  g.step = step;
  g.nx = (size.width - window) / step + 1;
  g.ny = (size.height - window) / step + 1;
  g.x0 = g.y0 = 0.5 * (window - 1);
  return g;
}

/// Bilinear value of a grid field (CV_32F ny x nx) at (x, y), constant outside.
double sample_grid(const cv::Mat& values, const Grid& g, double x, double y) {
  const double gx = std::clamp((x - g.x0) / g.step, 0.0, static_cast<double>(values.cols - 1));
  const double gy = std::clamp((y - g.y0) / g.step, 0.0, static_cast<double>(values.rows - 1));
  const int j0 = std::min(static_cast<int>(gx), values.cols - 1);
  const int i0 = std::min(static_cast<int>(gy), values.rows - 1);
  const int j1 = std::min(j0 + 1, values.cols - 1), i1 = std::min(i0 + 1, values.rows - 1);
  const double tx = gx - j0, ty = gy - i0;
  const double top = (1 - tx) * values.at<float>(i0, j0) + tx * values.at<float>(i0, j1);
  const double bot = (1 - tx) * values.at<float>(i1, j0) + tx * values.at<float>(i1, j1);
  return (1 - ty) * top + ty * bot;
}

/// The predictor of the next pass: a field's u and v as ny x nx CV_32F grids, smoothed
/// as the options say (predictor_smoothing 0: as they are).
void smoothed_predictor(const VectorField& f, const PivOptions& opt, cv::Mat& pred_u, cv::Mat& pred_v) {
  const int nx = static_cast<int>(f.nx()), ny = static_cast<int>(f.ny());
  pred_u = cv::Mat(ny, nx, CV_32F, const_cast<float*>(f.u_px.data())).clone();
  pred_v = cv::Mat(ny, nx, CV_32F, const_cast<float*>(f.v_px.data())).clone();
  if (opt.predictor_smoothing <= 0) return;
  if (opt.predictor_fit == PredictorFit::kGaussian) {
    cv::GaussianBlur(pred_u, pred_u, cv::Size(0, 0), opt.predictor_smoothing, 0, cv::BORDER_REPLICATE);
    cv::GaussianBlur(pred_v, pred_v, cv::Size(0, 0), opt.predictor_smoothing, 0, cv::BORDER_REPLICATE);
    return;
  }
  const std::vector<double> w = quadratic_fit_weights(opt.predictor_fit_half_width());
  const cv::Mat k(static_cast<int>(w.size()), 1, CV_64F, const_cast<double*>(w.data()));
  cv::sepFilter2D(pred_u, pred_u, -1, k, k, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  cv::sepFilter2D(pred_v, pred_v, -1, k, k, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
}

/// Fraction of masked pixels in a window, from an integral image of (mask != 0).
double masked_fraction(const cv::Mat& integral, int x, int y, int w) {
  if (integral.empty()) return 0.0;
  const double s = integral.at<double>(y + w, x + w) - integral.at<double>(y, x + w) -
                   integral.at<double>(y + w, x) + integral.at<double>(y, x);
  return s / (static_cast<double>(w) * w);
}

/// Per image row, the merged pixel spans of the unmasked windows of grid g.
RowSpans window_spans(const Grid& g, cv::Size size, const std::vector<std::uint8_t>& masked) {
  RowSpans spans(static_cast<std::size_t>(size.height));
  std::vector<std::pair<int, int>> row, merged;
  for (int i = 0; i < g.ny; ++i) {
    row.clear();
    for (int j = 0; j < g.nx; ++j) {
      if (masked[static_cast<std::size_t>(i) * static_cast<std::size_t>(g.nx) + static_cast<std::size_t>(j)]) continue;
      const int from = j * g.step, to = from + g.window;
      if (!row.empty() && from <= row.back().second) row.back().second = to;
      else row.emplace_back(from, to);
    }
    if (row.empty()) continue;
    for (int y = i * g.step; y < i * g.step + g.window && y < size.height; ++y) {
      auto& s = spans[static_cast<std::size_t>(y)];
      merged.clear();
      std::merge(s.begin(), s.end(), row.begin(), row.end(), std::back_inserter(merged));
      s.clear();
      for (const auto& iv : merged) {
        if (!s.empty() && iv.first <= s.back().second) s.back().second = std::max(s.back().second, iv.second);
        else s.push_back(iv);
      }
    }
  }
  return spans;
}

cv::Mat mask_integral(const cv::Mat& mask) {
  if (mask.empty()) return {};
  cv::Mat binary, integral;
  cv::compare(mask, 0, binary, cv::CMP_NE);  // 255 where masked
  binary.convertTo(binary, CV_8U, 1.0 / 255.0);
  cv::integral(binary, integral, CV_64F);
  return integral;
}

void check_image(const cv::Mat& m, const char* which) {
  if (m.empty()) throw InputError(fmt::format("PIV: image {} is empty", which));
  if (m.channels() != 1)
    throw InputError(fmt::format("PIV: image {} has {} channels; expected a grey image", which,
                                 m.channels()));
  if (m.depth() != CV_8U && m.depth() != CV_16U && m.depth() != CV_32F)
    throw InputError(fmt::format("PIV: image {} has an unsupported sample type; expected 8-bit, "
                                 "16-bit or float",
                                 which));
}

}  // namespace

namespace {
/// Per-thread buffers of process(): images, spline coefficients, deformed frames.
struct PairScratch {
  cv::Mat A, B, coef_a, coef_b, transposed, deformed_a, deformed_b;
};
PairScratch& pair_scratch() {
  static thread_local PairScratch s;
  return s;
}
void unit_float_into(const cv::Mat& image, cv::Mat& out) {
  const double scale = image.depth() == CV_8U ? 1.0 / 255.0 : image.depth() == CV_16U ? 1.0 / 65535.0 : 1.0;
  image.convertTo(out, CV_32F, scale);
}
}  // namespace

namespace {
/// Coarse displacement field for the first pass's range check: the pair at half
/// resolution (pyrDown: coarse pixel (i, j) is centred on full pixel (2i, 2j)),
/// templates of t = w0/2 coarse px of A (w0 px of the image, the first window's
/// footprint) side by side, each found in B within +-t coarse px (+-w0 px of the
/// image) by zero-mean normalised cross-correlation (cv::matchTemplate): unlike the
/// first pass's FFT correlation of two w0 windows (which loses most pairs beyond
/// w0/4 and aliases beyond w0/2), no pairs leave the template, so a displacement of
/// a whole first window still peaks at full height. Integer
/// coarse pixels (2 px of the image); the first pass refines. A template is masked
/// when its centre is, or more than half its pixels are, masked in A or B; masked
/// pixels take the template's (or the search region's) unmasked mean. A peak below
/// kMinCoarsePeak or on the search border is unmatched (kInvalid). Returns full-image px.
constexpr double kMinCoarsePeak = 0.5;
/// A pair whose coarse estimate matches fewer than this fraction of its textured
/// templates (and at least kMinCoarseTemplates are textured) is refused: every
/// vector invalid. Measured matched fractions: 0 % for uniform shifts beyond the
/// search (synthetic beads, 64-120 px with 64 px first windows: every first-pass
/// vector there was a wrong match at about zero, half of them flagged valid); 62 % or
/// more on every real recording tried (PIVlab sand 0->3 with its decorrelated
/// avalanche, the OpenPIV tutorial pair, Oseen, the PIVlab jet).
constexpr double kMinCoarseMatched = 0.25;
constexpr std::size_t kMinCoarseTemplates = 4;
struct CoarseField {
  VectorField field;
  std::size_t textured = 0;  ///< templates neither masked nor blank
  std::size_t matched = 0;   ///< of those, peaks >= kMinCoarsePeak inside the search
};
CoarseField coarse_field(const cv::Mat& a_in, const cv::Mat& b_in, const cv::Mat& mask_a,
                         const cv::Mat& mask_b, int w0) {
  const cv::Size half((a_in.cols + 1) / 2, (a_in.rows + 1) / 2);
  const int t = w0 / 2, step = t, r = t;
  CoarseField out;
  VectorField& f = out.field;
  if (half.width < t + 2 || half.height < t + 2) return out;
  cv::Mat a, b;
  auto down = [&](const cv::Mat& in, cv::Mat& dst) {
    cv::Mat u;
    unit_float_into(in, u);
    cv::pyrDown(u, dst, half);
  };
  down(a_in, a);
  down(b_in, b);
  // A coarse pixel is masked when any full pixel of its 3x3 neighbourhood is.
  cv::Mat mask;
  for (const cv::Mat* m : {&mask_a, &mask_b})
    if (!m->empty()) {
      cv::Mat grown, h;
      cv::dilate(*m, grown, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
      cv::resize(grown, h, half, 0, 0, cv::INTER_NEAREST);
      if (mask.empty()) mask = h;
      else cv::bitwise_or(mask, h, mask);
    }
  const int nx = (half.width - t) / step + 1, ny = (half.height - t) / step + 1;
  f.x_px.resize(static_cast<std::size_t>(nx));
  f.y_px.resize(static_cast<std::size_t>(ny));
  for (int j = 0; j < nx; ++j) f.x_px[static_cast<std::size_t>(j)] = 2.0 * (j * step + 0.5 * (t - 1));
  for (int i = 0; i < ny; ++i) f.y_px[static_cast<std::size_t>(i)] = 2.0 * (i * step + 0.5 * (t - 1));
  f.resize_to_grid();
  // Masked pixels of a patch take the mean of its unmasked ones.
  auto fill_masked = [&](cv::Mat& patch, const cv::Rect& roi) {
    if (mask.empty()) return true;
    const cv::Mat m = mask(roi);
    const int n_masked = cv::countNonZero(m);
    if (2 * n_masked > m.rows * m.cols) return false;
    if (n_masked > 0) patch.setTo(cv::mean(patch, m == 0), m);
    return true;
  };
  std::size_t textured = 0, matched = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : textured, matched)
  for (int i = 0; i < ny; ++i) {
    cv::Mat tpl, reg, res;
    for (int j = 0; j < nx; ++j) {
      const std::size_t k = f.index(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
      const int x = j * step, y = i * step;
      const cv::Rect troi(x, y, t, t);
      if (!mask.empty() && mask.at<std::uint8_t>(y + t / 2, x + t / 2)) {
        f.flag[k] = VectorFlag::kMasked;
        continue;
      }
      const int x0 = std::max(0, x - r), y0 = std::max(0, y - r);
      const int x1 = std::min(half.width, x + t + r), y1 = std::min(half.height, y + t + r);
      const cv::Rect sroi(x0, y0, x1 - x0, y1 - y0);
      a(troi).copyTo(tpl);
      b(sroi).copyTo(reg);
      if (!fill_masked(tpl, troi) || !fill_masked(reg, sroi)) {
        f.flag[k] = VectorFlag::kMasked;
        continue;
      }
      cv::Scalar mean, sd;
      cv::meanStdDev(tpl, mean, sd);
      if (sd[0] < 1e-4) {
        f.flag[k] = VectorFlag::kInvalid;
        continue;
      }
      cv::matchTemplate(reg, tpl, res, cv::TM_CCOEFF_NORMED);
      double best = 0;
      cv::Point at;
      cv::minMaxLoc(res, nullptr, &best, nullptr, &at);
      f.peak[k] = static_cast<float>(best);
      // A peak on the search border may lie beyond it.
      const bool border = (at.x == 0 && x0 > 0) || (at.y == 0 && y0 > 0) ||
                          (at.x == res.cols - 1 && x1 < half.width) || (at.y == res.rows - 1 && y1 < half.height);
      f.flag[k] = best >= kMinCoarsePeak && !border ? VectorFlag::kValid : VectorFlag::kInvalid;
      ++textured;
      matched += f.flag[k] == VectorFlag::kValid;
      f.u_px[k] = static_cast<float>(2 * (x0 + at.x - x));
      f.v_px[k] = static_cast<float>(2 * (y0 + at.y - y));
    }
  }
  out.textured = textured;
  out.matched = matched;
  return out;
}

}  // namespace

cv::Mat to_unit_float(const cv::Mat& image) {
  cv::Mat f;
  unit_float_into(image, f);
  return f;
}

PivEngine::PivEngine(PivOptions options) : opt_(std::move(options)) {
  opt_.validate();
  for (int w : opt_.windows_px) {
    bool have = false;
    for (const auto& c : correlators_) have |= c->window() == w;
    if (!have) correlators_.push_back(std::make_unique<Correlator>(w));
  }
}

PivEngine::~PivEngine() = default;

const Correlator& PivEngine::correlator(int window_px) const {
  for (const auto& c : correlators_)
    if (c->window() == window_px) return *c;
  throw InternalError(fmt::format("no correlator for window {}", window_px));
}

void PivEngine::final_grid(cv::Size size, std::vector<double>& x_px, std::vector<double>& y_px) const {
  const Grid g = make_grid(size, opt_.windows_px.back(), opt_.step_px(opt_.windows_px.size() - 1));
  x_px.resize(static_cast<std::size_t>(std::max(g.nx, 0)));
  y_px.resize(static_cast<std::size_t>(std::max(g.ny, 0)));
  for (int j = 0; j < g.nx; ++j) x_px[static_cast<std::size_t>(j)] = g.x0 + j * g.step;
  for (int i = 0; i < g.ny; ++i) y_px[static_cast<std::size_t>(i)] = g.y0 + i * g.step;
}

PivResult PivEngine::process(const cv::Mat& a_in, const cv::Mat& b_in, const cv::Mat& mask_a,
                             const cv::Mat& mask_b) const {
  // Step 1: check and convert the inputs.
  check_image(a_in, "A");
  check_image(b_in, "B");
  if (a_in.size() != b_in.size())
    throw InputError(fmt::format("PIV: images differ in size: A is {}x{}, B is {}x{}",
                                 a_in.cols, a_in.rows, b_in.cols, b_in.rows));
  for (const cv::Mat* m : {&mask_a, &mask_b})
    if (!m->empty() && (m->size() != a_in.size() || m->type() != CV_8U))
      throw InputError(fmt::format("PIV: mask must be 8-bit and {}x{} like the images",
                                   a_in.cols, a_in.rows));
  const cv::Size size = a_in.size();
  const int w0 = opt_.windows_px.front();
  if (size.width < w0 || size.height < w0)
    throw InputError(fmt::format("PIV: images of {}x{} px are smaller than the first window "
                                 "({} px)",
                                 size.width, size.height, w0));
  // Step 0: the coarse estimate.
  PivResult result;
  cv::Mat pred_u, pred_v;  // predictor on the previous grid (CV_32F)
  Grid prev;
  bool have_predictor = false;
  if (opt_.coarse_estimate && w0 >= 16) {
    CoarseField coarse = coarse_field(a_in, b_in, mask_a, mask_b, w0);
    VectorField& cf = coarse.field;
    if (coarse.textured >= kMinCoarseTemplates)
      result.coarse_matched_fraction = static_cast<double>(coarse.matched) / static_cast<double>(coarse.textured);
    if (cf.size() > 0) {
      flag_outliers(cf, opt_);
      double dmax = 0.0;
      for (std::size_t k = 0; k < cf.size(); ++k)
        if (cf.flag[k] == VectorFlag::kValid)
          dmax = std::max(dmax, std::hypot(static_cast<double>(cf.u_px[k]), static_cast<double>(cf.v_px[k])));
      result.coarse_max_displacement_px = dmax;
      if (dmax > 0.25 * w0) {
        // The coarse field, gap-filled (masked windows too), is the first pass's predictor.
        fill_holes(cf, {VectorFlag::kReplaced, VectorFlag::kInvalid, VectorFlag::kMasked});
        smoothed_predictor(cf, opt_, pred_u, pred_v);
        prev.window = w0;
        prev.nx = static_cast<int>(cf.nx());
        prev.ny = static_cast<int>(cf.ny());
        prev.step = w0;  // coarse templates side by side: w0/2 coarse px = w0 px apart
        prev.x0 = cf.x_px.front();
        prev.y0 = cf.y_px.front();
        have_predictor = true;
        result.coarse_predictor = true;
      }
    }
  }
  // Large buffers are kept per thread and reused from pair to pair (fewer page faults).
  PairScratch& sc = pair_scratch();
  unit_float_into(a_in, sc.A);
  unit_float_into(b_in, sc.B);
  const cv::Mat A = sc.A, B = sc.B;
  // Interpolation coefficients (B-spline prefilter) once per pair, reused by every pass.
  cv::Mat& coef_a = sc.coef_a;
  cv::Mat& coef_b = sc.coef_b;
  cv::Mat& deformed_a = sc.deformed_a;  // reused by every pass (never aliases A, B or coef_*)
  cv::Mat& deformed_b = sc.deformed_b;
  if (opt_.deform &&
      (have_predictor || opt_.windows_px.size() + static_cast<std::size_t>(opt_.final_pass_repeats) > 1)) {
    interpolation_coefficients(A, opt_.interpolation, coef_a, sc.transposed);
    interpolation_coefficients(B, opt_.interpolation, coef_b, sc.transposed);
  }
  const cv::Mat ia = mask_integral(mask_a), ib = mask_integral(mask_b);
  // Inside a window, pixels masked in either frame are blanked in both, so that no
  // pattern is visible in one window and hidden in the other.
  cv::Mat mask_ab;
  if (!mask_a.empty() && !mask_b.empty()) cv::bitwise_or(mask_a, mask_b, mask_ab);
  else mask_ab = mask_a.empty() ? mask_b : mask_a;

  // Pass schedule: every window, then the final one repeated.
  std::vector<std::size_t> schedule;
  for (std::size_t p = 0; p < opt_.windows_px.size(); ++p) schedule.push_back(p);
  for (int r = 0; r < opt_.final_pass_repeats; ++r) schedule.push_back(opt_.windows_px.size() - 1);

  VectorField f;
  for (std::size_t s = 0; s < schedule.size(); ++s) {
    const std::size_t pass = schedule[s];
    // Without a coarse predictor the first pass searches the whole correlation plane
    // and skips the peak tests; with one it is deformed like the later passes.
    const bool first = s == 0 && !have_predictor;
    const Grid g = make_grid(size, opt_.windows_px[pass], opt_.step_px(pass));

    // Step 2: the deformed images (symmetric, by half the predictor each).
    // Every pass uses the configured interpolation: a bilinear predictor pass leaves a
    // bias (-0.05 px at half-pixel shifts) that the final passes only partly remove
    // (measured: -0.012 px after 16 + 16 px passes).
    // (Fresh outputs each pass: deform_pair must never write into its inputs, which
    // for bilinear and Keys interpolation are A and B themselves.)
    // Masked windows (centre masked, or too much of the window masked in A or B) are
    // never correlated. The centre of an even window lies between pixels: it is masked
    // if any of the (up to four) pixels around it is.
    std::vector<std::uint8_t> masked(static_cast<std::size_t>(g.nx) * static_cast<std::size_t>(g.ny), 0);
    bool any_masked = false;
    if (!mask_a.empty() || !mask_b.empty())
      for (int i = 0; i < g.ny; ++i)
        for (int j = 0; j < g.nx; ++j) {
          const int x = j * g.step, y = i * g.step;
          const double cx = g.x0 + j * g.step, cy = g.y0 + i * g.step;
          bool centre_masked = false;
          for (int ci : {static_cast<int>(std::floor(cy)), static_cast<int>(std::ceil(cy))})
            for (int cj : {static_cast<int>(std::floor(cx)), static_cast<int>(std::ceil(cx))})
              centre_masked |= (!mask_a.empty() && mask_a.at<std::uint8_t>(ci, cj)) ||
                               (!mask_b.empty() && mask_b.at<std::uint8_t>(ci, cj));
          const bool m = centre_masked || masked_fraction(ia, x, y, g.window) > opt_.mask_fraction ||
                         masked_fraction(ib, x, y, g.window) > opt_.mask_fraction;
          masked[static_cast<std::size_t>(i) * static_cast<std::size_t>(g.nx) + static_cast<std::size_t>(j)] = m;
          any_masked |= m;
        }
    cv::Mat Ad, Bd;
    if (!first && opt_.deform) {
      // Only the pixels of unmasked windows are deformed (outside the cup and on the
      // vane nothing is read).
      RowSpans spans;
      if (any_masked) spans = window_spans(g, size, masked);
      deform_pair(coef_a, coef_b, pred_u, pred_v, prev.x0, prev.y0, prev.step, opt_.interpolation,
                  deformed_a, deformed_b, any_masked ? &spans : nullptr);
      Ad = deformed_a;
      Bd = deformed_b;
    } else {
      Ad = A;
      Bd = B;
    }

    // Step 3: correlate every window.
    f = VectorField{};
    f.x_px.resize(static_cast<std::size_t>(g.nx));
    f.y_px.resize(static_cast<std::size_t>(g.ny));
    for (int j = 0; j < g.nx; ++j) f.x_px[static_cast<std::size_t>(j)] = g.x0 + j * g.step;
    for (int i = 0; i < g.ny; ++i) f.y_px[static_cast<std::size_t>(i)] = g.y0 + i * g.step;
    f.resize_to_grid();
    const Correlator& corr = correlator(g.window);
    const int W = g.window;
    const int radius = first ? W / 2 - 1
                             : std::max(2, static_cast<int>(std::lround(opt_.restricted_search * W)));
    const float min_var = static_cast<float>(opt_.min_window_std * opt_.min_window_std);

#pragma omp parallel
    {
      Workspace ws(W);
#pragma omp for schedule(dynamic, 1)
      for (int i = 0; i < g.ny; ++i) {
        for (int j = 0; j < g.nx; ++j) {
          const std::size_t k = f.index(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
          const int x = j * g.step, y = i * g.step;  // window origin
          const double cx = f.x_px[static_cast<std::size_t>(j)], cy = f.y_px[static_cast<std::size_t>(i)];
          if (masked[static_cast<std::size_t>(i) * static_cast<std::size_t>(g.nx) + static_cast<std::size_t>(j)]) {
            f.flag[k] = VectorFlag::kMasked;
            continue;
          }
          // Predictor at the window centre; without deformation, integer offsets.
          double pu = 0, pv = 0;
          int oax = 0, oay = 0, obx = 0, oby = 0;
          if (!first) {
            pu = sample_grid(pred_u, prev, cx, cy);
            pv = sample_grid(pred_v, prev, cx, cy);
            if (!opt_.deform) {
              const int ru = static_cast<int>(std::lround(pu)), rv = static_cast<int>(std::lround(pv));
              oax = -(ru / 2);
              oay = -(rv / 2);
              obx = ru + oax;
              oby = rv + oay;
              pu = ru;
              pv = rv;
            }
          }
          // Extract the windows (clamped at the image border).
          auto extract = [&](const cv::Mat& img, const cv::Mat& mask, int ox, int oy, float* dst) {
            double sum = 0;
            int n = 0;
            const bool interior = x + ox >= 0 && y + oy >= 0 && x + ox + W <= size.width &&
                                  y + oy + W <= size.height;
            for (int r = 0; r < W; ++r) {
              if (interior) {
                std::copy_n(img.ptr<float>(y + oy + r) + x + ox, W, dst + r * W);
                continue;
              }
              const int yy = std::clamp(y + oy + r, 0, size.height - 1);
              const float* src = img.ptr<float>(yy);
              for (int c = 0; c < W; ++c) {
                const int xx = std::clamp(x + ox + c, 0, size.width - 1);
                dst[r * W + c] = src[xx];
              }
            }
            if (mask.empty()) return;
            // Masked pixels take the mean of the unmasked ones.
            for (int r = 0; r < W; ++r) {
              const int yy = std::clamp(y + oy + r, 0, size.height - 1);
              const std::uint8_t* mrow = mask.ptr<std::uint8_t>(yy);
              for (int c = 0; c < W; ++c)
                if (!mrow[std::clamp(x + ox + c, 0, size.width - 1)]) {
                  sum += dst[r * W + c];
                  ++n;
                }
            }
            const float mean = n ? static_cast<float>(sum / n) : 0.0f;
            for (int r = 0; r < W; ++r) {
              const int yy = std::clamp(y + oy + r, 0, size.height - 1);
              const std::uint8_t* mrow = mask.ptr<std::uint8_t>(yy);
              for (int c = 0; c < W; ++c)
                if (mrow[std::clamp(x + ox + c, 0, size.width - 1)]) dst[r * W + c] = mean;
            }
          };
          extract(Ad, mask_ab, oax, oay, ws.a());
          extract(Bd, mask_ab, obx, oby, ws.b());
          // Correlate; a window whose intensity variance is below min_window_std^2 has no
          // texture (blank, saturated) and is invalid.
          if (!corr.correlate(ws, min_var)) {
            f.flag[k] = VectorFlag::kInvalid;
            continue;
          }
          const Peak pk = find_peak(ws.corr(), W, radius, opt_.subpixel);
          f.peak[k] = pk.height;
          f.peak_ratio[k] = pk.ratio;
          // In the first pass a correct peak is lowered by the loss of pairs (about
          // (1 - |dx|/W)(1 - |dy|/W)) and by the gradients a large window spans, and
          // quasi-periodic textures (bead packings) give strong second peaks, so the
          // height and ratio tests apply after deformation only.
          // The height test with a relative threshold waits for the whole pass (below).
          const bool weak = !first && ((opt_.min_peak_relative <= 0 && pk.height < opt_.min_peak) ||
                                       pk.ratio < opt_.min_peak_ratio);
          if (!pk.found || weak) {
            f.flag[k] = VectorFlag::kInvalid;
            continue;
          }
          double dx = pk.dx, dy = pk.dy;
          if (!first && opt_.deform && opt_.residual == Residual::kGradient &&
              pk.sigma_px >= kMinGradientPeakSigmaPx) {
            // A broad peak (beads, coarse textures) finds the residual's basin; the
            // gradient step measures it without the peak's pull towards zero. Outside a
            // pixel of the peak the linear step is not trusted, nor where the texture has
            // no gradient across one direction. Sharp peaks (seeded particles) keep the
            // peak's fit: unbiased there, and less noisy than the gradient step.
            const GradientStep gs = gradient_step(ws.a(), ws.b(), W);
            if (gs.ok && gs.conditioning >= kMinGradientConditioning &&
                std::abs(gs.dx - pk.dx) <= 1.0 && std::abs(gs.dy - pk.dy) <= 1.0) {
              dx = gs.dx;
              dy = gs.dy;
            }
          }
          f.u_px[k] = static_cast<float>(pu + dx);
          f.v_px[k] = static_cast<float>(pv + dy);
        }
      }
    }

    if (s == 0 && f.count(VectorFlag::kMasked) == f.size())
      throw InputError("PIV: the mask covers every interrogation window; nothing to measure");

    // Peak-height test relative to the recording: min(min_peak, relative x the median
    // peak of this pass's matched windows). Seeded-particle recordings peak lower
    // (0.6-0.7 on the OpenPIV tutorial pair) than bead or sand textures (0.9-1.0), so
    // one absolute height either empties the first or keeps outliers in the second.
    // A pass whose matches are ambiguous (median first/second peak ratio below
    // kCleanPeakRatio) keeps the absolute min_peak: an aliased pass (every window
    // wrong) also has low peaks (median 0.30, ratio 1.6 for a shift of 0.6 windows),
    // while real recordings have median ratios of 3.3-8 (tutorial pair, Oseen,
    // Karman, PIVlab jet and sand).
    constexpr double kCleanPeakRatio = 2.5;
    double peak_threshold = first ? 0.0 : opt_.min_peak;
    if (!first && opt_.min_peak_relative > 0) {
      std::vector<float> peaks, ratios;
      peaks.reserve(f.size());
      ratios.reserve(f.size());
      for (std::size_t k = 0; k < f.size(); ++k)
        if (f.flag[k] == VectorFlag::kValid) {
          peaks.push_back(f.peak[k]);
          ratios.push_back(f.peak_ratio[k]);
        }
      if (!peaks.empty() && core::upper_median_inplace(ratios) >= kCleanPeakRatio)
        peak_threshold = std::min(opt_.min_peak, opt_.min_peak_relative * core::upper_median_inplace(peaks));
      for (std::size_t k = 0; k < f.size(); ++k)
        if (f.flag[k] == VectorFlag::kValid && f.peak[k] < peak_threshold) f.flag[k] = VectorFlag::kInvalid;
    }

    // Step 4: validate and fill.
    flag_outliers(f, opt_);
    fill_holes(f, {VectorFlag::kReplaced, VectorFlag::kInvalid, VectorFlag::kMasked});

    PassReport rep;
    rep.window_px = g.window;
    rep.step_px = g.step;
    rep.nx = static_cast<std::size_t>(g.nx);
    rep.ny = static_cast<std::size_t>(g.ny);
    rep.peak_threshold = peak_threshold;
    rep.valid = f.count(VectorFlag::kValid);
    rep.replaced = f.count(VectorFlag::kReplaced);
    rep.masked = f.count(VectorFlag::kMasked);
    rep.invalid = f.count(VectorFlag::kInvalid);
    result.passes.push_back(rep);

    // Step 5: the predictor for the next pass (smoothed copy).
    smoothed_predictor(f, opt_, pred_u, pred_v);
    prev = g;
  }

  // Replacements count only where they are interpolations between measurements.
  demote_unsupported_replacements(f);
  // A window whose samples lie mostly outside the frame (the displacement carries
  // its pattern out of the image: clamped border pixels correlate with nothing) is
  // not a measurement: A is read at x - d/2 and B at x + d/2 over the final window.
  {
    const double W = opt_.windows_px.back();
    auto inside = [&](double c, double shift, int extent) {
      const double lo = c - 0.5 * (W - 1) + shift, hi = c + 0.5 * (W - 1) + shift;
      return std::clamp((std::min(hi, extent - 1.0) - std::max(lo, 0.0) + 1.0) / W, 0.0, 1.0);
    };
    for (std::size_t i = 0; i < f.ny(); ++i)
      for (std::size_t j = 0; j < f.nx(); ++j) {
        const std::size_t k = f.index(i, j);
        if (f.flag[k] != VectorFlag::kValid && f.flag[k] != VectorFlag::kReplaced) continue;
        const double hu = 0.5 * f.u_px[k], hv = 0.5 * f.v_px[k];
        const double in_a = inside(f.x_px[j], -hu, size.width) * inside(f.y_px[i], -hv, size.height);
        const double in_b = inside(f.x_px[j], hu, size.width) * inside(f.y_px[i], hv, size.height);
        if (std::min(in_a, in_b) < kMinInsideFraction) f.flag[k] = VectorFlag::kInvalid;
      }
  }
  // A pair whose coarse estimate matched almost nothing within +-1 first window is
  // refused: its displacement exceeds what the passes can see (or the frames are
  // unrelated), and what the first pass found there is a chance or static match.
  if (result.coarse_matched_fraction < kMinCoarseMatched) {
    result.coarse_refused = true;
    for (std::size_t k = 0; k < f.size(); ++k)
      if (f.flag[k] != VectorFlag::kMasked) f.flag[k] = VectorFlag::kInvalid;
  }
  // Masked vectors are not measurements: zero them.
  for (std::size_t k = 0; k < f.size(); ++k)
    if (f.flag[k] == VectorFlag::kMasked) f.u_px[k] = f.v_px[k] = 0.0f;
  result.field = std::move(f);
  return result;
}

}  // namespace shearzone::piv
