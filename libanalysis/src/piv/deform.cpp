#include "shearzone/piv/deform.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "shearzone/core/check.hpp"

namespace shearzone::piv {

cv::Mat grid_to_pixels(const cv::Mat& values, double x0, double y0, double step, cv::Size size) {
  SHEARZONE_CHECK(values.type() == CV_32F && step > 0);
  cv::Mat map_x(size, CV_32F), map_y(size, CV_32F);
  std::vector<float> gx(static_cast<std::size_t>(size.width));
  for (int j = 0; j < size.width; ++j) gx[static_cast<std::size_t>(j)] = static_cast<float>((j - x0) / step);
  for (int i = 0; i < size.height; ++i) {
    const float gy = static_cast<float>((i - y0) / step);
    float* mx = map_x.ptr<float>(i);
    float* my = map_y.ptr<float>(i);
    for (int j = 0; j < size.width; ++j) {
      mx[j] = gx[static_cast<std::size_t>(j)];
      my[j] = gy;
    }
  }
  cv::Mat out;
  cv::remap(values, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

// ---- Interpolation -----------------------------------------------------------------
//
// All methods are evaluated here at the exact sample positions. (cv::remap rounds
// positions to 1/32 px, which alone adds up to 0.016 px of error: too much for PIV.)
// Separable kernels of support N (2, 4 or 6 samples per axis):
//   bilinear       triangle
//   bicubic        Keys cubic convolution with a = -0.5 (Keys 1981), on the pixels
//   bspline        cubic B-spline on prefiltered coefficients
//   bspline5       quintic B-spline on prefiltered coefficients
// B-spline prefilter (Unser, Aldroubi & Eden 1993): per pole z, gain (1-z)(1-1/z) and
// a causal then an anti-causal first-order recursion, mirror boundaries.
// Cubic: z = sqrt(3) - 2. Quintic: z1, z2 = roots of z^4 + 26 z^3 + 66 z^2 + 26 z + 1 in (-1, 0).

namespace {

void prefilter_pole(float* c, int n, int stride, double z) {
  if (n < 2) return;
  const double gain = (1.0 - z) * (1.0 - 1.0 / z);
  for (int k = 0; k < n; ++k) c[k * stride] = static_cast<float>(c[k * stride] * gain);
  // Causal initialisation (mirror boundary): sum to machine precision.
  const int horizon = std::min(n, static_cast<int>(std::ceil(std::log(1e-10) / std::log(std::abs(z)))));
  double sum = c[0];
  double zk = z;
  for (int k = 1; k < horizon; ++k) {
    sum += zk * c[k * stride];
    zk *= z;
  }
  c[0] = static_cast<float>(sum);
  for (int k = 1; k < n; ++k) c[k * stride] = static_cast<float>(c[k * stride] + z * c[(k - 1) * stride]);
  // Anti-causal initialisation.
  c[(n - 1) * stride] = static_cast<float>((z / (z * z - 1.0)) *
                                           (c[(n - 1) * stride] + z * c[(n - 2) * stride]));
  for (int k = n - 2; k >= 0; --k)
    c[k * stride] = static_cast<float>(z * (c[(k + 1) * stride] - c[k * stride]));
}

std::vector<double> bspline_poles(int degree) {
  if (degree == 3) return {std::sqrt(3.0) - 2.0};
  // Quintic: the two roots in (-1, 0) of z^4 + 26 z^3 + 66 z^2 + 26 z + 1.
  const double a = std::sqrt(135.0 / 2.0 - std::sqrt(17745.0 / 4.0)) + std::sqrt(105.0 / 4.0) - 13.0 / 2.0;
  const double b = std::sqrt(135.0 / 2.0 + std::sqrt(17745.0 / 4.0)) - std::sqrt(105.0 / 4.0) - 13.0 / 2.0;
  return {a, b};
}

inline double pow3(double x) { return x * x * x; }
inline double pow5(double x) { return x * x * x * x * x; }

/// Kernel weights for the N samples at offsets 1 - N/2 ... N/2 from floor(x), t = x - floor(x).
template <int N>
inline void weights(Interpolation m, double t, double w[N]) {
  if constexpr (N == 2) {
    w[0] = 1.0 - t;
    w[1] = t;
  } else if constexpr (N == 4) {
    if (m == Interpolation::kBicubic) {
      // Keys, a = -0.5, at distances 1 + t, t, 1 - t, 2 - t.
      const double a = -0.5;
      auto near = [a](double d) { return (a + 2) * pow3(d) - (a + 3) * d * d + 1; };
      auto far = [a](double d) { return a * pow3(d) - 5 * a * d * d + 8 * a * d - 4 * a; };
      w[0] = far(1 + t);
      w[1] = near(t);
      w[2] = near(1 - t);
      w[3] = far(2 - t);
    } else {  // cubic B-spline
      w[0] = pow3(1 - t) / 6.0;
      w[1] = (4.0 - 6.0 * t * t + 3.0 * pow3(t)) / 6.0;
      w[2] = (1.0 + 3.0 * t + 3.0 * t * t - 3.0 * pow3(t)) / 6.0;
      w[3] = pow3(t) / 6.0;
    }
  } else {
    // Quintic B-spline beta5(d) for the distances d = t + 2, t + 1, t, 1 - t, 2 - t, 3 - t.
    auto beta5 = [](double d) {
      d = std::abs(d);
      if (d >= 3) return 0.0;
      double v = pow5(3 - d);
      if (d < 2) v -= 6 * pow5(2 - d);
      if (d < 1) v += 15 * pow5(1 - d);
      return v / 120.0;
    };
    for (int q = 0; q < 6; ++q) w[q] = beta5(t - (q - 2));
  }
}

int mirror(int k, int n) {
  if (n == 1) return 0;
  const int period = 2 * (n - 1);
  k %= period;
  if (k < 0) k += period;
  return k < n ? k : period - k;
}

template <int N>
void remap_separable(const cv::Mat& c, const cv::Mat& map_x, const cv::Mat& map_y,
                     Interpolation method, cv::Mat& out) {
  out.create(map_x.size(), CV_32F);
  const int W = c.cols, H = c.rows;
  constexpr int lo = 1 - N / 2;  // first offset from floor
#pragma omp parallel for schedule(static)
  for (int i = 0; i < out.rows; ++i) {
    const float* mx = map_x.ptr<float>(i);
    const float* my = map_y.ptr<float>(i);
    float* o = out.ptr<float>(i);
    for (int j = 0; j < out.cols; ++j) {
      // Positions outside the image replicate the border value.
      const double x = std::clamp<double>(mx[j], 0.0, W - 1.0);
      const double y = std::clamp<double>(my[j], 0.0, H - 1.0);
      const int ix = static_cast<int>(std::floor(x)), iy = static_cast<int>(std::floor(y));
      double wx[N], wy[N];
      weights<N>(method, x - ix, wx);
      weights<N>(method, y - iy, wy);
      double acc = 0.0;
      if (ix + lo >= 0 && iy + lo >= 0 && ix + lo + N <= W && iy + lo + N <= H) {
        for (int r = 0; r < N; ++r) {
          const float* row = c.ptr<float>(iy + lo + r) + (ix + lo);
          double s = 0;
          for (int q = 0; q < N; ++q) s += wx[q] * row[q];
          acc += wy[r] * s;
        }
      } else {
        for (int r = 0; r < N; ++r) {
          const float* row = c.ptr<float>(mirror(iy + lo + r, H));
          double s = 0;
          for (int q = 0; q < N; ++q) s += wx[q] * row[mirror(ix + lo + q, W)];
          acc += wy[r] * s;
        }
      }
      o[j] = static_cast<float>(acc);
    }
  }
}

}  // namespace

cv::Mat bspline_coefficients(const cv::Mat& image, int degree) {
  SHEARZONE_CHECK(image.type() == CV_32F);
  SHEARZONE_CHECK(degree == 3 || degree == 5);
  cv::Mat c = image.clone();
  for (double z : bspline_poles(degree)) {
#pragma omp parallel for schedule(static)
    for (int i = 0; i < c.rows; ++i) prefilter_pole(c.ptr<float>(i), c.cols, 1, z);
#pragma omp parallel for schedule(static)
    for (int j = 0; j < c.cols; ++j)
      prefilter_pole(c.ptr<float>(0) + j, c.rows, static_cast<int>(c.step1()), z);
  }
  return c;
}

cv::Mat remap_image(const cv::Mat& image, const cv::Mat& map_x, const cv::Mat& map_y,
                    Interpolation method) {
  SHEARZONE_CHECK(image.type() == CV_32F && map_x.type() == CV_32F && map_y.type() == CV_32F);
  cv::Mat out;
  switch (method) {
    case Interpolation::kBilinear: remap_separable<2>(image, map_x, map_y, method, out); break;
    case Interpolation::kBicubic: remap_separable<4>(image, map_x, map_y, method, out); break;
    case Interpolation::kBSpline:
      remap_separable<4>(bspline_coefficients(image, 3), map_x, map_y, method, out);
      break;
    case Interpolation::kBSpline5:
      remap_separable<6>(bspline_coefficients(image, 5), map_x, map_y, method, out);
      break;
  }
  return out;
}

}  // namespace shearzone::piv
