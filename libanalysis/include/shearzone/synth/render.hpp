// shearzone/synth/render.hpp: renderers for synthetic frames with exact positions.
//
// Renderers produce an "ideal" image: CV_64F, intensity as a fraction of full
// scale, no noise, no clipping. quantise() then adds seeded Gaussian noise, clips to
// [0, 1] and rounds to 8 or 16 bits. All renderers are deterministic for any number
// of OpenMP threads: each output pixel is summed in a fixed order.
//
// Pixel (row i, column j) covers the square [j - 1/2, j + 1/2] x [i - 1/2, i + 1/2]
// and has its centre at (x, y) = (j, i).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace shearzone::synth {

/// Gaussian particle images integrated over each pixel's area (not sampled at the
/// pixel centre), so that the intensity centroid and the summed intensity are
/// exact. Particle i has the intensity profile
///     I(x, y) = peak_i exp(-8 ((x - x_i)^2 + (y - y_i)^2) / d^2),
/// i.e. d = diameter_px is the e^-2 diameter (sigma = d / 4), the usual PIV
/// definition. Its summed intensity is peak_i * 2 pi sigma^2. The profile is cut at
/// 5 sigma (the mass beyond is below 4e-6 of the total).
/// Returns a CV_64F image of `size` (added onto a zero background).
cv::Mat render_particles(const std::vector<double>& x, const std::vector<double>& y,
                         const std::vector<double>& peak, cv::Size size, double diameter_px);

/// Shading parameters of bead renders.
struct BeadShading {
  double light_azimuth_deg = 135.0;   ///< light direction in the image plane, CCW from +x
  double light_elevation_deg = 50.0;  ///< above the image plane
  double ambient = 0.08;              ///< fraction of full scale on every lit bead
  double diffuse = 0.75;              ///< Lambert term weight
  double specular = 0.6;              ///< Blinn-Phong highlight weight
  double shininess = 40.0;            ///< highlight exponent
  double gap_level = 0.03;            ///< intensity between beads (shadowed gaps)
  int supersample = 3;                ///< samples per pixel side (anti-aliasing)
};

/// A dense top view of shiny spheres of diameter `diameter_px`: bead i is at
/// (x_i, y_i) with its top at height top_i (px; higher beads hide lower ones) and
/// albedo albedo_i. Returns a CV_64F image.
cv::Mat render_beads(const std::vector<double>& x, const std::vector<double>& y,
                     const std::vector<double>& top, const std::vector<double>& albedo,
                     cv::Size size, double diameter_px, const BeadShading& shading);
/// The same with a diameter per bead (a perspective view: nearer beads look larger).
cv::Mat render_beads(const std::vector<double>& x, const std::vector<double>& y,
                     const std::vector<double>& top, const std::vector<double>& albedo,
                     const std::vector<double>& diameter_px, cv::Size size, const BeadShading& shading);

/// An opaque vane seen from above: `blades` straight blades of half-width
/// `half_width_px` from the centre out to `radius_px`, blade k along the direction
/// at angle angle_rad + 2 pi k / blades, counter-clockwise as the camera sees it
/// from +x (image direction (cos a, -sin a)). Painted with intensity `level`,
/// anti-aliased by 4x4 supersampling of the coverage.
void draw_vane(cv::Mat& ideal, double centre_x_px, double centre_y_px, double angle_rad,
               int blades, double half_width_px, double radius_px, double level);

/// True if the point (x, y) is inside the vane (core::VaneGeometry::contains).
bool inside_vane(double x, double y, double centre_x_px, double centre_y_px, double angle_rad,
                 int blades, double half_width_px, double radius_px);

/// Adds Gaussian noise of standard deviation `noise` (fraction of full scale) and
/// `background`, clips to [0, 1] and rounds to `bit_depth` (8 or 16) bits. The noise
/// of row i of frame `frame` comes from its own generator seeded from
/// (seed, frame, i), so the result is independent of the thread count.
cv::Mat quantise(const cv::Mat& ideal, double background, double noise, int bit_depth,
                 std::uint64_t seed, std::uint64_t frame);

/// SplitMix64: the seed mixer used for every derived random stream.
std::uint64_t splitmix64(std::uint64_t x);

}  // namespace shearzone::synth
