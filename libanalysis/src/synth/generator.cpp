#include "shearzone/synth/generator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <fmt/format.h>

#include "shearzone/core/check.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/point_cells.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::synth {
namespace {

using io::format_number;

void require(bool ok, const std::string& what, double value, const std::string& rule) {
  if (!ok) throw ConfigError(fmt::format("{} = {}: {}", what, format_number(value), rule));
}

/// Poisson-disk sampling (Bridson 2007, "Fast Poisson disk sampling in arbitrary
/// dimensions"): points at least `r` apart filling the rectangle, k = 30 candidates
/// per active point. Deterministic for a given generator state.
void poisson_disk(double x0, double y0, double x1, double y1, double r, std::mt19937_64& rng,
                  std::vector<double>& xs, std::vector<double>& ys) {
  const double cell = r / std::sqrt(2.0);
  const int gw = static_cast<int>(std::ceil((x1 - x0) / cell)) + 1;
  const int gh = static_cast<int>(std::ceil((y1 - y0) / cell)) + 1;
  std::vector<int> grid(static_cast<std::size_t>(gw) * gh, -1);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<int> active;
  auto insert = [&](double px, double py) {
    const int idx = static_cast<int>(xs.size());
    xs.push_back(px);
    ys.push_back(py);
    const int cx = static_cast<int>((px - x0) / cell), cy = static_cast<int>((py - y0) / cell);
    grid[static_cast<std::size_t>(cy) * gw + cx] = idx;
    active.push_back(idx);
  };
  insert(x0 + u01(rng) * (x1 - x0), y0 + u01(rng) * (y1 - y0));
  while (!active.empty()) {
    const std::size_t pick = static_cast<std::size_t>(u01(rng) * active.size()) % active.size();
    const int a = active[pick];
    bool found = false;
    for (int attempt = 0; attempt < 30; ++attempt) {
      const double ang = 2.0 * std::numbers::pi * u01(rng);
      const double rad = r * (1.0 + u01(rng));
      const double px = xs[static_cast<std::size_t>(a)] + rad * std::cos(ang);
      const double py = ys[static_cast<std::size_t>(a)] + rad * std::sin(ang);
      if (px < x0 || px >= x1 || py < y0 || py >= y1) continue;
      const int cx = static_cast<int>((px - x0) / cell), cy = static_cast<int>((py - y0) / cell);
      bool ok = true;
      for (int gy = std::max(0, cy - 2); ok && gy <= std::min(gh - 1, cy + 2); ++gy)
        for (int gx = std::max(0, cx - 2); ok && gx <= std::min(gw - 1, cx + 2); ++gx) {
          const int o = grid[static_cast<std::size_t>(gy) * gw + gx];
          if (o < 0) continue;
          const double dx = xs[static_cast<std::size_t>(o)] - px;
          const double dy = ys[static_cast<std::size_t>(o)] - py;
          if (dx * dx + dy * dy < r * r) ok = false;
        }
      if (ok) {
        insert(px, py);
        found = true;
        break;
      }
    }
    if (!found) {
      active[pick] = active.back();
      active.pop_back();
    }
  }
}

}  // namespace

const char* texture_kind_name(TextureKind kind) {
  return kind == TextureKind::kParticles ? "particles" : "beads";
}

void SynthOptions::validate() const {
  field.validate();
  require(image.width_px >= 8 && image.width_px <= 8192, "ImageOptions::width_px",
          image.width_px, "must satisfy 8 <= width_px <= 8192 (time and memory stay under 10 s and 1 GB a pair)");
  require(image.height_px >= 8 && image.height_px <= 8192, "ImageOptions::height_px",
          image.height_px, "must satisfy 8 <= height_px <= 8192 (time and memory stay under 10 s and 1 GB a pair)");
  require(image.noise >= 0 && image.noise <= 0.5, "ImageOptions::noise", image.noise,
          "must satisfy 0 <= noise <= 0.5 (fraction of full scale)");
  require(image.background >= 0 && image.background <= 1, "ImageOptions::background",
          image.background, "must satisfy 0 <= background <= 1 (fraction of full scale)");
  require(image.bit_depth == 8 || image.bit_depth == 16, "ImageOptions::bit_depth",
          image.bit_depth, "must be 8 or 16");
  if (texture == TextureKind::kParticles) {
    require(particles.diameter_px >= 0.5 && particles.diameter_px <= 50,
            "ParticleOptions::diameter_px", particles.diameter_px,
            "must satisfy 0.5 <= diameter_px <= 50");
    require(particles.density_ppp > 0 && particles.density_ppp <= 0.2,
            "ParticleOptions::density_ppp", particles.density_ppp,
            "must satisfy 0 < density_ppp <= 0.2 (particles per pixel)");
    require(particles.intensity_min >= 0 && particles.intensity_min <= particles.intensity_max,
            "ParticleOptions::intensity_min", particles.intensity_min,
            "must satisfy 0 <= intensity_min <= intensity_max");
    require(particles.intensity_max <= 10, "ParticleOptions::intensity_max",
            particles.intensity_max, "must be <= 10 (fraction of full scale; > 1 saturates)");
  } else {
    require(beads.diameter_px >= 3 && beads.diameter_px <= 200, "BeadOptions::diameter_px",
            beads.diameter_px, "must satisfy 3 <= diameter_px <= 200");
    require(beads.min_spacing >= 0.5 && beads.min_spacing <= 1.2, "BeadOptions::min_spacing",
            beads.min_spacing, "must satisfy 0.5 <= min_spacing <= 1.2 (fraction of diameter)");
    require(beads.albedo_min >= 0 && beads.albedo_min <= beads.albedo_max &&
                beads.albedo_max <= 1,
            "BeadOptions::albedo_min", beads.albedo_min,
            "must satisfy 0 <= albedo_min <= albedo_max <= 1");
    require(beads.height_jitter >= 0 && beads.height_jitter <= 1, "BeadOptions::height_jitter",
            beads.height_jitter, "must satisfy 0 <= height_jitter <= 1");
    require(beads.shading.supersample >= 1 && beads.shading.supersample <= 8,
            "BeadShading::supersample", beads.shading.supersample, "must satisfy 1..8");
  }
  require(sequence.frames >= 2 && sequence.frames <= 1000000, "SequenceOptions::frames",
          sequence.frames, "must satisfy 2 <= frames <= 1000000");
  require(sequence.fps > 0 && std::isfinite(sequence.fps), "SequenceOptions::fps", sequence.fps,
          "must be > 0");
  require(sequence.oscillate_f_Hz >= 0 && sequence.oscillate_f_Hz < 0.5 * sequence.fps,
          "SequenceOptions::oscillate_f_Hz", sequence.oscillate_f_Hz,
          "must satisfy 0 <= f < fps/2 (Nyquist)");
  require(sequence.jitter_px >= 0 && sequence.jitter_px <= 20, "SequenceOptions::jitter_px (--jitter-px)", sequence.jitter_px,
          "must satisfy 0 <= jitter <= 20 px");
  require(vane.blades >= 0 && vane.blades <= 64, "VaneOptions::blades", vane.blades,
          "must satisfy 0 <= blades <= 64");
  if (vane.blades > 0) {
    require(vane.half_width_px > 0, "VaneOptions::half_width_px", vane.half_width_px,
            "must be > 0");
    require(vane.radius_px > vane.half_width_px, "VaneOptions::radius_px", vane.radius_px,
            "must be > half_width_px");
    require(std::isfinite(vane.phi0_rad), "VaneOptions::phi0_rad", vane.phi0_rad,
            "must be finite");
    require(std::isfinite(vane.angle0_deg), "VaneOptions::angle0_deg", vane.angle0_deg,
            "must be finite");
    require(vane.level >= 0 && vane.level <= 1, "VaneOptions::level", vane.level,
            "must satisfy 0 <= level <= 1");
  }
}

core::Metadata SynthOptions::to_metadata() const {
  core::Metadata m{{"synth_texture", texture_kind_name(texture)},
                   {"image_size_px", fmt::format("{}x{}", image.width_px, image.height_px)},
                   {"noise_fraction_of_full_scale", format_number(image.noise)},
                   {"background_fraction_of_full_scale", format_number(image.background)},
                   {"bit_depth", std::to_string(image.bit_depth)},
                   {"seed", std::to_string(image.seed)}};
  if (texture == TextureKind::kParticles) {
    m.emplace_back("particle_diameter_px", format_number(particles.diameter_px) + " (e^-2 diameter)");
    m.emplace_back("particle_density_ppp", format_number(particles.density_ppp));
    m.emplace_back("particle_intensity_range",
                   format_number(particles.intensity_min) + "," + format_number(particles.intensity_max));
  } else {
    m.emplace_back("bead_diameter_px", format_number(beads.diameter_px));
    m.emplace_back("bead_min_spacing_fraction_of_d", format_number(beads.min_spacing));
    m.emplace_back("bead_albedo_range",
                   format_number(beads.albedo_min) + "," + format_number(beads.albedo_max));
    m.emplace_back("bead_height_jitter_fraction_of_d", format_number(beads.height_jitter));
  }
  for (auto& kv : field.to_metadata()) m.push_back(std::move(kv));
  m.emplace_back("frames", std::to_string(sequence.frames));
  m.emplace_back("fps_Hz", format_number(sequence.fps));
  m.emplace_back("oscillate_f_Hz", format_number(sequence.oscillate_f_Hz));
  if (sequence.jitter_px > 0)
    m.emplace_back("jitter_px", fmt::format("{} (each frame a Gaussian step of this per component about the field; "
                                            "the truth is the field)",
                                            format_number(sequence.jitter_px)));
  if (vane.blades > 0) {
    m.emplace_back("vane", fmt::format("blades={}, half_width_px={}, radius_px={}", vane.blades,
                                       format_number(vane.half_width_px), format_number(vane.radius_px)));
    m.emplace_back("vane_phi0_rad", format_number(vane.phi0_rad));
    m.emplace_back("vane_angle0_deg", format_number(vane.angle0_deg));
  }
  m.emplace_back("placement",
                 "symmetric about the midpoint: A = p - d(p)/2, B = p + d(p)/2; later frames by "
                 "the implicit midpoint rule");
  return m;
}

namespace {
SynthOptions resolved(SynthOptions o) {
  o.validate();
  o.field.resolve_centre(o.image.width_px, o.image.height_px);
  return o;
}
}  // namespace

FrameGenerator::FrameGenerator(SynthOptions options)
    : opt_(resolved(std::move(options))), field_(opt_.field),
      jitter_rng_(splitmix64(opt_.image.seed ^ 0x6a09e667f3bcc908ULL)) {
  place_tracers();
}

FrameTime FrameGenerator::frame_time(int k) const {
  FrameTime ft;
  ft.index = k;
  ft.t_s = k / opt_.sequence.fps;
  const double f = opt_.sequence.oscillate_f_Hz;
  if (f > 0) {
    ft.phi_rad = opt_.vane.phi0_rad * std::sin(2.0 * std::numbers::pi * f * ft.t_s);
    ft.pair_scale =
        std::cos(2.0 * std::numbers::pi * f * (ft.t_s + 0.5 / opt_.sequence.fps));
  }
  return ft;
}

void FrameGenerator::place_tracers() {
  const int W = opt_.image.width_px, H = opt_.image.height_px;
  const bool particles = opt_.texture == TextureKind::kParticles;
  const double size = particles ? opt_.particles.diameter_px : opt_.beads.diameter_px;
  // Distance beyond which a tracer cannot touch the image (5 sigma for particles).
  const double reach = particles ? 1.25 * size + 2.0 : 0.5 * size + 2.0;

  // Step 1: the sampling domain.
  if (opt_.field.kind == FieldKind::kUniform) {
    const double m = reach + 2.0 * field_.max_speed(W, H) + 2.0;
    dom_x0_ = -0.5 - m;
    dom_y0_ = -0.5 - m;
    dom_x1_ = W - 0.5 + m;
    dom_y1_ = H - 0.5 + m;
    periodic_ = opt_.sequence.frames > 2;
  } else {
    const double cx = opt_.field.centre_x_px, cy = opt_.field.centre_y_px;
    double rmax = 0;
    for (double x : {-0.5, W - 0.5})
      for (double y : {-0.5, H - 0.5}) rmax = std::max(rmax, std::hypot(x - cx, y - cy));
    const double R = rmax + reach + field_.max_speed(W, H) + 2.0;
    dom_x0_ = cx - R;
    dom_y0_ = cy - R;
    dom_x1_ = cx + R;
    dom_y1_ = cy + R;
    periodic_ = false;
  }

  // Step 2: midpoints p of the first pair.
  std::mt19937_64 rng(splitmix64(opt_.image.seed));
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<double> px, py;
  const double area = (dom_x1_ - dom_x0_) * (dom_y1_ - dom_y0_);
  // Time and memory stay bounded: the domain grows with the displacement, and every
  // tracer costs about 40 bytes and a render per frame.
  constexpr double kMaxTracers = 2e7;
  const double expected = particles ? opt_.particles.density_ppp * area
                                    : area / (0.5 * std::pow(opt_.beads.min_spacing * size, 2));
  if (!(expected <= kMaxTracers))
    throw ConfigError(fmt::format(
        "synth: the field carries tracers over a {:.3g} x {:.3g} px domain ({:.3g} tracers, at most "
        "{:.0e}): reduce the displacement per frame (--u, --v, --U0, --omega) or the image size",
        dom_x1_ - dom_x0_, dom_y1_ - dom_y0_, expected, kMaxTracers));
  if (particles) {
    std::poisson_distribution<long long> count(opt_.particles.density_ppp * area);
    const long long n = count(rng);
    px.resize(static_cast<std::size_t>(n));
    py.resize(static_cast<std::size_t>(n));
    brightness_.resize(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < px.size(); ++i) {
      px[i] = dom_x0_ + u01(rng) * (dom_x1_ - dom_x0_);
      py[i] = dom_y0_ + u01(rng) * (dom_y1_ - dom_y0_);
      brightness_[i] = opt_.particles.intensity_min +
                       u01(rng) * (opt_.particles.intensity_max - opt_.particles.intensity_min);
    }
  } else {
    poisson_disk(dom_x0_, dom_y0_, dom_x1_, dom_y1_, opt_.beads.min_spacing * size, rng, px, py);
    brightness_.resize(px.size());
    top_.resize(px.size());
    for (std::size_t i = 0; i < px.size(); ++i) {
      brightness_[i] =
          opt_.beads.albedo_min + u01(rng) * (opt_.beads.albedo_max - opt_.beads.albedo_min);
      top_[i] = opt_.beads.height_jitter * size * u01(rng);
    }
  }

  // Step 3: frame 0 at p - s_0 d(p)/2.
  const double s0 = frame_time(0).pair_scale;
  x_.resize(px.size());
  y_.resize(py.size());
  for (std::size_t i = 0; i < px.size(); ++i) {
    const auto d = field_(px[i], py[i]);
    x_[i] = px[i] - 0.5 * s0 * d[0];
    y_[i] = py[i] - 0.5 * s0 * d[1];
  }
}

void FrameGenerator::advance(int k) {
  // Implicit midpoint rule: solve m = x + s d(m)/2 by fixed-point iteration (a
  // contraction while s |grad d| / 2 < 1), then x' = 2m - x.
  const double s = frame_time(k).pair_scale;
  constexpr int kMaxIterations = 200;
  constexpr double kTolerancePx = 1e-12;
  bool diverged = false;
#pragma omp parallel for schedule(static) reduction(|| : diverged)
  for (std::size_t i = 0; i < x_.size(); ++i) {
    double mx = x_[i], my = y_[i];
    bool converged = false;
    for (int it = 0; it < kMaxIterations; ++it) {
      const auto d = field_(mx, my);
      const double nx = x_[i] + 0.5 * s * d[0], ny = y_[i] + 0.5 * s * d[1];
      const double change = std::abs(nx - mx) + std::abs(ny - my);
      mx = nx;
      my = ny;
      if (change < kTolerancePx) {
        converged = true;
        break;
      }
    }
    if (!converged) diverged = true;
    x_[i] = 2.0 * mx - x_[i];
    y_[i] = 2.0 * my - y_[i];
  }
  if (diverged)
    throw ConfigError(
        "synth: the displacement changes too fast in space for the midpoint rule (it needs "
        "|grad d| < 2 per frame); reduce omega, U0 or increase w");
  if (opt_.sequence.jitter_px > 0) {  // serial: the same steps for any thread count
    std::normal_distribution<double> step(0.0, opt_.sequence.jitter_px);
    for (std::size_t i = 0; i < x_.size(); ++i) {
      x_[i] += step(jitter_rng_);
      y_[i] += step(jitter_rng_);
    }
  }
}

void FrameGenerator::wrap() {
  if (!periodic_) return;
  const double wx = dom_x1_ - dom_x0_, wy = dom_y1_ - dom_y0_;
  for (std::size_t i = 0; i < x_.size(); ++i) {
    if (x_[i] < dom_x0_) x_[i] += wx;
    else if (x_[i] >= dom_x1_) x_[i] -= wx;
    if (y_[i] < dom_y0_) y_[i] += wy;
    else if (y_[i] >= dom_y1_) y_[i] -= wy;
  }
}

cv::Mat FrameGenerator::next_ideal() {
  SHEARZONE_CHECK(!done());
  const int k = next_;
  const cv::Size size(opt_.image.width_px, opt_.image.height_px);
  cv::Mat img;
  if (opt_.texture == TextureKind::kParticles) {
    img = render_particles(x_, y_, brightness_, size, opt_.particles.diameter_px);
  } else {
    img = render_beads(x_, y_, top_, brightness_, size, opt_.beads.diameter_px,
                       opt_.beads.shading);
  }
  if (opt_.vane.blades > 0) {
    const double angle =
        opt_.vane.angle0_deg * std::numbers::pi / 180.0 + frame_time(k).phi_rad;
    draw_vane(img, opt_.field.centre_x_px, opt_.field.centre_y_px, angle, opt_.vane.blades,
              opt_.vane.half_width_px, opt_.vane.radius_px, opt_.vane.level);
  }
  ++next_;
  if (next_ < opt_.sequence.frames) {
    // For k = 0 the midpoint of the step is exactly p (frame 0 is p - s_0 d(p)/2 and
    // the fixed point is unique), so frame 1 is p + s_0 d(p)/2 as promised.
    advance(k);
    wrap();
  }
  return img;
}

cv::Mat FrameGenerator::next() {
  const int k = next_;
  cv::Mat ideal = next_ideal();
  return quantise(ideal, opt_.image.background, opt_.image.noise, opt_.image.bit_depth,
                  splitmix64(opt_.image.seed + 0x5EEDull), static_cast<std::uint64_t>(k));
}

std::vector<TruthPoint> FrameGenerator::truth(double spacing_px, double scale) const {
  SHEARZONE_CHECK(spacing_px >= 1);
  std::vector<TruthPoint> out;
  const double off = 0.5 * (spacing_px - 1.0);
  for (double y = off; y <= opt_.image.height_px - 1; y += spacing_px)
    for (double x = off; x <= opt_.image.width_px - 1; x += spacing_px) {
      const auto d = field_(x, y);
      out.push_back({x, y, scale * d[0], scale * d[1]});
    }
  return out;
}

TracedPair traced_pair(const SynthOptions& options) {
  FrameGenerator gen(options);
  TracedPair p;
  p.xa = gen.tracer_x();
  p.ya = gen.tracer_y();
  p.a = gen.next();
  p.xb = gen.tracer_x();
  p.yb = gen.tracer_y();
  p.b = gen.next();
  return p;
}

std::vector<long> tracer_under(const std::vector<double>& tx, const std::vector<double>& ty,
                               const std::vector<double>& x, const std::vector<double>& y, double radius) {
  const double cell = 2 * radius;
  const core::PointCells cells(tx, ty, cell);
  std::vector<long> out(x.size(), -1);
  for (std::size_t k = 0; k < x.size(); ++k) {
    double best = radius * radius;
    int near = 0;
    cells.near(x[k], y[k], [&](std::size_t t) {
      const double d2 = (tx[t] - x[k]) * (tx[t] - x[k]) + (ty[t] - y[k]) * (ty[t] - y[k]);
      near += d2 < cell * cell;
      if (d2 < best) best = d2, out[k] = static_cast<long>(t);
    });
    if (near > 1) out[k] = -1;
  }
  return out;
}

}  // namespace shearzone::synth
