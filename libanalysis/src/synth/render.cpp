#include "shearzone/synth/render.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "shearzone/core/check.hpp"
#include "shearzone/core/vane.hpp"

namespace shearzone::synth {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// ---- Particles ----------------------------------------------------------------------
//
// Pixel-integrated Gaussian. With sigma = d/4, the 1-D weight of pixel j for a
// particle at x_p is
//     g_j = integral_{j-1/2}^{j+1/2} exp(-(s - x_p)^2 / (2 sigma^2)) ds
//         = sigma sqrt(pi/2) [erf((j + 1/2 - x_p)/(sqrt2 sigma)) - erf((j - 1/2 - x_p)/(sqrt2 sigma))]
// and the pixel value is peak * g_j * g_i / (pixel area 1), separable in x and y.
// Rows are processed in bands; each band sums its particles in index order, so the
// result does not depend on the thread count.

cv::Mat render_particles(const std::vector<double>& x, const std::vector<double>& y,
                         const std::vector<double>& peak, cv::Size size, double diameter_px) {
  SHEARZONE_CHECK(x.size() == y.size() && x.size() == peak.size());
  SHEARZONE_CHECK(diameter_px > 0);
  cv::Mat img = cv::Mat::zeros(size, CV_64F);
  const double sigma = diameter_px / 4.0;
  const int reach = static_cast<int>(std::ceil(5.0 * sigma)) + 1;
  const double inv = 1.0 / (std::sqrt(2.0) * sigma);
  const double norm = sigma * std::sqrt(std::numbers::pi / 2.0);

  // Bin particles by band of rows they touch.
  const int band_rows = 16;
  const int bands = (size.height + band_rows - 1) / band_rows;
  std::vector<std::vector<std::size_t>> band_members(static_cast<std::size_t>(bands));
  for (std::size_t p = 0; p < x.size(); ++p) {
    if (!std::isfinite(x[p]) || !std::isfinite(y[p])) continue;
    if (x[p] < -reach || x[p] > size.width + reach || y[p] < -reach || y[p] > size.height + reach)
      continue;
    const int i0 = std::max(0, static_cast<int>(std::floor(y[p])) - reach);
    const int i1 = std::min(size.height - 1, static_cast<int>(std::ceil(y[p])) + reach);
    for (int b = i0 / band_rows; b <= i1 / band_rows && b < bands; ++b)
      band_members[static_cast<std::size_t>(b)].push_back(p);
  }

#pragma omp parallel for schedule(dynamic, 1)
  for (int b = 0; b < bands; ++b) {
    const int row_lo = b * band_rows;
    const int row_hi = std::min(size.height, row_lo + band_rows) - 1;
    std::vector<double> gx, gy;
    for (std::size_t p : band_members[static_cast<std::size_t>(b)]) {
      const int j0 = std::max(0, static_cast<int>(std::floor(x[p])) - reach);
      const int j1 = std::min(size.width - 1, static_cast<int>(std::ceil(x[p])) + reach);
      const int i0 = std::max(row_lo, static_cast<int>(std::floor(y[p])) - reach);
      const int i1 = std::min(row_hi, static_cast<int>(std::ceil(y[p])) + reach);
      if (j0 > j1 || i0 > i1) continue;
      gx.resize(static_cast<std::size_t>(j1 - j0 + 1));
      gy.resize(static_cast<std::size_t>(i1 - i0 + 1));
      for (int j = j0; j <= j1; ++j)
        gx[static_cast<std::size_t>(j - j0)] =
            norm * (std::erf((j + 0.5 - x[p]) * inv) - std::erf((j - 0.5 - x[p]) * inv));
      for (int i = i0; i <= i1; ++i)
        gy[static_cast<std::size_t>(i - i0)] =
            norm * (std::erf((i + 0.5 - y[p]) * inv) - std::erf((i - 0.5 - y[p]) * inv));
      for (int i = i0; i <= i1; ++i) {
        double* row = img.ptr<double>(i);
        const double wy = peak[p] * gy[static_cast<std::size_t>(i - i0)];
        for (int j = j0; j <= j1; ++j) row[j] += wy * gx[static_cast<std::size_t>(j - j0)];
      }
    }
  }
  return img;
}

// ---- Beads --------------------------------------------------------------------------
//
// Ray-cast from above at S x S samples per pixel, done as a splat: each bead writes
// the samples under its disc into a depth buffer, and the highest surface wins. For a
// sample at offset (dx, dy) from a bead centre, inside its radius R, the sphere surface
// is at height top - R + sqrt(R^2 - rho^2) and its normal is (dx, -dy, h)/R in a
// right-handed frame (x right, y up on screen, z towards the camera).
// Shade = ambient + albedo diffuse max(0, n.L) + specular max(0, n.H)^shininess.
// Rows are processed in bands; within a band beads are splatted in index order with a
// strict depth test, so the result does not depend on the thread count.

cv::Mat render_beads(const std::vector<double>& x, const std::vector<double>& y,
                     const std::vector<double>& top, const std::vector<double>& albedo,
                     cv::Size size, double diameter_px, const BeadShading& sh) {
  SHEARZONE_CHECK(diameter_px > 0);
  return render_beads(x, y, top, albedo, std::vector<double>(x.size(), diameter_px), size, sh);
}

cv::Mat render_beads(const std::vector<double>& x, const std::vector<double>& y,
                     const std::vector<double>& top, const std::vector<double>& albedo,
                     const std::vector<double>& diameter_px, cv::Size size, const BeadShading& sh) {
  SHEARZONE_CHECK(x.size() == y.size() && x.size() == top.size() && x.size() == albedo.size() &&
                  x.size() == diameter_px.size());
  SHEARZONE_CHECK(sh.supersample >= 1);
  for (const double d : diameter_px) SHEARZONE_CHECK(d > 0);
  const int S = sh.supersample;

  const double az = sh.light_azimuth_deg * std::numbers::pi / 180.0;
  const double el = sh.light_elevation_deg * std::numbers::pi / 180.0;
  const double L[3] = {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
  double H[3] = {L[0], L[1], L[2] + 1.0};
  const double hn = std::sqrt(H[0] * H[0] + H[1] * H[1] + H[2] * H[2]);
  for (double& h : H) h /= hn;

  // Sample (si, sj) of pixel (i, j) sits at (j - 1/2 + (sj + 1/2)/S, i - 1/2 + (si + 1/2)/S);
  // in sample-grid units, sample column c = j S + sj has x = (c + 1/2)/S - 1/2.
  auto sample_pos = [S](int c) { return (c + 0.5) / S - 0.5; };
  auto first_sample = [S](double v) {  // smallest c with sample_pos(c) >= v
    return static_cast<int>(std::ceil((v + 0.5) * S - 0.5));
  };

  const int band_rows = 16;
  const int bands = (size.height + band_rows - 1) / band_rows;
  std::vector<std::vector<std::size_t>> band_members(static_cast<std::size_t>(bands));
  for (std::size_t b = 0; b < x.size(); ++b) {
    const double R = diameter_px[b] / 2.0;
    if (y[b] + R < -0.5 || y[b] - R > size.height - 0.5) continue;
    if (x[b] + R < -0.5 || x[b] - R > size.width - 0.5) continue;
    const int i0 = std::max(0, static_cast<int>(std::floor(y[b] - R + 0.5)));
    const int i1 = std::min(size.height - 1, static_cast<int>(std::floor(y[b] + R + 0.5)));
    for (int band = i0 / band_rows; band <= i1 / band_rows; ++band)
      band_members[static_cast<std::size_t>(band)].push_back(b);
  }

  cv::Mat img(size, CV_64F);
  const int cols = size.width * S;
#pragma omp parallel for schedule(dynamic, 1)
  for (int band = 0; band < bands; ++band) {
    const int row_lo = band * band_rows;
    const int row_hi = std::min(size.height, row_lo + band_rows);
    const int r_lo = row_lo * S, r_hi = row_hi * S;  // sample rows [r_lo, r_hi)
    std::vector<double> depth(static_cast<std::size_t>((r_hi - r_lo) * cols), -1e300);
    std::vector<double> shade(depth.size(), sh.gap_level);
    for (std::size_t b : band_members[static_cast<std::size_t>(band)]) {
      const double R = diameter_px[b] / 2.0;
      const int c0 = std::max(0, first_sample(x[b] - R));
      const int c1 = std::min(cols - 1, first_sample(x[b] + R) - 1);
      const int q0 = std::max(r_lo, first_sample(y[b] - R));
      const int q1 = std::min(r_hi - 1, first_sample(y[b] + R) - 1);
      for (int q = q0; q <= q1; ++q) {
        const double dy = sample_pos(q) - y[b];
        double* drow = depth.data() + static_cast<std::size_t>(q - r_lo) * cols;
        double* srow = shade.data() + static_cast<std::size_t>(q - r_lo) * cols;
        for (int c = c0; c <= c1; ++c) {
          const double dx = sample_pos(c) - x[b];
          const double rho2 = dx * dx + dy * dy;
          if (rho2 >= R * R) continue;
          const double hz = std::sqrt(R * R - rho2);
          const double h = top[b] - R + hz;
          if (h <= drow[c]) continue;
          drow[c] = h;
          const double n[3] = {dx / R, -dy / R, hz / R};
          const double nl = std::max(0.0, n[0] * L[0] + n[1] * L[1] + n[2] * L[2]);
          const double nh = std::max(0.0, n[0] * H[0] + n[1] * H[1] + n[2] * H[2]);
          srow[c] = sh.ambient + albedo[b] * sh.diffuse * nl +
                    (nh > 0 ? sh.specular * std::pow(nh, sh.shininess) : 0.0);
        }
      }
    }
    // Average the S x S samples of each pixel.
    const double inv_s2 = 1.0 / (S * S);
    for (int i = row_lo; i < row_hi; ++i) {
      double* row = img.ptr<double>(i);
      for (int j = 0; j < size.width; ++j) {
        double acc = 0.0;
        for (int si = 0; si < S; ++si) {
          const double* srow = shade.data() + static_cast<std::size_t>((i * S + si) - r_lo) * cols;
          for (int sj = 0; sj < S; ++sj) acc += srow[j * S + sj];
        }
        row[j] = acc * inv_s2;
      }
    }
  }
  return img;
}

// ---- Vane ---------------------------------------------------------------------------

bool inside_vane(double x, double y, double cx, double cy, double angle_rad, int blades,
                 double half_width_px, double radius_px) {
  return core::VaneGeometry{blades, half_width_px, radius_px}.contains(x, y, cx, cy, angle_rad);
}

void draw_vane(cv::Mat& ideal, double cx, double cy, double angle_rad, int blades,
               double half_width_px, double radius_px, double level) {
  SHEARZONE_CHECK(ideal.type() == CV_64F);
  if (blades <= 0) return;
  const int S = 4;
  const int i0 = std::max(0, static_cast<int>(std::floor(cy - radius_px - 2)));
  const int i1 = std::min(ideal.rows - 1, static_cast<int>(std::ceil(cy + radius_px + 2)));
  const int j0 = std::max(0, static_cast<int>(std::floor(cx - radius_px - 2)));
  const int j1 = std::min(ideal.cols - 1, static_cast<int>(std::ceil(cx + radius_px + 2)));
#pragma omp parallel for schedule(static)
  for (int i = i0; i <= i1; ++i) {
    double* row = ideal.ptr<double>(i);
    for (int j = j0; j <= j1; ++j) {
      int covered = 0;
      for (int si = 0; si < S; ++si)
        for (int sj = 0; sj < S; ++sj)
          covered += inside_vane(j - 0.5 + (sj + 0.5) / S, i - 0.5 + (si + 0.5) / S, cx, cy,
                                 angle_rad, blades, half_width_px, radius_px);
      const double a = static_cast<double>(covered) / (S * S);
      row[j] = (1.0 - a) * row[j] + a * level;
    }
  }
}

// ---- Noise and quantisation -----------------------------------------------------------

cv::Mat quantise(const cv::Mat& ideal, double background, double noise, int bit_depth,
                 std::uint64_t seed, std::uint64_t frame) {
  SHEARZONE_CHECK(ideal.type() == CV_64F);
  SHEARZONE_CHECK(bit_depth == 8 || bit_depth == 16);
  const double full = bit_depth == 8 ? 255.0 : 65535.0;
  cv::Mat out(ideal.size(), bit_depth == 8 ? CV_8U : CV_16U);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < ideal.rows; ++i) {
    std::mt19937_64 rng(splitmix64(seed ^ splitmix64(frame * 0x100000001B3ull + static_cast<std::uint64_t>(i))));
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double* src = ideal.ptr<double>(i);
    for (int j = 0; j < ideal.cols; ++j) {
      double v = src[j] + background;
      if (noise > 0) v += noise * gauss(rng);
      v = std::clamp(v, 0.0, 1.0) * full;
      const double q = std::round(v);
      if (bit_depth == 8) out.ptr<std::uint8_t>(i)[j] = static_cast<std::uint8_t>(q);
      else out.ptr<std::uint16_t>(i)[j] = static_cast<std::uint16_t>(q);
    }
  }
  return out;
}

}  // namespace shearzone::synth
