// See shearzone/synth/cup_view.hpp.
#include "shearzone/synth/cup_view.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"

namespace shearzone::synth {

void CupLook::validate() const {
  if (!(noise >= 0 && noise <= 1)) throw ConfigError(fmt::format("--noise {}: expected 0..1 of full scale", noise));
  if (!(blur_px >= 0 && blur_px <= 50)) throw ConfigError(fmt::format("--blur-px {}: expected 0..50 px", blur_px));
  if (!(jpeg_quality >= 0 && jpeg_quality <= 100))
    throw ConfigError(fmt::format("--jpeg-quality {}: expected 1..100, or 0 for none", jpeg_quality));
  if (!(depth_fade_d > 0 && albedo_spread >= 0 && albedo_spread < 1))
    throw ConfigError("look: expected depth_fade_d > 0 and 0 <= albedo_spread < 1");
}

DownCamera cup_camera(const CupGeometry& cup, double surface_z_m, bool orthographic, int width_px,
                             int height_px, double m_per_px, double height_m) {
  DownCamera c;
  c.orthographic = orthographic;
  c.width_px = width_px;
  c.height_px = height_px;
  c.centre_x_px = 0.5 * (width_px - 1);
  c.centre_y_px = 0.5 * (height_px - 1);
  c.axis_x_m = cup.centre_x_m;
  c.axis_y_m = cup.centre_y_m;
  c.z_ref_m = surface_z_m;
  c.height_m = height_m;
  if (core::is_set(m_per_px)) {
    c.m_per_px = m_per_px;
  } else {
    const double target_px = 0.45 * std::min(width_px, height_px);
    // The rim at the cup's top: R f / (height + z_ref - z_rim) = target, f = height / m.
    c.m_per_px = orthographic ? cup.radius_m / target_px
                              : cup.radius_m * height_m / ((height_m + surface_z_m - cup.height_m) * target_px);
  }
  if (!orthographic && !(cup.height_m < surface_z_m + height_m))
    throw ConfigError(fmt::format("--height-m {}: the pinhole must be above the cup's rim ({} m above the bead "
                                  "surface)",
                                  height_m, cup.height_m - surface_z_m));
  c.validate();
  return c;
}

ProjectedBeads project_beads(const DownCamera& cam, const CupGeometry& cup, const CupBeads& beads,
                             double surface_z_m, const CupLook& look) {
  ProjectedBeads p;
  const double d = cup.bead_diameter_m;
  const double s_ref = cam.px_per_m(surface_z_m);
  for (std::size_t b = 0; b < beads.x.size(); ++b) {
    // Beads under the rim (the wall's own) are hidden by it.
    if (std::hypot(beads.x[b] - cup.centre_x_m, beads.y[b] - cup.centre_y_m) > cup.radius_m + d) continue;
    double x = 0, y = 0;
    cam.project(beads.x[b], beads.y[b], beads.z[b], x, y);
    const double dpx = d * cam.px_per_m(beads.z[b]);
    if (x < -dpx || y < -dpx || x > cam.width_px + dpx || y > cam.height_px + dpx) continue;
    const auto u = static_cast<double>(splitmix64(look.seed ^ splitmix64(
                                                              static_cast<std::uint64_t>(beads.id[b]) + 1)) >>
                                       11) *
                   0x1.0p-53;
    double albedo = 1.0 + look.albedo_spread * (2.0 * u - 1.0);
    if (beads.z[b] < surface_z_m) albedo *= std::exp(-(surface_z_m - beads.z[b]) / (look.depth_fade_d * d));
    if (!beads.mobile[b]) albedo *= 0.6;  // the floor's fixed beads: rougher, duller
    p.x.push_back(x);
    p.y.push_back(y);
    p.top.push_back((beads.z[b] + 0.5 * d) * s_ref);
    p.diameter.push_back(dpx);
    p.albedo.push_back(albedo);
    p.id.push_back(beads.id[b]);
  }
  return p;
}

CupImage cup_image(const DownCamera& cam, const CupGeometry& cup, double surface_z_m) {
  CupImage im;
  cam.project(cup.centre_x_m, cup.centre_y_m, surface_z_m, im.centre_x_px, im.centre_y_px);
  im.cup_radius_px = cup.radius_m * cam.px_per_m(surface_z_m);
  im.rim_radius_px = cup.radius_m * cam.px_per_m(cup.height_m);
  if (cup.vane_blades > 0) {
    const double s = cam.px_per_m(cup.vane_height_m);
    im.vane_radius_px = cup.vane_radius_m * s;
    im.vane_half_width_px = 0.5 * cup.bead_diameter_m * s;
    im.vane_surface_radius_px = cup.vane_radius_m * cam.px_per_m(surface_z_m);
  }
  return im;
}

cv::Mat render_cup_frame(const DownCamera& cam, const CupGeometry& cup, double surface_z_m,
                         const ProjectedBeads& beads, double vane_angle_rad, const CupLook& look,
                         std::uint64_t frame) {
  const cv::Size size(cam.width_px, cam.height_px);
  cv::Mat ideal = render_beads(beads.x, beads.y, beads.top, beads.albedo, beads.diameter, size, look.shading);
  // The rim: its top face a bright ring of rim_width_px beyond the wall's inner edge (the
  // line --detect-cup fits), the outside beyond it; inside it a dark band: the wall's
  // inner face (seen between the bead surface's and the rim's radius in a pinhole view)
  // and its shadow, at least 4 px or 0.3 d wide. Anti-aliased by 4 x 4 samples near edges.
  const CupImage im = cup_image(cam, cup, surface_z_m);
  const double R = im.rim_radius_px;
  const double d_px = cup.bead_diameter_m * cam.px_per_m(surface_z_m);
  const double R_in = R - std::max({4.0, 0.3 * d_px, R - im.cup_radius_px});
  const double R_out = R + look.rim_width_px;
  auto level_of = [&](double r) {  // at distance r from the axis' image
    if (r > R_out) return look.outside_level;
    return r > R ? look.rim_level : (r > R_in ? look.wall_level : -1.0);  // -1: the beads
  };
#pragma omp parallel for schedule(static)
  for (int i = 0; i < ideal.rows; ++i) {
    double* row = ideal.ptr<double>(i);
    for (int j = 0; j < ideal.cols; ++j) {
      const double r = std::hypot(j - im.centre_x_px, i - im.centre_y_px);
      if (r < R_in - 1.0) continue;
      if ((r > R_in + 1.0 && r < R - 1.0) || (r > R + 1.0 && r < R_out - 1.0) || r > R_out + 1.0) {
        row[j] = level_of(r);
        continue;
      }
      double acc = 0.0;
      for (int si = 0; si < 4; ++si)
        for (int sj = 0; sj < 4; ++sj) {
          const double v = level_of(std::hypot(j - 0.5 + (sj + 0.5) / 4 - im.centre_x_px,
                                               i - 0.5 + (si + 0.5) / 4 - im.centre_y_px));
          acc += v < 0 ? row[j] : v;
        }
      row[j] = acc / 16.0;
    }
  }
  if (cup.vane_blades > 0)
    draw_vane(ideal, im.centre_x_px, im.centre_y_px, vane_angle_rad, cup.vane_blades, im.vane_half_width_px,
                     im.vane_radius_px, look.vane_level);
  if (look.blur_px > 0) cv::GaussianBlur(ideal, ideal, cv::Size(0, 0), look.blur_px, look.blur_px, cv::BORDER_REFLECT);
  cv::Mat out = quantise(ideal, 0.0, look.noise, 8, look.seed, frame);
  if (look.jpeg_quality > 0) {
    std::vector<unsigned char> buf;
    cv::imencode(".jpg", out, buf, {cv::IMWRITE_JPEG_QUALITY, look.jpeg_quality});
    out = cv::imdecode(buf, cv::IMREAD_GRAYSCALE);
  }
  return out;
}

namespace {

/// The top-most bead of a frame over a point (render_beads' depth rule), from buckets
/// of the discs one diameter wide.
class TopBead {
 public:
  explicit TopBead(const ProjectedBeads& a) : a_(a) {
    for (const double d : a.diameter) cell_ = std::max(cell_, d);
    // A dense grid of cells over the discs' extent (the beads lie within the image,
    // give or take a diameter: project_beads drops the rest).
    for (std::size_t k = 0; k < a.x.size(); ++k) {
      const auto [kx, ky] = key(a.x[k], a.y[k]);
      if (k == 0 || kx < cx0_) cx0_ = kx;
      if (k == 0 || ky < cy0_) cy0_ = ky;
      if (k == 0 || kx > cx1_) cx1_ = kx;
      if (k == 0 || ky > cy1_) cy1_ = ky;
    }
    ncx_ = cx1_ - cx0_ + 1;
    buckets_.resize(static_cast<std::size_t>(std::max(0L, ncx_ * (cy1_ - cy0_ + 1))));
    for (std::size_t k = 0; k < a.x.size(); ++k) {
      const auto [kx, ky] = key(a.x[k], a.y[k]);
      buckets_[static_cast<std::size_t>((ky - cy0_) * ncx_ + (kx - cx0_))].push_back(k);
    }
  }

  /// The index of the top-most bead covering (x, y); none: a.x.size().
  std::size_t at(double x, double y) const {
    const auto [cx, cy] = key(x, y);
    double best = -1e300;
    std::size_t seen = a_.x.size();
    for (long dy = -1; dy <= 1; ++dy)
      for (long dx = -1; dx <= 1; ++dx) {
        const long kx = cx + dx, ky = cy + dy;
        if (kx < cx0_ || kx > cx1_ || ky < cy0_ || ky > cy1_) continue;
        for (const std::size_t k : buckets_[static_cast<std::size_t>((ky - cy0_) * ncx_ + (kx - cx0_))]) {
          const double R = 0.5 * a_.diameter[k];
          const double rho2 = (x - a_.x[k]) * (x - a_.x[k]) + (y - a_.y[k]) * (y - a_.y[k]);
          if (rho2 >= R * R) continue;
          const double h = a_.top[k] - R + std::sqrt(R * R - rho2);
          if (h > best) {
            best = h;
            seen = k;
          }
        }
      }
    return seen;
  }

 private:
  std::pair<long, long> key(double x, double y) const {
    return {static_cast<long>(std::floor(x / cell_)), static_cast<long>(std::floor(y / cell_))};
  }
  const ProjectedBeads& a_;
  double cell_ = 1.0;
  long cx0_ = 0, cy0_ = 0, cx1_ = -1, cy1_ = -1, ncx_ = 0;
  std::vector<std::vector<std::size_t>> buckets_;
};

/// Masked for the camera's truth: beyond the cup radius or on the vane.
bool masked_at(double x, double y, const CupImage& im, int blades, double vane_angle_a) {
  return std::hypot(x - im.centre_x_px, y - im.centre_y_px) > im.cup_radius_px ||
         (blades > 0 &&
          inside_vane(x, y, im.centre_x_px, im.centre_y_px, vane_angle_a, blades, im.vane_half_width_px,
                      im.vane_radius_px));
}

}  // namespace

core::VectorField visible_motion(const ProjectedBeads& a, const ProjectedBeads& b, const std::vector<double>& xs,
                                 const std::vector<double>& ys, const CupImage& im, int blades, double vane_angle_a) {
  core::VectorField f;
  f.x_px = xs;
  f.y_px = ys;
  f.resize_to_grid();
  const TopBead top(a);
  std::map<std::int64_t, std::size_t> in_b;
  for (std::size_t k = 0; k < b.id.size(); ++k) in_b.emplace(b.id[k], k);
  for (std::size_t i = 0; i < ys.size(); ++i) {
    for (std::size_t j = 0; j < xs.size(); ++j) {
      const std::size_t n = f.index(i, j);
      const double x = xs[j], y = ys[i];
      f.u_px[n] = f.v_px[n] = 0.0f;
      f.peak[n] = 1.0f;
      f.peak_ratio[n] = 10.0f;
      if (masked_at(x, y, im, blades, vane_angle_a)) {
        f.flag[n] = core::VectorFlag::kMasked;
        continue;
      }
      const std::size_t seen_k = top.at(x, y);
      const auto hit = seen_k < a.x.size() ? in_b.find(a.id[seen_k]) : in_b.end();
      if (hit == in_b.end()) {
        f.flag[n] = core::VectorFlag::kInvalid;
        continue;
      }
      f.u_px[n] = static_cast<float>(b.x[hit->second] - a.x[seen_k]);
      f.v_px[n] = static_cast<float>(b.y[hit->second] - a.y[seen_k]);
      f.flag[n] = core::VectorFlag::kValid;
    }
  }
  return f;
}

VisibleBeads visible_beads(const ProjectedBeads& a, const ProjectedBeads& b, const CupImage& im, int blades,
                           double vane_angle_a) {
  VisibleBeads v;
  const TopBead top(a);
  std::map<std::int64_t, std::size_t> in_b;
  for (std::size_t k = 0; k < b.id.size(); ++k) in_b.emplace(b.id[k], k);
  for (std::size_t k = 0; k < a.x.size(); ++k) {
    if (masked_at(a.x[k], a.y[k], im, blades, vane_angle_a)) continue;
    // Its middle in view: the centre and four points a quarter diameter from it are its own.
    const double q = 0.25 * a.diameter[k];
    bool own = true;
    for (const auto& [dx, dy] : {std::pair{0.0, 0.0}, {q, 0.0}, {-q, 0.0}, {0.0, q}, {0.0, -q}})
      own = own && top.at(a.x[k] + dx, a.y[k] + dy) == k;
    if (!own) continue;
    const auto hit = in_b.find(a.id[k]);
    if (hit == in_b.end()) continue;
    v.x_px.push_back(a.x[k]);
    v.y_px.push_back(a.y[k]);
    v.u_px.push_back(b.x[hit->second] - a.x[k]);
    v.v_px.push_back(b.y[hit->second] - a.y[k]);
  }
  return v;
}

}  // namespace shearzone::synth
