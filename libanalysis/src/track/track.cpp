// Bead tracking between two frames (track/track.hpp).
#include "shearzone/track/track.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/core/point_cells.hpp"

namespace shearzone::track {
namespace {

/// The window of a bead: three quarters of its diameter, odd, at least 7 px: the bead's
/// own image. A window one diameter wide takes in the neighbours' edges, which move
/// otherwise where the field turns: on 64 px beads rotating at 0.004 rad per frame the
/// bias was 0.014 px (0.75 d: 0.005 px; 0.5 d: 0.001-0.006 px but an RMS up to 0.035 px
/// at 16 px; tests/track/test_track.cpp).
int window_px(double d) { return std::max(7, 2 * static_cast<int>(std::lround(0.375 * d)) + 1); }

/// Near a mask or the image's edge a bead's window shrinks to stay clear of it (static
/// pixels of a wall or a vane in the window would pull the bead towards their motion),
/// down to this half-width.
constexpr int kMinHalfWindowPx = 3;

/// The half-width of the window of a bead whose neighbour, at nn < d, overlaps it in
/// projection: the window's corners stay inside the neighbour's edge (its square within
/// nn - d/2 of the centre along the diagonal), at least kMinHalfWindowPx. The overlap's
/// edge moves with the neighbour: in the 3/4-bead window it pulled each bead's
/// displacement towards its neighbours', and a known random velocity of beads at 0.85 d
/// read 3 % low (uniform field, 16 px, 7 000 beads; 1.8 % low with this window).
int overlap_half_window(double nn, double d) {
  return std::max(kMinHalfWindowPx, static_cast<int>(std::floor((nn - 0.5 * d) / std::numbers::sqrt2)));
}

/// Frames as LK takes them: 8-bit (16-bit scaled by 1/256).
cv::Mat as_8bit(const cv::Mat& m) {
  if (m.type() == CV_8UC1) return m;
  if (m.type() == CV_16UC1) {
    cv::Mat out;
    m.convertTo(out, CV_8U, 1.0 / 256.0);
    return out;
  }
  throw InputError(fmt::format("track: frames must be 8- or 16-bit grey (OpenCV type {})", m.type()));
}

/// The distance from points to the nearest masked pixel or beyond the image's edge, px,
/// up to a cap: how wide a window centred there may be and stay clear of both. The
/// Euclidean distance between pixel centres, as OpenCV's exact distance transform gives
/// it, but only where asked: a transform of the whole frame, twice a pair, cost more
/// than the rest of the detection (26 ms a 1080p frame).
class Clearance {
 public:
  Clearance(const cv::Mat& mask, cv::Size size, int cap) : mask_(mask), size_(size), cap_(cap) {
    if (!mask.empty() && (mask.size() != size || mask.type() != CV_8UC1))
      throw InputError(fmt::format("track: a mask of {}x{} px (OpenCV type {}) for a frame of {}x{}: expected an "
                                   "8-bit mask of the frame's size",
                                   mask.cols, mask.rows, mask.type(), size.width, size.height));
  }
  /// At the pixel nearest (x, y): min(distance to the edge, distance to a masked pixel, cap).
  float at(double x, double y) const {
    const int i = static_cast<int>(std::lround(y)), j = static_cast<int>(std::lround(x));
    if (i < 0 || j < 0 || i >= size_.height || j >= size_.width) return 0.0f;
    int best2 = cap_ * cap_;
    const int edge = std::min({i + 1, j + 1, size_.height - i, size_.width - j});
    best2 = std::min(best2, edge * edge);
    if (!mask_.empty()) {
      const int r = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(best2)))) - 1;
      for (int ii = std::max(0, i - r); ii <= std::min(size_.height - 1, i + r); ++ii) {
        const std::uint8_t* row = mask_.ptr<std::uint8_t>(ii);
        const int di2 = (ii - i) * (ii - i);
        if (di2 >= best2) continue;
        for (int jj = std::max(0, j - r); jj <= std::min(size_.width - 1, j + r); ++jj)
          if (row[jj]) best2 = std::min(best2, di2 + (jj - j) * (jj - j));
      }
    }
    return static_cast<float>(std::sqrt(static_cast<double>(best2)));
  }

 private:
  cv::Mat mask_;
  cv::Size size_;
  int cap_;
};

/// A detection needs this much clearance: a quarter bead, and room for the smallest window.
double min_clearance(double d) { return std::max(kMinHalfWindowPx + 0.5, 0.25 * d); }

/// Vertex of the parabola through (-1, a), (0, b), (1, c), clamped to +-0.5.
double parabola_vertex(double a, double b, double c) {
  const double den = a - 2 * b + c;
  if (!(den < 0)) return 0.0;
  return std::clamp(0.5 * (a - c) / den, -0.5, 0.5);
}

}  // namespace

void TrackOptions::validate() const {
  if (!(bead_diameter_px >= 3 && bead_diameter_px <= 200))
    throw ConfigError(fmt::format("track: bead diameter {} px: expected 3..200", bead_diameter_px));
  if (!(fb_tolerance_px > 0 && fb_tolerance_px <= 10))
    throw ConfigError(fmt::format("track: forward-backward tolerance {} px: expected > 0 and <= 10", fb_tolerance_px));
  if (pyramid_levels < 0 || pyramid_levels > 6)
    throw ConfigError(fmt::format("track: pyramid levels {}: expected 0..6", pyramid_levels));
  if (max_iterations < 1 || max_iterations > 10000)
    throw ConfigError(fmt::format("track: iterations {}: expected 1..10000", max_iterations));
  if (!(epsilon_px > 0 && epsilon_px < 1))
    throw ConfigError(fmt::format("track: epsilon {} px: expected 0 < e < 1", epsilon_px));
  if (!(std::isfinite(centre_offset_px.x) && std::isfinite(centre_offset_px.y) &&
        std::hypot(centre_offset_px.x, centre_offset_px.y) <= 0.5 * bead_diameter_px))
    throw ConfigError(fmt::format("track: centre offset {},{} px: expected within half a bead", centre_offset_px.x,
                                  centre_offset_px.y));
  if (!(min_contrast >= 0 && min_contrast < 1))
    throw ConfigError(fmt::format("track: minimum contrast {}: expected 0 <= c < 1", min_contrast));
}

core::Metadata TrackOptions::to_metadata() const {
  return {{"track_bead_diameter_px", fmt::format("{:.4g}", bead_diameter_px)},
          {"track_window_px", fmt::format("{} (smaller near what hides beads, the vane or a mask image, or the edge, "
                                          "down to {}: each bead's window stays clear of them)",
                                          window_px(bead_diameter_px), 2 * kMinHalfWindowPx + 1)},
          {"track_pyramid_levels", std::to_string(pyramid_levels)},
          {"track_fb_tolerance_px", fmt::format("{}", fb_tolerance_px)},
          {"track_lk", fmt::format("pyramidal Lucas-Kanade (OpenCV calcOpticalFlowPyrLK), at most {} iterations "
                                   "per level, stop below {} px",
                                   max_iterations, epsilon_px)},
          {"track_min_contrast", fmt::format("{}", min_contrast)},
          {"track_centre_offset_px", fmt::format("{:.3f},{:.3f} (from a bead's smoothed peak to its disc's centre)",
                                                 centre_offset_px.x, centre_offset_px.y)}};
}

std::size_t PairBeads::tracked() const {
  return static_cast<std::size_t>(std::count(ok.begin(), ok.end(), std::uint8_t{1}));
}

namespace {

/// Beads are looked for in the frame shrunk to the means of whole blocks of this many
/// pixels a side, as many as keep a bead kCoarseBeadPx across (35 px beads: blocks of 2,
/// 50 px: 4; below 24 px: the frame itself), each centre by a parabola through the
/// blocks. Smoothing, the two filters and the percentiles of a 1080p frame of 35 px
/// beads cost 70 ms on the whole frame; on blocks the centres lie 0.1-0.3 px from the
/// whole frame's (docs/track.md, step 2).
constexpr double kCoarseBeadPx = 12.0;
int coarse_factor(double d) { return std::max(1, static_cast<int>(std::floor(d / kCoarseBeadPx))); }

/// `mask` and `outside` together (either may be empty), checked against the frame.
cv::Mat masked_or_outside(const cv::Mat& mask, const cv::Mat& outside, cv::Size size) {
  if (outside.empty()) return mask;
  if (outside.size() != size || outside.type() != CV_8UC1)
    throw InputError(fmt::format("track: a region mask of {}x{} px (OpenCV type {}) for a frame of {}x{}: expected "
                                 "an 8-bit mask of the frame's size",
                                 outside.cols, outside.rows, outside.type(), size.width, size.height));
  if (mask.empty()) return outside;
  cv::Mat m;
  cv::bitwise_or(mask != 0, outside != 0, m);
  return m;
}

/// detect_beads on an 8-bit frame: `mask` the union of what hides beads and where none
/// counts (the frame's range leaves it out, centres may not lie in it), `clear` the
/// clearance from what hides beads only.
std::vector<cv::Point2d> detect_with_clearance(const cv::Mat& image8, const cv::Mat& mask, const Clearance& clear,
                                               const TrackOptions& o) {
  const double d = o.bead_diameter_px;
  const double sigma = d / 6.0;
  cv::Mat f;
  image8.convertTo(f, CV_32F);
  const int fac = coarse_factor(d);
  const cv::Size cs(f.cols / fac, f.rows / fac);
  if (cs.width < 3 || cs.height < 3) return {};
  // The frame in blocks (their means) and smoothed so that, with the blocks' own width,
  // it is smoothed by d/6 in all.
  cv::Mat c;
  if (fac == 1)
    c = f;
  else
    cv::resize(f(cv::Rect(0, 0, cs.width * fac, cs.height * fac)), c, cs, 0, 0, cv::INTER_AREA);
  const double sigma_c = std::sqrt(std::max(0.0, sigma * sigma - (fac * fac - 1) / 12.0)) / fac;
  cv::Mat s;
  cv::GaussianBlur(c, s, {0, 0}, sigma_c, sigma_c, cv::BORDER_REFLECT);
  // Local maxima and minima over a square of side 0.7 d: a square's max and min filters
  // are separable, so they cost O(d) a pixel where a disc's cost O(d^2) (detection of
  // 35 px beads in a 1080p frame: 0.21 s with a disc, 0.09 s with the square; the same
  // beads found on `bench track`'s pairs).
  const int k = 2 * static_cast<int>(std::lround(0.35 * d / fac)) + 1;
  const cv::Mat square = cv::getStructuringElement(cv::MORPH_RECT, {k, k});
  cv::Mat hi, lo;
  cv::dilate(s, hi, square);
  cv::erode(s, lo, square);

  // The frame's range is taken away from the masks and the edge: outside a square of a
  // quarter bead about each masked pixel and a band of a quarter bead along the edge
  // (the exact distance decides each bead below).
  const double mc = min_clearance(d);
  cv::Mat out(cs, CV_8U, cv::Scalar(0));
  if (!mask.empty()) {
    cv::Mat m = mask != 0;
    if (fac > 1) {
      cv::resize(m(cv::Rect(0, 0, cs.width * fac, cs.height * fac)), m, cs, 0, 0, cv::INTER_AREA);
      m = m != 0;
    }
    const int g = 2 * static_cast<int>(std::ceil(mc / fac)) + 1;
    cv::dilate(m, out, cv::getStructuringElement(cv::MORPH_RECT, {g, g}));
  }
  auto centre_px = [fac](int ic) { return ic * fac + 0.5 * (fac - 1); };  // a block's centre, full-frame px
  for (int i = 0; i < cs.height; ++i) {
    std::uint8_t* row = out.ptr<std::uint8_t>(i);
    const double y = centre_px(i);
    const bool band_y = std::min(y + 1, f.rows - y) < mc;
    for (int j = 0; j < cs.width; ++j) {
      const double x = centre_px(j);
      if (band_y || std::min(x + 1, f.cols - x) < mc) row[j] = 255;
    }
  }

  // The frame's range: 1st to 99th percentile of the smoothed frame where beads may lie
  // (order statistics by nth_element, not core::percentile: that sorts a copy of the
  // frame's millions of pixels, every frame).
  std::vector<float> vals;
  vals.reserve(s.total());
  for (int i = 0; i < s.rows; ++i) {
    const float* sv = s.ptr<float>(i);
    const std::uint8_t* ov = out.ptr<std::uint8_t>(i);
    for (int j = 0; j < s.cols; ++j)
      if (!ov[j]) vals.push_back(sv[j]);
  }
  if (vals.size() < 4) return {};
  auto pct = [&](double p) {
    auto it = vals.begin() + static_cast<std::ptrdiff_t>(p * static_cast<double>(vals.size() - 1));
    std::nth_element(vals.begin(), it, vals.end());
    return static_cast<double>(*it);
  };
  const double range = pct(0.99) - pct(0.01);
  const double min_contrast = std::max(1e-6, o.min_contrast * range);

  // Peaks, each centred to sub-pixel by a parabola through it and its neighbours (of the
  // shrunk frame: its blocks' centres are fac px apart).
  struct Peak {
    float value;
    int i, j;  // the nearest full-frame pixel
    double x, y;
  };
  std::vector<Peak> peaks;
  for (int i = 1; i < s.rows - 1; ++i)
    for (int j = 1; j < s.cols - 1; ++j) {
      const float v = s.at<float>(i, j);
      if (!(v == hi.at<float>(i, j) && v - lo.at<float>(i, j) >= min_contrast)) continue;
      const double x = centre_px(j) + fac * parabola_vertex(s.at<float>(i, j - 1), v, s.at<float>(i, j + 1)) +
                       o.centre_offset_px.x;
      const double y = centre_px(i) + fac * parabola_vertex(s.at<float>(i - 1, j), v, s.at<float>(i + 1, j)) +
                       o.centre_offset_px.y;
      const int pi = static_cast<int>(std::lround(y)), pj = static_cast<int>(std::lround(x));
      if (clear.at(pj, pi) < mc) continue;  // 0 off the frame: (pi, pj) is inside below
      if (!mask.empty() && mask.at<std::uint8_t>(pi, pj)) continue;
      peaks.push_back({v, pi, pj, x, y});
    }

  // Brightest first; a plateau or a second peak within half a bead of an accepted one
  // is the same bead.
  std::stable_sort(peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) { return a.value > b.value; });
  const double sep2 = 0.25 * d * d;
  const int cell = std::max(1, static_cast<int>(std::ceil(0.5 * d)));
  const int gx = f.cols / cell + 1, gy = f.rows / cell + 1;
  std::vector<std::vector<std::size_t>> grid(static_cast<std::size_t>(gx) * static_cast<std::size_t>(gy));
  std::vector<cv::Point2d> centres;
  for (const Peak& p : peaks) {
    const double x = p.x, y = p.y;
    const int ci = p.i / cell, cj = p.j / cell;
    bool taken = false;
    for (int di = -1; di <= 1 && !taken; ++di)
      for (int dj = -1; dj <= 1 && !taken; ++dj) {
        const int ii = ci + di, jj = cj + dj;
        if (ii < 0 || jj < 0 || ii >= gy || jj >= gx) continue;
        for (std::size_t q : grid[static_cast<std::size_t>(ii) * gx + jj]) {
          const double dx = centres[q].x - x, dy = centres[q].y - y;
          if (dx * dx + dy * dy < sep2) {
            taken = true;
            break;
          }
        }
      }
    if (taken) continue;
    grid[static_cast<std::size_t>(ci) * gx + cj].push_back(centres.size());
    centres.emplace_back(x, y);
  }
  // Raster order (top to bottom, then left to right): the output does not depend on
  // how equal peaks were sorted.
  std::sort(centres.begin(), centres.end(), [](const cv::Point2d& a, const cv::Point2d& b) {
    return a.y != b.y ? a.y < b.y : a.x < b.x;
  });
  return centres;
}

/// The clearance's cap for beads of d px: above anything a check asks of it.
int clearance_cap(double d) {
  return std::max((window_px(d) - 1) / 2 + 2, static_cast<int>(std::ceil(min_clearance(d))) + 1);
}

}  // namespace

std::vector<cv::Point2d> detect_beads(const cv::Mat& image, const cv::Mat& mask, const TrackOptions& o,
                                      const cv::Mat& outside) {
  o.validate();
  const cv::Mat image8 = as_8bit(image);
  const Clearance clear(mask, image8.size(), clearance_cap(o.bead_diameter_px));
  return detect_with_clearance(image8, masked_or_outside(mask, outside, image8.size()), clear, o);
}

cv::Point2d disc_centre_offset(const cv::Mat& image, const cv::Mat& mask, const TrackOptions& options) {
  TrackOptions o = options;
  o.centre_offset_px = {0.0, 0.0};
  const std::vector<cv::Point2d> peaks = detect_beads(image, mask, o);
  const double d = o.bead_diameter_px;
  // The mean image about the peaks (each at its nearest pixel), out to 0.9 d: the disc,
  // its rim and what lies past it; masked pixels left out, pixel by pixel.
  const int P = static_cast<int>(std::ceil(0.9 * d));
  const cv::Size patch(2 * P + 1, 2 * P + 1);
  const cv::Mat f = as_8bit(image);
  cv::Mat sum = cv::Mat::zeros(patch, CV_64F), count = cv::Mat::zeros(patch, CV_64F);
  int n = 0;
  for (const cv::Point2d& p : peaks) {
    const int i = static_cast<int>(std::lround(p.y)), j = static_cast<int>(std::lround(p.x));
    if (i < P || j < P || i >= f.rows - P || j >= f.cols - P) continue;
    const cv::Rect r(j - P, i - P, 2 * P + 1, 2 * P + 1);
    for (int a = 0; a < r.height; ++a) {
      const std::uint8_t* src = f.ptr<std::uint8_t>(r.y + a) + r.x;
      const std::uint8_t* msk = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(r.y + a) + r.x;
      double* s = sum.ptr<double>(a);
      double* c = count.ptr<double>(a);
      for (int b = 0; b < r.width; ++b)
        if (!msk || !msk[b]) s[b] += src[b], c[b] += 1.0;
    }
    ++n;
  }
  if (n < kMinOffsetBeads) return {0.0, 0.0};
  cv::Mat m(patch, CV_64F);
  for (int a = 0; a < m.rows; ++a)
    for (int b = 0; b < m.cols; ++b) {
      const double c = count.at<double>(a, b);
      if (c < 0.25 * n) return {0.0, 0.0};  // the beads' surroundings mostly masked
      m.at<double>(a, b) = sum.at<double>(a, b) / c;
    }
  auto at = [&m](double x, double y) {  // bilinear, inside the patch
    const int j = std::clamp(static_cast<int>(std::floor(x)), 0, m.cols - 2);
    const int i = std::clamp(static_cast<int>(std::floor(y)), 0, m.rows - 2);
    const double tx = x - j, ty = y - i;
    return (1 - ty) * ((1 - tx) * m.at<double>(i, j) + tx * m.at<double>(i, j + 1)) +
           ty * ((1 - tx) * m.at<double>(i + 1, j) + tx * m.at<double>(i + 1, j + 1));
  };
  // The circle of the bead's diameter centred at (P + ox, P + oy): points w inside it
  // against w outside. (Its radius fitted as well came out short: the circle hugged
  // the lit side, and the offset was half the truth on `synth beads`.)
  constexpr int kPoints = 64;
  const double r = 0.5 * d, w = std::max(1.0, d / 16.0);
  std::vector<cv::Point2d> inner(kPoints), outer(kPoints);  // the circle's points about its centre
  for (int k = 0; k < kPoints; ++k) {
    const double th = 2.0 * std::numbers::pi * k / kPoints, ux = std::cos(th), uy = std::sin(th);
    inner[k] = {(r - w) * ux, (r - w) * uy};
    outer[k] = {(r + w) * ux, (r + w) * uy};
  }
  auto separation = [&](double ox, double oy) {
    double s = 0.0;
    for (int k = 0; k < kPoints; ++k)
      s += at(P + ox + inner[k].x, P + oy + inner[k].y) - at(P + ox + outer[k].x, P + oy + outer[k].y);
    return s;
  };
  // Over offsets up to 0.35 d (within half a bead, as TrackOptions::validate asks) by 1/4
  // px, then by 1/50 px about the best.
  double best = -std::numeric_limits<double>::infinity(), bx = 0.0, by = 0.0;
  const double span = 0.35 * d;
  auto consider = [&](double ox, double oy) {
    if (std::hypot(ox, oy) > span) return;
    if (const double sc = separation(ox, oy); sc > best) best = sc, bx = ox, by = oy;
  };
  for (double oy = -span; oy <= span; oy += 0.25)
    for (double ox = -span; ox <= span; ox += 0.25) consider(ox, oy);
  const double cx = bx, cy = by;
  for (double oy = cy - 0.25; oy <= cy + 0.25; oy += 0.02)
    for (double ox = cx - 0.25; ox <= cx + 0.25; ox += 0.02) consider(ox, oy);
  return {bx, by};
}

PairBeads track_pair(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask_a, const cv::Mat& mask_b,
                     const TrackOptions& o, const cv::Mat& outside) {
  o.validate();
  if (a.size() != b.size()) throw InputError("track: the two frames differ in size");
  const cv::Mat a8 = as_8bit(a), b8 = as_8bit(b);
  const int cap = clearance_cap(o.bead_diameter_px);
  const Clearance clear_a(mask_a, a8.size(), cap), clear_b(mask_b, b8.size(), cap);
  const std::vector<cv::Point2d> centres =
      detect_with_clearance(a8, masked_or_outside(mask_a, outside, a8.size()), clear_a, o);
  PairBeads r;
  const std::size_t n = centres.size();
  for (const cv::Point2d& c : centres) {
    r.x_px.push_back(c.x);
    r.y_px.push_back(c.y);
  }
  r.u_px.assign(n, 0.0);
  r.v_px.assign(n, 0.0);
  r.fb_px.assign(n, std::numeric_limits<double>::quiet_NaN());
  r.ok.assign(n, 0);
  if (n == 0) return r;
  // Each bead's window: 3/4 of a bead, smaller where a mask or the edge is nearer (its
  // half-width at most the clearance less half a pixel). LK runs once per window size.
  const int h_full = (window_px(o.bead_diameter_px) - 1) / 2;
  std::vector<int> half(n);
  const double d = o.bead_diameter_px;
  const core::PointCells cells(r.x_px, r.y_px, d);
  for (std::size_t k = 0; k < n; ++k) {
    half[k] = std::min(h_full, static_cast<int>(std::floor(clear_a.at(r.x_px[k], r.y_px[k]) - 0.5)));
    double nn = d;  // the nearest other bead's centre, if nearer than a diameter
    cells.near(r.x_px[k], r.y_px[k], [&](std::size_t i) {
      if (i != k) nn = std::min(nn, std::hypot(r.x_px[i] - r.x_px[k], r.y_px[i] - r.y_px[k]));
    });
    if (nn < d - 0.5) half[k] = std::min(half[k], overlap_half_window(nn, d));  // overlapping by > 1/2 px
  }
  const cv::TermCriteria crit(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, o.max_iterations, o.epsilon_px);
  // Both frames' pyramids (with their derivatives) once, bordered for the widest window,
  // for every window size: LK would build them again for each.
  std::vector<cv::Mat> pyr_a, pyr_b;
  const cv::Size widest(2 * h_full + 1, 2 * h_full + 1);
  const int levels = cv::buildOpticalFlowPyramid(a8, pyr_a, widest, o.pyramid_levels, true);
  cv::buildOpticalFlowPyramid(b8, pyr_b, widest, o.pyramid_levels, true);
  for (int h = kMinHalfWindowPx; h <= h_full; ++h) {
    std::vector<std::size_t> group;
    for (std::size_t k = 0; k < n; ++k)
      if (half[k] == h) group.push_back(k);
    if (group.empty()) continue;
    std::vector<cv::Point2f> p, q, back;
    for (std::size_t k : group) p.emplace_back(static_cast<float>(r.x_px[k]), static_cast<float>(r.y_px[k]));
    std::vector<std::uint8_t> st, st_back;
    std::vector<float> err;
    cv::calcOpticalFlowPyrLK(pyr_a, pyr_b, p, q, st, err, {2 * h + 1, 2 * h + 1}, levels, crit);
    cv::calcOpticalFlowPyrLK(pyr_b, pyr_a, q, back, st_back, err, {2 * h + 1, 2 * h + 1}, levels, crit);
    for (std::size_t g = 0; g < group.size(); ++g) {
      const std::size_t k = group[g];
      if (!st[g] || !st_back[g]) continue;
      r.fb_px[k] = std::hypot(static_cast<double>(back[g].x) - p[g].x, static_cast<double>(back[g].y) - p[g].y);
      // The window at the end clear of mask b too (the vane has not moved over it).
      const bool clear = clear_b.at(q[g].x, q[g].y) >= h + 0.5;
      if (!(r.fb_px[k] <= o.fb_tolerance_px) || !clear) continue;
      r.u_px[k] = static_cast<double>(q[g].x) - p[g].x;
      r.v_px[k] = static_cast<double>(q[g].y) - p[g].y;
      r.ok[k] = 1;
    }
  }
  return r;
}

int grid_cell_px(double bead_diameter_px) {
  return std::max(2, static_cast<int>(std::lround(0.5 * bead_diameter_px)));
}

core::VectorField beads_to_grid(const PairBeads& beads, cv::Size size, int cell_px, const cv::Mat& mask_a) {
  if (cell_px < 1) throw ConfigError(fmt::format("track: grid cell {} px: expected >= 1", cell_px));
  core::VectorField f;
  const int nx = size.width / cell_px, ny = size.height / cell_px;
  for (int j = 0; j < nx; ++j) f.x_px.push_back(j * cell_px + 0.5 * (cell_px - 1));
  for (int i = 0; i < ny; ++i) f.y_px.push_back(i * cell_px + 0.5 * (cell_px - 1));
  f.resize_to_grid();
  std::vector<double> su(f.size(), 0.0), sv(f.size(), 0.0);
  std::vector<int> n_ok(f.size(), 0), n_all(f.size(), 0);
  for (std::size_t k = 0; k < beads.size(); ++k) {
    const int j = static_cast<int>(std::floor((beads.x_px[k] + 0.5) / cell_px));
    const int i = static_cast<int>(std::floor((beads.y_px[k] + 0.5) / cell_px));
    if (i < 0 || j < 0 || i >= ny || j >= nx) continue;
    const std::size_t c = f.index(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
    ++n_all[c];
    if (!beads.ok[k]) continue;
    su[c] += beads.u_px[k];
    sv[c] += beads.v_px[k];
    ++n_ok[c];
  }
  for (std::size_t i = 0; i < f.ny(); ++i)
    for (std::size_t j = 0; j < f.nx(); ++j) {
      const std::size_t c = f.index(i, j);
      f.peak[c] = 0.0f;
      f.peak_ratio[c] = 0.0f;
      const int yi = static_cast<int>(std::lround(f.y_px[i])), xj = static_cast<int>(std::lround(f.x_px[j]));
      const bool masked = !mask_a.empty() && mask_a.at<std::uint8_t>(yi, xj) != 0;
      if (masked || n_all[c] == 0) {
        f.flag[c] = core::VectorFlag::kMasked;
      } else if (n_ok[c] == 0) {
        f.flag[c] = core::VectorFlag::kInvalid;
      } else {
        f.u_px[c] = static_cast<float>(su[c] / n_ok[c]);
        f.v_px[c] = static_cast<float>(sv[c] / n_ok[c]);
        f.flag[c] = core::VectorFlag::kValid;
      }
    }
  return f;
}

Linker::Linker(double bead_diameter_px) : gate_px_(0.25 * bead_diameter_px) {
  if (!(bead_diameter_px > 0))
    throw ConfigError(fmt::format("track: bead diameter {} px: expected > 0", bead_diameter_px));
}

core::TrackedBeads Linker::link(const PairBeads& beads, std::int64_t frame_a, std::int64_t frame_b, double t_a_s,
                                double dt_s) {
  const std::size_t n = beads.size();
  core::TrackedBeads t;
  t.track_id.assign(n, -1);
  t.frame_a.assign(n, frame_a);
  t.frame_b.assign(n, frame_b);
  t.t_a_s.assign(n, t_a_s);
  t.dt_s.assign(n, dt_s);
  t.x_px = beads.x_px;
  t.y_px = beads.y_px;
  t.fb_px = beads.fb_px;
  t.tracked = beads.ok;
  t.linked.assign(n, 0);
  t.u_px.resize(n);
  t.v_px.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    t.u_px[k] = beads.ok[k] ? beads.u_px[k] : std::numeric_limits<double>::quiet_NaN();
    t.v_px[k] = beads.ok[k] ? beads.v_px[k] : std::numeric_limits<double>::quiet_NaN();
  }
  if (frame_a == prev_frame_b_) linkable_ += n;
  if (frame_a == prev_frame_b_ && !end_x_.empty() && n > 0) {
    // Nearest within the gate, both ways, by cells one gate wide.
    const core::PointCells cells(end_x_, end_y_, std::max(gate_px_, 1.0));
    const std::size_t ne = end_x_.size();
    const double gate2 = gate_px_ * gate_px_;
    std::vector<std::size_t> best_end(n, ne);
    std::vector<double> best_end_d2(n, gate2), end_best_d2(ne, gate2);
    std::vector<std::size_t> end_best(ne, n);
    for (std::size_t k = 0; k < n; ++k)
      cells.near(t.x_px[k], t.y_px[k], [&](std::size_t e) {
        const double d2 = std::pow(end_x_[e] - t.x_px[k], 2) + std::pow(end_y_[e] - t.y_px[k], 2);
        if (d2 <= best_end_d2[k] && (d2 < best_end_d2[k] || e < best_end[k])) best_end_d2[k] = d2, best_end[k] = e;
        if (d2 <= end_best_d2[e] && (d2 < end_best_d2[e] || k < end_best[e])) end_best_d2[e] = d2, end_best[e] = k;
      });
    for (std::size_t k = 0; k < n; ++k)
      if (best_end[k] < ne && end_best[best_end[k]] == k) {
        t.track_id[k] = end_ids_[best_end[k]];
        t.linked[k] = 1;
        ++linked_;
      }
  }
  for (std::size_t k = 0; k < n; ++k)
    if (t.track_id[k] < 0) t.track_id[k] = next_id_++;
  // Where this pair's tracked beads end: the next pair's frame a, if it is this frame b.
  end_x_.clear();
  end_y_.clear();
  end_ids_.clear();
  for (std::size_t k = 0; k < n; ++k)
    if (beads.ok[k]) {
      end_x_.push_back(beads.x_px[k] + beads.u_px[k]);
      end_y_.push_back(beads.y_px[k] + beads.v_px[k]);
      end_ids_.push_back(t.track_id[k]);
    }
  prev_frame_b_ = frame_b;
  return t;
}

}  // namespace shearzone::track
