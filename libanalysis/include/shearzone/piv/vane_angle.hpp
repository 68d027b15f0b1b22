// shearzone/piv/vane_angle.hpp: the vane's angle seen in a frame.
//
// An opaque vane looks uniform where the bead layer around it is textured. The angle
// estimate is the blade-0 direction a (CCW on screen from +x) that minimises the
// intensity variance of the pixels under the blade template at a, searched on a grid
// of 0.25 deg over [a_lo, a_hi] and refined by a parabola through the best three.
// Used to align a rheometer angle log with the video (`--log-offset-s auto`).
// Assumes a uniform vane; a textured or specular vane needs the offset given by hand.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "shearzone/core/vane.hpp"

namespace shearzone::piv {

/// Blade-0 angle in rad within [a_lo, a_hi] (CCW on screen from +x).
double estimate_vane_angle(const cv::Mat& frame, double cx, double cy,
                           const core::VaneGeometry& vane, double a_lo, double a_hi);

/// Linear interpolation of a log (strictly increasing times `t`, values `a`) at x;
/// the end values hold outside the range.
double interpolate_log(const std::vector<double>& t, const std::vector<double>& a, double x);

/// The offset o (s) minimising sum_k (video_angle_k - log_angle(t_k + o))^2 over the
/// offsets for which the log covers every frame time, with log_angle linear between
/// rows; candidates every `step_s`, then refined to step_s / 20 around the best.
/// Returns NaN if no offset keeps every frame inside the log.
double best_log_offset(const std::vector<double>& frame_t_s, const std::vector<double>& video_angle,
                       const std::vector<double>& log_t_s, const std::vector<double>& log_angle,
                       double step_s);

/// The sinusoid A sin(2 pi f t + phase) + c fitted to measured vane angles by linear
/// least squares (f given; core::fit_sine_at about t = 0). phase in (-pi, pi]; NaN when
/// the frames span less than a quarter cycle (the phase is then not determined).
struct VanePhaseFit {
  double phase_rad = 0, amplitude_rad = 0, offset_rad = 0, rms_rad = 0;
};
VanePhaseFit fit_vane_phase(const std::vector<double>& t_s, const std::vector<double>& angle_rad, double f_Hz);

/// phi(t) of the vane as its mask follows it: blade 0 at angle0 + phi0 sin(2 pi f t +
/// phase), or at angle0 + a rheometer log's angle at t + offset (io::read_angle_log, linear
/// between rows). The phase and the offset may be set once found from the video.
class VaneDrive {
 public:
  struct Options {
    double angle0_deg = 0, phi0_rad = 0, f_Hz = 0, phase_rad = 0;
    std::string log_path;  ///< empty: the sinusoid
    double log_offset_s = 0;
  };
  explicit VaneDrive(Options o);

  const std::vector<double>& log_times() const { return time_; }
  const std::vector<double>& log_angles() const { return angle_; }
  void set_log_offset(double s) { o_.log_offset_s = s; }
  double log_offset() const { return o_.log_offset_s; }
  void set_phase(double p) { o_.phase_rad = p; }
  double phase() const { return o_.phase_rad; }

  /// Blade-0 angle (angle0 + phi) at frame time t, rad. InputError naming the log and
  /// `frame_label` when t + offset lies outside the log.
  double at(double t_s, const std::string& frame_label) const;

 private:
  Options o_;
  std::vector<double> time_, angle_;
};

}  // namespace shearzone::piv
