#include "shearzone/piv/correlate.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <vector>

#include <Eigen/Dense>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "shearzone/core/check.hpp"
#include "cpu_features.hpp"

namespace shearzone::piv {
namespace {

// FFTW's planner is not thread-safe; execution with new arrays is.
std::mutex g_fftw_planner_mutex;

std::size_t spectrum_size(int w) { return static_cast<std::size_t>(w) * (w / 2 + 1); }

}  // namespace

Workspace::Workspace(int window_px) : w_(window_px) {
  const std::size_t n = static_cast<std::size_t>(w_) * w_;
  a_ = fftwf_alloc_real(n);
  b_ = fftwf_alloc_real(n);
  corr_ = fftwf_alloc_real(n);
  real_ = fftwf_alloc_real(n);
  spec_a_ = fftwf_alloc_complex(spectrum_size(w_));
  spec_b_ = fftwf_alloc_complex(spectrum_size(w_));
  SHEARZONE_CHECK(a_ && b_ && corr_ && real_ && spec_a_ && spec_b_);
}

Workspace::~Workspace() {
  fftwf_free(a_);
  fftwf_free(b_);
  fftwf_free(corr_);
  fftwf_free(real_);
  fftwf_free(spec_a_);
  fftwf_free(spec_b_);
}

Correlator::Correlator(int window_px) : w_(window_px) {
  SHEARZONE_CHECK(w_ >= 4 && (w_ & (w_ - 1)) == 0);
  Workspace tmp(w_);  // plans are made on FFTW-aligned arrays like every workspace's
  std::lock_guard lock(g_fftw_planner_mutex);
  plan_fwd_ = fftwf_plan_dft_r2c_2d(w_, w_, tmp.a(), static_cast<fftwf_complex*>(tmp.spec_a_),
                                    FFTW_ESTIMATE);
  plan_inv_ = fftwf_plan_dft_c2r_2d(w_, w_, static_cast<fftwf_complex*>(tmp.spec_a_), tmp.real_,
                                    FFTW_ESTIMATE);
  SHEARZONE_CHECK(plan_fwd_ != nullptr && plan_inv_ != nullptr);
}

Correlator::~Correlator() {
  std::lock_guard lock(g_fftw_planner_mutex);
  fftwf_destroy_plan(static_cast<fftwf_plan>(plan_fwd_));
  fftwf_destroy_plan(static_cast<fftwf_plan>(plan_inv_));
}

namespace {

#if defined(__x86_64__)
using detail::cpu_has_avx2_fma;

/// zero_mean for n a multiple of 8, in double lanes. A constant window sums exactly in
/// double (n copies of a 24-bit value, n <= 2^16), so it comes out exactly zero (no
/// variance) as on the scalar path; otherwise the sums round in a different order.
__attribute__((target("avx2,fma"))) void zero_mean_avx2(float* a, float* b, int n, double& ea_out,
                                                         double& eb_out) {
  alignas(32) double lanes[4];
  auto total = [&lanes]() { return (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]); };
  __m256d sa = _mm256_setzero_pd(), sb = _mm256_setzero_pd();
  for (int i = 0; i < n; i += 8) {
    const __m256 x = _mm256_loadu_ps(a + i), y = _mm256_loadu_ps(b + i);
    sa = _mm256_add_pd(sa, _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(x)),
                                         _mm256_cvtps_pd(_mm256_extractf128_ps(x, 1))));
    sb = _mm256_add_pd(sb, _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(y)),
                                         _mm256_cvtps_pd(_mm256_extractf128_ps(y, 1))));
  }
  _mm256_store_pd(lanes, sa);
  const __m256 ma = _mm256_set1_ps(static_cast<float>(total() / n));
  _mm256_store_pd(lanes, sb);
  const __m256 mb = _mm256_set1_ps(static_cast<float>(total() / n));
  __m256d ea = _mm256_setzero_pd(), eb = _mm256_setzero_pd();
  for (int i = 0; i < n; i += 8) {
    const __m256 x = _mm256_sub_ps(_mm256_loadu_ps(a + i), ma);
    const __m256 y = _mm256_sub_ps(_mm256_loadu_ps(b + i), mb);
    _mm256_storeu_ps(a + i, x);
    _mm256_storeu_ps(b + i, y);
    const __m256d x0 = _mm256_cvtps_pd(_mm256_castps256_ps128(x)), x1 = _mm256_cvtps_pd(_mm256_extractf128_ps(x, 1));
    const __m256d y0 = _mm256_cvtps_pd(_mm256_castps256_ps128(y)), y1 = _mm256_cvtps_pd(_mm256_extractf128_ps(y, 1));
    ea = _mm256_fmadd_pd(x0, x0, _mm256_fmadd_pd(x1, x1, ea));
    eb = _mm256_fmadd_pd(y0, y0, _mm256_fmadd_pd(y1, y1, eb));
  }
  _mm256_store_pd(lanes, ea);
  ea_out = total();
  _mm256_store_pd(lanes, eb);
  eb_out = total();
}
#endif

void zero_mean_scalar(float* a, float* b, int n, double& ea_out, double& eb_out) {
  double sa = 0, sb = 0;
  for (int i = 0; i < n; ++i) {
    sa += a[i];
    sb += b[i];
  }
  const float ma = static_cast<float>(sa / n), mb = static_cast<float>(sb / n);
  double ea = 0, eb = 0;
  for (int i = 0; i < n; ++i) {
    a[i] -= ma;
    b[i] -= mb;
    ea += static_cast<double>(a[i]) * a[i];
    eb += static_cast<double>(b[i]) * b[i];
  }
  ea_out = ea;
  eb_out = eb;
}

/// Subtracts the means of a and b (n values each) and returns their energies; false
/// if either variance is not above min_variance. (The AVX2 path sums in a different
/// order: results differ from the scalar path in the last bits, never between runs or
/// thread counts on one machine.)
bool zero_mean(float* a, float* b, int n, double min_variance, double& ea, double& eb) {
#if defined(__x86_64__)
  if (n % 8 == 0 && cpu_has_avx2_fma()) zero_mean_avx2(a, b, n, ea, eb);
  else zero_mean_scalar(a, b, n, ea, eb);
#else
  zero_mean_scalar(a, b, n, ea, eb);
#endif
  return ea > 0 && eb > 0 && ea > min_variance * n && eb > min_variance * n;
}

}  // namespace

bool Correlator::correlate(Workspace& ws, double min_variance) const {
  SHEARZONE_DCHECK(ws.w_ == w_);
  const int n = w_ * w_;
  double ea = 0, eb = 0;
  if (!zero_mean(ws.a_, ws.b_, n, min_variance, ea, eb)) {
    std::fill(ws.corr_, ws.corr_ + n, 0.0f);
    return false;
  }
  // Step 2: spectra, cross-power, inverse transform.
  auto* fa = static_cast<fftwf_complex*>(ws.spec_a_);
  auto* fb = static_cast<fftwf_complex*>(ws.spec_b_);
  fftwf_execute_dft_r2c(static_cast<fftwf_plan>(plan_fwd_), ws.a_, fa);
  fftwf_execute_dft_r2c(static_cast<fftwf_plan>(plan_fwd_), ws.b_, fb);
  const std::size_t ns = spectrum_size(w_);
  for (std::size_t k = 0; k < ns; ++k) {
    // conj(fa) * fb
    const float re = fa[k][0] * fb[k][0] + fa[k][1] * fb[k][1];
    const float im = fa[k][0] * fb[k][1] - fa[k][1] * fb[k][0];
    fa[k][0] = re;
    fa[k][1] = im;
  }
  fftwf_execute_dft_c2r(static_cast<fftwf_plan>(plan_inv_), fa, ws.real_);
  // Step 3: normalise (FFTW's inverse is unscaled by n) and shift zero to (W/2, W/2).
  const float scale = static_cast<float>(1.0 / (n * std::sqrt(ea * eb)));
  const int h = w_ / 2;
  for (int y = 0; y < w_; ++y) {
    const int ys = (y + h) & (w_ - 1);
    for (int x = 0; x < w_; ++x) {
      const int xs = (x + h) & (w_ - 1);
      ws.corr_[ys * w_ + xs] = ws.real_[y * w_ + x] * scale;
    }
  }
  return true;
}

GradientStep gradient_step(const float* a, const float* b, int w) {
  GradientStep g;
  if (w < 8) return g;
  double ea = 0, eb = 0;
  for (int k = 0; k < w * w; ++k) {
    ea += static_cast<double>(a[k]) * a[k];
    eb += static_cast<double>(b[k]) * b[k];
  }
  if (!(ea > 0 && eb > 0)) return g;
  const float s = static_cast<float>(std::sqrt(ea / eb));  // b to a's energy (brightness changes)
  double hxx = 0, hxy = 0, hyy = 0, ex = 0, ey = 0;
  // Central differences over the (W - 2)^2 interior pixels (bead textures are smooth;
  // the passes' iteration removes what the difference's gain leaves).
  for (int y = 1; y < w - 1; ++y) {
    const float* pa = a + y * w;
    const float* pb = b + y * w;
    float sxx = 0, sxy = 0, syy = 0, sex = 0, sey = 0;  // per row in float, summed in double
#pragma omp simd reduction(+ : sxx, sxy, syy, sex, sey)
    for (int x = 1; x < w - 1; ++x) {
      const float gx = 0.25f * ((pa[x + 1] - pa[x - 1]) + s * (pb[x + 1] - pb[x - 1]));
      const float gy = 0.25f * ((pa[x + w] - pa[x - w]) + s * (pb[x + w] - pb[x - w]));
      const float e = pa[x] - s * pb[x];
      sxx += gx * gx;
      sxy += gx * gy;
      syy += gy * gy;
      sex += gx * e;
      sey += gy * e;
    }
    hxx += sxx;
    hxy += sxy;
    hyy += syy;
    ex += sex;
    ey += sey;
  }
  const double det = hxx * hyy - hxy * hxy, tr = hxx + hyy;
  if (!(det > 0 && tr > 0)) return g;
  const double disc = std::sqrt(std::max(0.0, 0.25 * (hxx - hyy) * (hxx - hyy) + hxy * hxy));
  const double lmax = 0.5 * tr + disc, lmin = 0.5 * tr - disc;
  g.conditioning = lmin / lmax;
  g.dx = (hyy * ex - hxy * ey) / det;
  g.dy = (hxx * ey - hxy * ex) / det;
  g.ok = std::isfinite(g.dx) && std::isfinite(g.dy);
  return g;
}

double gauss3(double lo, double c, double hi) {
  double d;
  if (lo > 0 && c > 0 && hi > 0) {
    const double l = std::log(lo), m = std::log(c), r = std::log(hi);
    const double den = 2.0 * (l - 2.0 * m + r);
    d = den < 0 ? (l - r) / den : 0.0;
  } else {
    const double den = 2.0 * (lo - 2.0 * c + hi);
    d = den < 0 ? (lo - hi) / den : 0.0;
  }
  return std::clamp(d, -1.0, 1.0);
}

namespace {

/// Least-squares fit of ln c = a0 + a1 x + a2 y + a3 x^2 + a4 xy + a5 y^2 over the
/// 3x3 neighbourhood: a = P ln(c) with the constant 6x9 pseudo-inverse P.
const Eigen::Matrix<double, 6, 9>& gauss2d_pinv() {
  static const Eigen::Matrix<double, 6, 9> P = [] {
    Eigen::Matrix<double, 9, 6> X;
    int k = 0;
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x, ++k) X.row(k) << 1, x, y, x * x, x * y, y * y;
    return Eigen::Matrix<double, 6, 9>((X.transpose() * X).inverse() * X.transpose());
  }();
  return P;
}

}  // namespace

Peak find_peak(const float* corr, int w, int radius, Subpixel method) {
  Peak p;
  const int h = w / 2;
  radius = std::clamp(radius, 1, h - 1);
  // Step 1: integer maximum in the search square: the largest value (8 independent
  // running maxima, not one serial chain), then its first position in row-major order.
  int bx = h, by = h;
  float best = -2.0f;
  {
    float m[8] = {-2.0f, -2.0f, -2.0f, -2.0f, -2.0f, -2.0f, -2.0f, -2.0f};
    const int n = 2 * radius + 1;
    for (int y = h - radius; y <= h + radius; ++y) {
      const float* row = corr + y * w + h - radius;
      int x = 0;
      for (; x + 8 <= n; x += 8)
        for (int k = 0; k < 8; ++k) m[k] = row[x + k] > m[k] ? row[x + k] : m[k];
      for (; x < n; ++x) m[0] = row[x] > m[0] ? row[x] : m[0];
    }
    for (int k = 0; k < 8; ++k) best = m[k] > best ? m[k] : best;
    bool found = false;
    for (int y = h - radius; y <= h + radius && !found; ++y)
      for (int x = h - radius; x <= h + radius; ++x)
        if (corr[y * w + x] == best) {
          bx = x;
          by = y;
          found = true;
          break;
        }
  }
  if (!(best > 0)) return p;
  auto at = [&](int x, int y) {
    return static_cast<double>(corr[((y + w) & (w - 1)) * w + ((x + w) & (w - 1))]);
  };
  // Step 2: sub-pixel refinement.
  double ox = gauss3(at(bx - 1, by), best, at(bx + 1, by));
  double oy = gauss3(at(bx, by - 1), best, at(bx, by + 1));
  {
    // Width: ln c = -x^2 / (2 sigma^2) + ... has second difference -1 / sigma^2.
    auto var = [best](double lo, double hi) {
      if (!(lo > 0 && hi > 0)) return 0.0;
      const double d2 = std::log(lo) - 2.0 * std::log(static_cast<double>(best)) + std::log(hi);
      return d2 < 0 ? -1.0 / d2 : 0.0;
    };
    p.sigma_px = static_cast<float>(std::pow(var(at(bx - 1, by), at(bx + 1, by)) *
                                             var(at(bx, by - 1), at(bx, by + 1)), 0.25));
  }
  if (method == Subpixel::kGauss2D) {
    Eigen::Matrix<double, 9, 1> lnc;
    bool positive = true;
    int k = 0;
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x, ++k) {
        const double v = at(bx + x, by + y);
        positive &= v > 0;
        lnc(k) = v > 0 ? std::log(v) : 0.0;
      }
    if (positive) {
      const Eigen::Matrix<double, 6, 1> a = gauss2d_pinv() * lnc;
      // Stationary point: [2a3 a4; a4 2a5] [x y]^T = -[a1 a2]^T, a maximum if negative definite.
      const double A = 2 * a(3), B = a(4), C = 2 * a(5);
      const double det = A * C - B * B;
      if (A < 0 && det > 0) {
        const double sx = (-a(1) * C + a(2) * B) / det;
        const double sy = (-a(2) * A + a(1) * B) / det;
        if (std::abs(sx) <= 1 && std::abs(sy) <= 1) {
          ox = sx;
          oy = sy;
        }
      }
    }
  }
  p.dx = (bx - h) + ox;
  p.dy = (by - h) + oy;
  p.height = best;
  // Step 3: second peak: the highest other local maximum (a value not below any of
  // its 8 neighbours) in the search square. Local maxima, not just any value outside a
  // fixed box, so that the shoulder of a broad peak (large particles, beads) is not
  // mistaken for a second peak.
  // The square with its neighbours: read in place when inside the plane, else from a
  // copy padded by one wrapped row and column on each side (the plane is circular).
  const float* plane = corr;
  int stride = w, x0 = h - radius, y0 = h - radius;
  if (radius + 1 >= h) {
    static thread_local std::vector<float> padded;
    const int pw = w + 2;
    padded.resize(static_cast<std::size_t>(pw) * pw);
    for (int y = -1; y <= w; ++y)
      for (int x = -1; x <= w; ++x)
        padded[static_cast<std::size_t>((y + 1) * pw + x + 1)] = corr[((y + w) & (w - 1)) * w + ((x + w) & (w - 1))];
    plane = padded.data();
    stride = pw;
    x0 += 1;
    y0 += 1;
    bx += 1;
    by += 1;
  }
  float second = 0.0f;
  for (int y = y0; y <= y0 + 2 * radius; ++y)
    for (int x = x0; x <= x0 + 2 * radius; ++x) {
      const float* q = plane + y * stride + x;
      const float c = *q;
      if (c <= second || (x == bx && y == by)) continue;
      if (q[-stride - 1] > c || q[-stride] > c || q[-stride + 1] > c || q[-1] > c || q[1] > c ||
          q[stride - 1] > c || q[stride] > c || q[stride + 1] > c)
        continue;
      second = c;
    }
  p.ratio = second > 0 ? best / second : 1000.0f;
  p.found = true;
  return p;
}

}  // namespace shearzone::piv
