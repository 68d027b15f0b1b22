#include "shearzone/piv/deform.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#if defined(__x86_64__)
#include <immintrin.h>
#define SHEARZONE_HAVE_X86_SIMD 1
#endif

#include "shearzone/core/check.hpp"
#include "cpu_features.hpp"

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
    // Quintic B-spline beta5 at the distances t + 2, t + 1, t, 1 - t, 2 - t, 3 - t, each in
    // its own polynomial piece (no branches):
    //   beta5(d) = [(3-d)^5 - 6 (2-d)^5 + 15 (1-d)^5] / 120   for |d| < 1, etc.
    const double a = pow5(1 - t), b = pow5(2 - t), c = pow5(3 - t);
    const double d = pow5(t), e = pow5(1 + t), g = pow5(2 + t);
    w[0] = a / 120.0;
    w[1] = (b - 6 * a) / 120.0;
    w[2] = (c - 6 * b + 15 * a) / 120.0;
    w[3] = (g - 6 * e + 15 * d) / 120.0;
    w[4] = (e - 6 * d) / 120.0;
    w[5] = d / 120.0;
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
      double wxd[N], wyd[N];
      weights<N>(method, x - ix, wxd);
      weights<N>(method, y - iy, wyd);
      float wx[N];
      for (int q = 0; q < N; ++q) wx[q] = static_cast<float>(wxd[q]);
      // Float sums: 36 terms of O(1) values keep ~1e-7 relative precision.
      float acc = 0.0f;
      if (ix + lo >= 0 && iy + lo >= 0 && ix + lo + N <= W && iy + lo + N <= H) {
        for (int r = 0; r < N; ++r) {
          const float* row = c.ptr<float>(iy + lo + r) + (ix + lo);
          float s = 0.0f;
          for (int q = 0; q < N; ++q) s += wx[q] * row[q];
          acc += static_cast<float>(wyd[r]) * s;
        }
      } else {
        for (int r = 0; r < N; ++r) {
          const float* row = c.ptr<float>(mirror(iy + lo + r, H));
          float s = 0.0f;
          for (int q = 0; q < N; ++q) s += wx[q] * row[mirror(ix + lo + q, W)];
          acc += static_cast<float>(wyd[r]) * s;
        }
      }
      o[j] = acc;
    }
  }
}

}  // namespace

namespace {

/// The prefilter along columns, run on whole rows at a time (contiguous memory).
void prefilter_columns(cv::Mat& c, double z) {
  const int n = c.rows, w = c.cols;
  if (n < 2) return;
  const float gain = static_cast<float>((1.0 - z) * (1.0 - 1.0 / z));
  const float zf = static_cast<float>(z);
  for (int k = 0; k < n; ++k) {
    float* r = c.ptr<float>(k);
    for (int j = 0; j < w; ++j) r[j] *= gain;
  }
  // Causal initialisation: row 0 += sum_k z^k row k, to machine precision.
  const int horizon = std::min(n, static_cast<int>(std::ceil(std::log(1e-10) / std::log(std::abs(z)))));
  std::vector<double> acc(static_cast<std::size_t>(w));
  const float* r0 = c.ptr<float>(0);
  for (int j = 0; j < w; ++j) acc[static_cast<std::size_t>(j)] = r0[j];
  double zk = z;
  for (int k = 1; k < horizon; ++k, zk *= z) {
    const float* r = c.ptr<float>(k);
    for (int j = 0; j < w; ++j) acc[static_cast<std::size_t>(j)] += zk * r[j];
  }
  float* first = c.ptr<float>(0);
  for (int j = 0; j < w; ++j) first[j] = static_cast<float>(acc[static_cast<std::size_t>(j)]);
  for (int k = 1; k < n; ++k) {
    float* r = c.ptr<float>(k);
    const float* p = c.ptr<float>(k - 1);
    for (int j = 0; j < w; ++j) r[j] += zf * p[j];
  }
  // Anti-causal.
  const float f = static_cast<float>(z / (z * z - 1.0));
  float* last = c.ptr<float>(n - 1);
  const float* before = c.ptr<float>(n - 2);
  for (int j = 0; j < w; ++j) last[j] = f * (last[j] + zf * before[j]);
  for (int k = n - 2; k >= 0; --k) {
    float* r = c.ptr<float>(k);
    const float* q = c.ptr<float>(k + 1);
    for (int j = 0; j < w; ++j) r[j] = zf * (q[j] - r[j]);
  }
}

}  // namespace

void bspline_coefficients(const cv::Mat& image, int degree, cv::Mat& out, cv::Mat& scratch) {
  SHEARZONE_CHECK(image.type() == CV_32F);
  SHEARZONE_CHECK(degree == 3 || degree == 5);
  SHEARZONE_CHECK(out.data == nullptr || out.data != image.data);
  // The recursion runs along columns on whole rows at a time (contiguous memory,
  // vectorised across columns); the rows are filtered the same way on the transpose.
  auto filter_columns = [](cv::Mat& c, double z) {
    const int strip = 64;
#pragma omp parallel for schedule(static)
    for (int j0 = 0; j0 < c.cols; j0 += strip) {
      cv::Mat s = c.colRange(j0, std::min(c.cols, j0 + strip));
      prefilter_columns(s, z);
    }
  };
  cv::transpose(image, scratch);
  for (double z : bspline_poles(degree)) filter_columns(scratch, z);  // rows of the image
  cv::transpose(scratch, out);
  for (double z : bspline_poles(degree)) filter_columns(out, z);  // columns of the image
}

cv::Mat bspline_coefficients(const cv::Mat& image, int degree) {
  cv::Mat out, scratch;
  bspline_coefficients(image, degree, out, scratch);
  return out;
}

bool needs_coefficients(Interpolation method) {
  return method == Interpolation::kBSpline || method == Interpolation::kBSpline5;
}

void interpolation_coefficients(const cv::Mat& image, Interpolation method, cv::Mat& out,
                                cv::Mat& scratch) {
  if (method == Interpolation::kBSpline) return bspline_coefficients(image, 3, out, scratch);
  if (method == Interpolation::kBSpline5) return bspline_coefficients(image, 5, out, scratch);
  image.copyTo(out);
}

cv::Mat interpolation_coefficients(const cv::Mat& image, Interpolation method) {
  if (method == Interpolation::kBSpline) return bspline_coefficients(image, 3);
  if (method == Interpolation::kBSpline5) return bspline_coefficients(image, 5);
  return image;
}

cv::Mat remap_coefficients(const cv::Mat& coefficients, const cv::Mat& map_x, const cv::Mat& map_y,
                           Interpolation method) {
  SHEARZONE_CHECK(coefficients.type() == CV_32F && map_x.type() == CV_32F && map_y.type() == CV_32F);
  cv::Mat out;
  switch (method) {
    case Interpolation::kBilinear: remap_separable<2>(coefficients, map_x, map_y, method, out); break;
    case Interpolation::kBicubic:
    case Interpolation::kBSpline: remap_separable<4>(coefficients, map_x, map_y, method, out); break;
    case Interpolation::kBSpline5: remap_separable<6>(coefficients, map_x, map_y, method, out); break;
  }
  return out;
}

namespace {

/// Quintic B-spline weights in single precision (the hot path of the deformation).
inline void quintic_weights(float t, float w[6]) {
  auto p5 = [](float x) {
    const float x2 = x * x;
    return x2 * x2 * x;
  };
  const float a = p5(1 - t), b = p5(2 - t), c = p5(3 - t);
  const float d = p5(t), e = p5(1 + t), g = p5(2 + t);
  constexpr float k = 1.0f / 120.0f;
  w[0] = a * k;
  w[1] = (b - 6 * a) * k;
  w[2] = (c - 6 * b + 15 * a) * k;
  w[3] = (g - 6 * e + 15 * d) * k;
  w[4] = (e - 6 * d) * k;
  w[5] = d * k;
}

template <int N>
inline float sample(const cv::Mat& c, double x, double y, Interpolation method) {
  const int W = c.cols, H = c.rows;
  constexpr int lo = 1 - N / 2;
  x = std::clamp(x, 0.0, W - 1.0);
  y = std::clamp(y, 0.0, H - 1.0);
  const int ix = static_cast<int>(x), iy = static_cast<int>(y);
  float wx[N], wy[N];
  if constexpr (N == 6) {
    quintic_weights(static_cast<float>(x - ix), wx);
    quintic_weights(static_cast<float>(y - iy), wy);
  } else {
    double wxd[N], wyd[N];
    weights<N>(method, x - ix, wxd);
    weights<N>(method, y - iy, wyd);
    for (int q = 0; q < N; ++q) {
      wx[q] = static_cast<float>(wxd[q]);
      wy[q] = static_cast<float>(wyd[q]);
    }
  }
  float acc = 0.0f;
  if (ix + lo >= 0 && iy + lo >= 0 && ix + lo + N <= W && iy + lo + N <= H) {
    const float* row = c.ptr<float>(iy + lo) + (ix + lo);
    const std::size_t stride = c.step1();
    for (int r = 0; r < N; ++r, row += stride) {
      float s = 0.0f;
      for (int q = 0; q < N; ++q) s += wx[q] * row[q];
      acc += wy[r] * s;
    }
  } else {
    for (int r = 0; r < N; ++r) {
      const float* row = c.ptr<float>(mirror(iy + lo + r, H));
      float s = 0.0f;
      for (int q = 0; q < N; ++q) s += wx[q] * row[mirror(ix + lo + q, W)];
      acc += wy[r] * s;
    }
  }
  return acc;
}

#if defined(SHEARZONE_HAVE_X86_SIMD)
// AVX2 + FMA kernel of the quintic deformation: 8 pixels at a time, weights computed
// in vector registers, the 6 x 6 coefficients of each pixel fetched with gathers.
// Used when the CPU has AVX2 and FMA (checked at run time); pixels whose 6 x 6
// support leaves the image take the scalar path. Sums run in a different order from
// the scalar path, so results differ in the last bits between the two paths (and so
// between CPUs), never between runs or thread counts on one machine.
namespace simd {

__attribute__((target("avx2,fma"))) inline __m256 p5(__m256 x) {
  const __m256 x2 = _mm256_mul_ps(x, x);
  return _mm256_mul_ps(_mm256_mul_ps(x2, x2), x);
}

__attribute__((target("avx2,fma"))) inline void quintic_weights8(__m256 t, __m256 w[6]) {
  const __m256 one = _mm256_set1_ps(1.0f), two = _mm256_set1_ps(2.0f), three = _mm256_set1_ps(3.0f);
  const __m256 six = _mm256_set1_ps(6.0f), fifteen = _mm256_set1_ps(15.0f);
  const __m256 k = _mm256_set1_ps(1.0f / 120.0f);
  const __m256 a = p5(_mm256_sub_ps(one, t)), b = p5(_mm256_sub_ps(two, t));
  const __m256 c = p5(_mm256_sub_ps(three, t)), d = p5(t);
  const __m256 e = p5(_mm256_add_ps(one, t)), g = p5(_mm256_add_ps(two, t));
  w[0] = _mm256_mul_ps(a, k);
  w[1] = _mm256_mul_ps(_mm256_fnmadd_ps(six, a, b), k);
  w[2] = _mm256_mul_ps(_mm256_fmadd_ps(fifteen, a, _mm256_fnmadd_ps(six, b, c)), k);
  w[3] = _mm256_mul_ps(_mm256_fmadd_ps(fifteen, d, _mm256_fnmadd_ps(six, e, g)), k);
  w[4] = _mm256_mul_ps(_mm256_fnmadd_ps(six, d, e), k);
  w[5] = _mm256_mul_ps(d, k);
}

/// Samples the quintic spline with coefficients `c` at 8 positions; returns false
/// (and writes nothing) if any support, read as 8 floats per row, leaves the image.
/// Each pixel's 6 x 6 support is read as 6 unaligned rows of 8 floats (no gathers: slow
/// on many cores), weighted by its wy and summed down the rows, then weighted by its
/// wx (lanes 6 and 7 weighted 0) and summed across: the 8 pixels' horizontal sums
/// share one reduction tree.
__attribute__((target("avx2,fma"))) inline bool sample8(const cv::Mat& c, const float* xs,
                                                         const float* ys, float* out) {
  const int W = c.cols, H = c.rows;
  __m256 x = _mm256_loadu_ps(xs), y = _mm256_loadu_ps(ys);
  x = _mm256_min_ps(_mm256_max_ps(x, _mm256_setzero_ps()), _mm256_set1_ps(static_cast<float>(W - 1)));
  y = _mm256_min_ps(_mm256_max_ps(y, _mm256_setzero_ps()), _mm256_set1_ps(static_cast<float>(H - 1)));
  const __m256 fx = _mm256_floor_ps(x), fy = _mm256_floor_ps(y);
  const __m256i ix = _mm256_cvttps_epi32(fx), iy = _mm256_cvttps_epi32(fy);
  // Interior: ix - 2 >= 0 and ix + 5 < W (8 floats read from ix - 2), iy - 2 >= 0, iy + 3 < H.
  const __m256i lo = _mm256_set1_epi32(1);
  const __m256i inside =
      _mm256_and_si256(_mm256_and_si256(_mm256_cmpgt_epi32(ix, lo), _mm256_cmpgt_epi32(_mm256_set1_epi32(W - 5), ix)),
                       _mm256_and_si256(_mm256_cmpgt_epi32(iy, lo), _mm256_cmpgt_epi32(_mm256_set1_epi32(H - 3), iy)));
  if (_mm256_movemask_ps(_mm256_castsi256_ps(inside)) != 0xFF) return false;
  __m256 wx[8], wy[6];
  quintic_weights8(_mm256_sub_ps(x, fx), wx);
  quintic_weights8(_mm256_sub_ps(y, fy), wy);
  wx[6] = wx[7] = _mm256_setzero_ps();
  // Transpose wx (tap x pixel) to pixel x tap: 8 x 8 in registers.
  {
    const __m256 t0 = _mm256_unpacklo_ps(wx[0], wx[1]), t1 = _mm256_unpackhi_ps(wx[0], wx[1]);
    const __m256 t2 = _mm256_unpacklo_ps(wx[2], wx[3]), t3 = _mm256_unpackhi_ps(wx[2], wx[3]);
    const __m256 t4 = _mm256_unpacklo_ps(wx[4], wx[5]), t5 = _mm256_unpackhi_ps(wx[4], wx[5]);
    const __m256 t6 = _mm256_unpacklo_ps(wx[6], wx[7]), t7 = _mm256_unpackhi_ps(wx[6], wx[7]);
    const __m256 u0 = _mm256_shuffle_ps(t0, t2, 0x44), u1 = _mm256_shuffle_ps(t0, t2, 0xEE);
    const __m256 u2 = _mm256_shuffle_ps(t1, t3, 0x44), u3 = _mm256_shuffle_ps(t1, t3, 0xEE);
    const __m256 u4 = _mm256_shuffle_ps(t4, t6, 0x44), u5 = _mm256_shuffle_ps(t4, t6, 0xEE);
    const __m256 u6 = _mm256_shuffle_ps(t5, t7, 0x44), u7 = _mm256_shuffle_ps(t5, t7, 0xEE);
    wx[0] = _mm256_permute2f128_ps(u0, u4, 0x20);
    wx[1] = _mm256_permute2f128_ps(u1, u5, 0x20);
    wx[2] = _mm256_permute2f128_ps(u2, u6, 0x20);
    wx[3] = _mm256_permute2f128_ps(u3, u7, 0x20);
    wx[4] = _mm256_permute2f128_ps(u0, u4, 0x31);
    wx[5] = _mm256_permute2f128_ps(u1, u5, 0x31);
    wx[6] = _mm256_permute2f128_ps(u2, u6, 0x31);
    wx[7] = _mm256_permute2f128_ps(u3, u7, 0x31);
  }
  alignas(32) float wys[6][8];
  for (int r = 0; r < 6; ++r) _mm256_store_ps(wys[r], wy[r]);
  alignas(32) int first[8];
  const int stride = static_cast<int>(c.step1());
  _mm256_store_si256(reinterpret_cast<__m256i*>(first),
                     _mm256_add_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(iy, _mm256_set1_epi32(2)),
                                                         _mm256_set1_epi32(stride)),
                                      _mm256_sub_epi32(ix, _mm256_set1_epi32(2))));
  const float* base = c.ptr<float>(0);
  __m256 res[8];
  for (int k = 0; k < 8; ++k) {
    const float* p = base + first[k];
    __m256 acc = _mm256_mul_ps(_mm256_set1_ps(wys[0][k]), _mm256_loadu_ps(p));
    for (int r = 1; r < 6; ++r) acc = _mm256_fmadd_ps(_mm256_set1_ps(wys[r][k]), _mm256_loadu_ps(p + r * stride), acc);
    res[k] = _mm256_mul_ps(acc, wx[k]);
  }
  // Horizontal sums of res[0..7] into one vector.
  const __m256 h0 = _mm256_hadd_ps(_mm256_hadd_ps(res[0], res[1]), _mm256_hadd_ps(res[2], res[3]));
  const __m256 h1 = _mm256_hadd_ps(_mm256_hadd_ps(res[4], res[5]), _mm256_hadd_ps(res[6], res[7]));
  _mm256_storeu_ps(out, _mm256_add_ps(_mm256_permute2f128_ps(h0, h1, 0x20), _mm256_permute2f128_ps(h0, h1, 0x31)));
  return true;
}

}  // namespace simd

using detail::cpu_has_avx2_fma;
#endif

template <int N>
void deform_pair_impl(const cv::Mat& ca, const cv::Mat& cb, const cv::Mat& gu, const cv::Mat& gv,
                      double x0, double y0, double step, Interpolation method, cv::Mat& a_out,
                      cv::Mat& b_out, const RowSpans* spans) {
  const cv::Size size = ca.size();
  a_out.create(size, CV_32F);
  b_out.create(size, CV_32F);
  const int gw = gu.cols, gh = gu.rows;
  // The predictor's columns around each pixel column (the same for every row).
  std::vector<int> col0(static_cast<std::size_t>(size.width)), col1(col0.size());
  std::vector<float> colt(col0.size());
  for (int j = 0; j < size.width; ++j) {
    const double gx = std::clamp((j - x0) / step, 0.0, gw - 1.0);
    const int j0 = std::min(static_cast<int>(gx), gw - 1);
    col0[static_cast<std::size_t>(j)] = j0;
    col1[static_cast<std::size_t>(j)] = std::min(j0 + 1, gw - 1);
    colt[static_cast<std::size_t>(j)] = static_cast<float>(gx - j0);
  }
#if defined(SHEARZONE_HAVE_X86_SIMD)
  const bool simd = N == 6 && cpu_has_avx2_fma();
#else
  const bool simd = false;
#endif
#pragma omp parallel for schedule(static)
  for (int i = 0; i < size.height; ++i) {
    if (spans && (*spans)[static_cast<std::size_t>(i)].empty()) continue;
    // Bilinear predictor along this row: rows of the grid around y.
    const double gy = std::clamp((i - y0) / step, 0.0, gh - 1.0);
    const int i0 = std::min(static_cast<int>(gy), gh - 1), i1 = std::min(i0 + 1, gh - 1);
    const float ty = static_cast<float>(gy - i0);
    const float *u0 = gu.ptr<float>(i0), *u1 = gu.ptr<float>(i1);
    const float *v0 = gv.ptr<float>(i0), *v1 = gv.ptr<float>(i1);
    float* pa = a_out.ptr<float>(i);
    float* pb = b_out.ptr<float>(i);
    auto scalar = [&](int j) {
      const int j0 = col0[static_cast<std::size_t>(j)], j1 = col1[static_cast<std::size_t>(j)];
      const float tx = colt[static_cast<std::size_t>(j)];
      const float du = (1 - ty) * ((1 - tx) * u0[j0] + tx * u0[j1]) + ty * ((1 - tx) * u1[j0] + tx * u1[j1]);
      const float dv = (1 - ty) * ((1 - tx) * v0[j0] + tx * v0[j1]) + ty * ((1 - tx) * v1[j0] + tx * v1[j1]);
      pa[j] = sample<N>(ca, j - 0.5 * du, i - 0.5 * dv, method);
      pb[j] = sample<N>(cb, j + 0.5 * du, i + 0.5 * dv, method);
    };
    auto run = [&](int from, int to) {  // pixels [from, to) of this row, at least
      if (!simd) {
        for (int j = from; j < to; ++j) scalar(j);
        return;
      }
#if defined(SHEARZONE_HAVE_X86_SIMD)
      // Whole blocks of 8 counted from the row start, the row's last partial block
      // scalar: every pixel takes the same path (and so has the same bits) whichever
      // part of the row is asked for.
      if constexpr (N == 6) {
        float xa[8], ya[8], xb[8], yb[8];
        for (int j = from / 8 * 8; j < to; j += 8) {
          if (j + 8 > size.width) {
            for (int jj = j; jj < size.width; ++jj) scalar(jj);
            break;
          }
          for (int k = 0; k < 8; ++k) {
            const int jj = j + k;
            const int j0 = col0[static_cast<std::size_t>(jj)], j1 = col1[static_cast<std::size_t>(jj)];
            const float tx = colt[static_cast<std::size_t>(jj)];
            const float du = (1 - ty) * ((1 - tx) * u0[j0] + tx * u0[j1]) + ty * ((1 - tx) * u1[j0] + tx * u1[j1]);
            const float dv = (1 - ty) * ((1 - tx) * v0[j0] + tx * v0[j1]) + ty * ((1 - tx) * v1[j0] + tx * v1[j1]);
            xa[k] = static_cast<float>(jj - 0.5 * du);
            ya[k] = static_cast<float>(i - 0.5 * dv);
            xb[k] = static_cast<float>(jj + 0.5 * du);
            yb[k] = static_cast<float>(i + 0.5 * dv);
          }
          if (!simd::sample8(ca, xa, ya, pa + j))
            for (int k = 0; k < 8; ++k) pa[j + k] = sample<N>(ca, xa[k], ya[k], method);
          if (!simd::sample8(cb, xb, yb, pb + j))
            for (int k = 0; k < 8; ++k) pb[j + k] = sample<N>(cb, xb[k], yb[k], method);
        }
      }
#endif
    };
    if (!spans) {
      run(0, size.width);
    } else {
      for (const auto& [from, to] : (*spans)[static_cast<std::size_t>(i)]) run(from, to);
    }
  }
}

}  // namespace

void deform_pair(const cv::Mat& coef_a, const cv::Mat& coef_b, const cv::Mat& grid_u,
                 const cv::Mat& grid_v, double x0, double y0, double step, Interpolation method,
                 cv::Mat& a_out, cv::Mat& b_out, const RowSpans* spans) {
  SHEARZONE_CHECK(coef_a.type() == CV_32F && coef_b.type() == CV_32F && coef_a.size() == coef_b.size());
  SHEARZONE_CHECK(spans == nullptr || static_cast<int>(spans->size()) == coef_a.rows);
  SHEARZONE_CHECK(grid_u.type() == CV_32F && grid_v.type() == CV_32F && grid_u.size() == grid_v.size());
  // The outputs must not share memory with the inputs (they are written while read).
  SHEARZONE_CHECK(a_out.data == nullptr || (a_out.data != coef_a.data && a_out.data != coef_b.data));
  SHEARZONE_CHECK(b_out.data == nullptr || (b_out.data != coef_a.data && b_out.data != coef_b.data));
  switch (method) {
    case Interpolation::kBilinear:
      deform_pair_impl<2>(coef_a, coef_b, grid_u, grid_v, x0, y0, step, method, a_out, b_out, spans);
      break;
    case Interpolation::kBicubic:
    case Interpolation::kBSpline:
      deform_pair_impl<4>(coef_a, coef_b, grid_u, grid_v, x0, y0, step, method, a_out, b_out, spans);
      break;
    case Interpolation::kBSpline5:
      deform_pair_impl<6>(coef_a, coef_b, grid_u, grid_v, x0, y0, step, method, a_out, b_out, spans);
      break;
  }
}

cv::Mat remap_image(const cv::Mat& image, const cv::Mat& map_x, const cv::Mat& map_y,
                    Interpolation method) {
  SHEARZONE_CHECK(image.type() == CV_32F);
  return remap_coefficients(interpolation_coefficients(image, method), map_x, map_y, method);
}

}  // namespace shearzone::piv
