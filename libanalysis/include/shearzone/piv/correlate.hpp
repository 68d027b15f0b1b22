// shearzone/piv/correlate.hpp: FFT cross-correlation of interrogation windows and
// sub-pixel peak location.
//
// For zero-mean windows a and b (W x W, row-major), the circular cross-correlation
//     c(s) = sum_x a(x) b(x + s) / sqrt(sum a^2 sum b^2)
// is computed as IFFT(conj(FFT a) FFT b) (FFTW, single precision, real-to-complex),
// so its peak is at the displacement s of the pattern from a to b and its height is
// the normalised correlation coefficient (1 for identical windows). The plane is
// stored shifted: zero displacement at index (W/2, W/2).
//
// Thread-safety: a Correlator is immutable after construction and may be shared;
// each thread passes its own Workspace. Plans use FFTW_ESTIMATE, so results are
// deterministic (FFTW_MEASURE may pick different algorithms from run to run).
#pragma once

#include <memory>
#include <vector>

#include "shearzone/piv/options.hpp"

namespace shearzone::piv {

/// Per-thread scratch buffers for one window size.
class Workspace {
 public:
  explicit Workspace(int window_px);
  ~Workspace();
  Workspace(const Workspace&) = delete;
  Workspace& operator=(const Workspace&) = delete;
  float* a() { return a_; }   ///< W*W input window A
  float* b() { return b_; }   ///< W*W input window B
  float* corr() { return corr_; }  ///< W*W correlation plane (shifted)

 private:
  friend class Correlator;
  int w_;
  float* a_ = nullptr;
  float* b_ = nullptr;
  float* corr_ = nullptr;
  float* real_ = nullptr;   // unshifted IFFT output
  void* spec_a_ = nullptr;  // fftwf_complex[W * (W/2 + 1)]
  void* spec_b_ = nullptr;
};

/// Sub-pixel correlation peak.
struct Peak {
  double dx = 0.0;        ///< displacement from a to b, px
  double dy = 0.0;
  float height = 0.0f;    ///< normalised correlation at the integer peak
  float ratio = 0.0f;     ///< height over the highest other local maximum (1000 if none)
  /// Width of the peak: the standard deviation, px, of the Gaussian through the 3 points
  /// at the integer maximum (geometric mean of x and y; 0 where they are not log-concave).
  float sigma_px = 0.0f;
  bool found = false;     ///< false: no positive peak in the search region
};

class Correlator {
 public:
  explicit Correlator(int window_px);
  ~Correlator();
  Correlator(const Correlator&) = delete;
  Correlator& operator=(const Correlator&) = delete;
  int window() const { return w_; }

  /// Subtracts the means of ws.a() and ws.b() and correlates them into ws.corr().
  /// Returns false (plane left at zero) if either window's intensity variance is not
  /// above `min_variance` (0: any variance will do).
  bool correlate(Workspace& ws, double min_variance = 0.0) const;

 private:
  int w_;
  void* plan_fwd_ = nullptr;  // fftwf_plan
  void* plan_inv_ = nullptr;
};

/// Locates the highest value of a shifted W x W plane within |s_x|, |s_y| <= radius
/// of zero displacement, refines it to sub-pixel with `method` and computes the
/// peak ratio against the highest other local maximum in the square. Neighbours wrap around (the plane is circular).
Peak find_peak(const float* corr, int w, int radius, Subpixel method);

/// Residual displacement from a to b by one Gauss-Newton (Lucas-Kanade) step on the
/// windows themselves: with b scaled to a's energy and G = (grad a + grad b) / 2 (central
/// differences over the (W - 2)^2 interior pixels), d = (sum G G^T)^-1 sum G (a - b).
/// For b(x) = a(x - d) the step is exact to O(d^3) (the symmetric difference), and no
/// pair of pixels leaves the window, so it has no loss-of-pairs bias: the correlation
/// peak of a broad texture (beads larger than a few px) is pulled towards zero
/// displacement by the window's edge and returns only part of the residual per pass.
/// Windows must be zero-mean (as correlate() leaves them).
struct GradientStep {
  double dx = 0.0, dy = 0.0;  ///< displacement from a to b, px
  /// Smaller over larger eigenvalue of sum G G^T: near 0 where the texture has no
  /// gradient across one direction (a window inside one smooth bead: the aperture problem).
  double conditioning = 0.0;
  bool ok = false;            ///< false: no texture (sum G G^T singular)
};
GradientStep gradient_step(const float* a, const float* b, int w);

/// 3-point Gaussian fit through (-1, lo), (0, c), (1, hi): the offset of the
/// maximum from 0. Falls back to a parabola if a value is not positive.
double gauss3(double lo, double c, double hi);

}  // namespace shearzone::piv
