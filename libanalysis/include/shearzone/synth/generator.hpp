// shearzone/synth/generator.hpp: synthetic frame sequences with exact ground truth.
//
// Tracers (Gaussian particles or shaded beads) move with a DisplacementField.
// Placement is symmetric about the midpoint, as in PIV test-image standards: for
// the first pair, midpoints p are drawn uniformly and
//     A = p - s_0 d(p) / 2,    B = p + s_0 d(p) / 2,
// so B - A = s_0 d(p) exactly at the midpoint p, which is where PIV reports the
// displacement. Later frames continue with the implicit midpoint rule
//     m = x_k + s_k d(m) / 2,    x_{k+1} = 2 m - x_k,
// which keeps the same property for every pair (k, k+1) and conserves the radius
// about the centre exactly for the rotation and shear-zone fields (the midpoint rule
// conserves quadratic invariants), so tracers never drift out of the disk.
//
// Time: frame k is at t_k = k / fps. With oscillation at f > 0, the displacement of
// the pair (k, k+1) is scaled by s_k = cos(2 pi f (t_k + 1/(2 fps))), the vane's
// angular velocity at the pair's mid-time; otherwise s_k = 1. The vane angle is
// phi(t) = phi0 sin(2 pi f t) (counter-clockwise positive as the camera sees it),
// and blade 0 points along the direction at angle0 + phi from +x.
//
// Determinism: the same options (seed included) give bit-identical frames for any
// number of threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "shearzone/core/metadata.hpp"
#include "shearzone/synth/field.hpp"
#include "shearzone/synth/render.hpp"

namespace shearzone::synth {

enum class TextureKind { kParticles, kBeads };

struct ImageOptions {
  int width_px = 512;   ///< image width, px (>= 8)
  int height_px = 512;  ///< image height, px (>= 8)
  /// Gaussian noise standard deviation, fraction of full scale (0..0.5).
  double noise = 0.01;
  /// Constant added to every pixel, fraction of full scale (0..1).
  double background = 0.0;
  int bit_depth = 8;       ///< 8 or 16
  std::uint64_t seed = 1;  ///< seeds tracer placement, brightness and noise
};

struct ParticleOptions {
  /// Particle image e^-2 diameter, px (0.5..50). 2-4 px is typical of PIV.
  double diameter_px = 3.0;
  /// Particles per pixel (0 < density <= 0.2). 0.02-0.05 is typical.
  double density_ppp = 0.02;
  /// Peak intensity range of a particle, fraction of full scale; each particle
  /// draws uniformly from [intensity_min, intensity_max].
  double intensity_min = 0.6;
  double intensity_max = 1.0;
};

struct BeadOptions {
  /// Bead diameter, px (3..200). The lab's 1080p films show beads of 10-20 px.
  double diameter_px = 12.0;
  /// Smallest centre distance in the top view, as a fraction of the diameter
  /// (0.5..1.2). Below 1 the beads overlap in projection, as in a 3-D pile.
  double min_spacing = 0.85;
  /// Albedo range (0..1) and random height of each bead's top, as a fraction of d.
  double albedo_min = 0.55;
  double albedo_max = 1.0;
  double height_jitter = 0.3;
  BeadShading shading;
};

struct SequenceOptions {
  int frames = 2;               ///< number of frames K (>= 2); 2 writes a pair A, B
  double fps = 25.0;            ///< frame rate, Hz (> 0)
  double oscillate_f_Hz = 0.0;  ///< vane frequency f, Hz (0: steady field)
  /// Random motion about the field: each frame every tracer takes an extra Gaussian
  /// step of this standard deviation per component, px (0..20; 0: none). A pair of
  /// consecutive frames then has a velocity fluctuation of exactly this per component
  /// about the field (granular temperature; the truth files hold the field only).
  double jitter_px = 0.0;
};

struct VaneOptions {
  int blades = 0;                ///< number of blades; 0 draws no vane
  double half_width_px = 4.0;    ///< blade half-width, px
  double radius_px = 60.0;       ///< blade radius, px
  double phi0_rad = 0.3;         ///< oscillation amplitude phi0, rad
  double angle0_deg = 0.0;       ///< direction of blade 0 at phi = 0, deg CCW from +x
  double level = 0.2;            ///< vane intensity, fraction of full scale
};

struct SynthOptions {
  TextureKind texture = TextureKind::kParticles;
  ImageOptions image;
  ParticleOptions particles;
  BeadOptions beads;
  FieldOptions field;
  SequenceOptions sequence;
  VaneOptions vane;

  /// Throws ConfigError naming the option and the constraint it violates.
  void validate() const;
  /// Every resolved option as `key: value` metadata (for output headers).
  core::Metadata to_metadata() const;
};

struct FrameTime {
  int index = 0;
  double t_s = 0.0;       ///< k / fps
  double phi_rad = 0.0;   ///< vane angle phi(t_k) (without angle0)
  double pair_scale = 1;  ///< s_k: displacement scale of the pair (k, k+1)
};

struct TruthPoint {
  double x_px, y_px, u_px, v_px;
};

class FrameGenerator {
 public:
  /// Validates the options, resolves the centre and places the tracers.
  explicit FrameGenerator(SynthOptions options);

  const SynthOptions& options() const { return opt_; }
  int num_frames() const { return opt_.sequence.frames; }
  int next_index() const { return next_; }
  bool done() const { return next_ >= opt_.sequence.frames; }
  std::size_t num_tracers() const { return x_.size(); }
  FrameTime frame_time(int k) const;

  /// Renders the next frame before noise and quantisation (CV_64F, fraction of
  /// full scale, vane drawn), then advances the tracers.
  cv::Mat next_ideal();
  /// Renders the next frame as stored: noise, clipping, 8 or 16 bits.
  cv::Mat next();

  /// Tracer positions of the frame next() renders (for tests).
  const std::vector<double>& tracer_x() const { return x_; }
  const std::vector<double>& tracer_y() const { return y_; }
  /// Peak intensity (particles) or albedo (beads) of each tracer.
  const std::vector<double>& tracer_brightness() const { return brightness_; }

  /// Displacement per frame at scale `scale` on a grid with spacing `spacing_px`:
  /// points at x = (spacing - 1)/2 + j spacing (the centres of spacing x spacing
  /// blocks of pixels), likewise for y.
  std::vector<TruthPoint> truth(double spacing_px, double scale) const;

 private:
  void place_tracers();
  void advance(int k);
  void wrap();

  SynthOptions opt_;
  DisplacementField field_;
  std::vector<double> x_, y_, brightness_, top_;
  // Sampling domain (uniform field: periodic rectangle).
  double dom_x0_ = 0, dom_y0_ = 0, dom_x1_ = 0, dom_y1_ = 0;
  bool periodic_ = false;
  int next_ = 0;
  std::mt19937_64 jitter_rng_;  // the jitter's steps, seeded from the image seed
};

/// "particles" or "beads".
const char* texture_kind_name(TextureKind kind);

/// Frames 0 and 1 of `options` with every tracer's position in each: the truth bead by
/// bead, for scoring a tracker.
struct TracedPair {
  cv::Mat a, b;
  std::vector<double> xa, ya, xb, yb;  ///< tracer k in frame a and in frame b, px
};
TracedPair traced_pair(const SynthOptions& options);

/// For each point (x[k], y[k]) the tracer (index into tx, ty) within `radius` px of it,
/// or -1 where there is none, or where a second tracer lies within twice the radius
/// (two beads almost on top of each other, one all but hidden: which one a camera
/// shows there is not defined).
std::vector<long> tracer_under(const std::vector<double>& tx, const std::vector<double>& ty,
                               const std::vector<double>& x, const std::vector<double>& y, double radius);

}  // namespace shearzone::synth
