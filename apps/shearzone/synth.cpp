// `shearzone synth particles|beads`: synthetic frames with exact ground truth.
// Flags map one-to-one onto pipeline::SynthJobOptions; --config FILE.toml sets the
// same options by their long names (the command line wins).
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/pipeline/synth_job.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

/// Flags and the values they bind to, for one of the two texture subcommands.
struct SynthCli {
  pipeline::SynthJobOptions job;
  std::string out_dir;
  std::string config;
  std::string field = "uniform";
  std::vector<double> centre;     // x, y in px
  std::vector<double> vane;       // blades, half-width px, radius px
  std::vector<double> intensity;  // particles: min, max
  std::vector<double> albedo;     // beads: min, max
  std::int64_t seed = 1;
};

void add_common_options(CLI::App& c, SynthCli& s) {
  auto& o = s.job.synth;
  c.add_option("-o,--output", s.out_dir, "Output folder (created if missing)");
  c.add_option("--config", s.config, "TOML file setting any of these options by long name");
  c.add_flag("--force", s.job.force, "Replace existing output files");
  // Image
  c.add_option("--width", o.image.width_px, "Image width, px; range: 8..8192")
      ->capture_default_str();
  c.add_option("--height", o.image.height_px, "Image height, px; range: 8..8192")
      ->capture_default_str();
  c.add_option("--noise", o.image.noise,
               "Gaussian noise std, fraction of full scale; range: 0..0.5")
      ->capture_default_str();
  c.add_option("--background", o.image.background,
               "Background level, fraction of full scale; range: 0..1")
      ->capture_default_str();
  c.add_option("--bits", o.image.bit_depth,
               "Bits per pixel: 8 or 16; range: 8 or 16 (8 only for mp4 and avi)")
      ->capture_default_str();
  c.add_option("--seed", s.seed, "Random seed (placement, brightness, noise); range: >= 0")
      ->capture_default_str();
  // Field
  c.add_option("--field", s.field, "Displacement field: uniform, rotation, shear-zone")
      ->capture_default_str();
  c.add_option("--u", o.field.u_px, "uniform: x displacement per frame, px; range: -4096..4096")
      ->capture_default_str();
  c.add_option("--v", o.field.v_px,
               "uniform: y displacement per frame, px (y down); range: -4096..4096")
      ->capture_default_str();
  c.add_option("--centre", s.centre, "rotation/shear-zone/vane centre X,Y in px (default: image "
                                     "centre); range: any finite numbers (a far centre exceeds "
                                     "the 2e7-tracer limit)")
      ->expected(2)
      ->delimiter(',');
  c.add_option("--omega", o.field.omega_rad,
               "rotation: rad per frame, > 0 counter-clockwise as the camera sees it; "
               "range: -pi..pi")
      ->capture_default_str();
  c.add_option("--r0", o.field.r0_px, "shear-zone: rigid core radius, px; range: > 0, finite")
      ->capture_default_str();
  c.add_option("--w", o.field.w_px, "shear-zone: decay length, px; range: > 0, finite")
      ->capture_default_str();
  c.add_option("--U0", o.field.U0_px,
               "shear-zone: speed at r0, px per frame (> 0 CCW); range: -4096..4096")
      ->capture_default_str();
  // Sequence and vane
  c.add_option("--frames", o.sequence.frames,
               "Number of frames K (2 writes a pair A, B); range: 2..1000000")
      ->capture_default_str();
  c.add_option("--fps", o.sequence.fps, "Frame rate, Hz; range: > 0, finite")
      ->capture_default_str();
  c.add_option("--oscillate", o.sequence.oscillate_f_Hz,
               "Vane frequency f, Hz: displacement per frame scaled by cos(2 pi f t); "
               "range: 0 <= x < fps/2")
      ->capture_default_str();
  c.add_option("--jitter-px", o.sequence.jitter_px,
               "Random motion about the field: each frame every tracer takes an extra Gaussian step of this "
               "standard deviation per component, px (a known granular temperature); range: 0..20")
      ->capture_default_str();
  c.add_option("--vane", s.vane,
               "Draw a vane: BLADES,HALF_WIDTH_PX,RADIUS_PX; range: BLADES a whole number "
               "in 1..64, 0 < HALF_WIDTH_PX < RADIUS_PX")
      ->expected(3)
      ->delimiter(',');
  c.add_option("--phi0", o.vane.phi0_rad,
               "Vane amplitude phi0, rad: phi(t) = phi0 sin(2 pi f t); range: any finite number")
      ->capture_default_str();
  c.add_option("--vane-angle0-deg", o.vane.angle0_deg,
               "Direction of blade 0 at phi = 0, deg CCW from +x; range: any finite number")
      ->capture_default_str();
  c.add_option("--vane-level", o.vane.level,
               "Vane intensity, fraction of full scale; range: 0..1")
      ->capture_default_str();
  // Output
  c.add_option("--format", s.job.format, "png, tiff, mp4 or avi")->capture_default_str();
  c.add_option("--codec", s.job.video_codec, "FourCC for mp4: mp4v or avc1")
      ->capture_default_str();
  c.add_option("--truth-spacing", s.job.truth_spacing_px,
               "Grid spacing of truth.csv, px; range: >= 1")
      ->capture_default_str();
}

int run_synth(CLI::App& c, SynthCli& s, const Context& ctx) {
  configure(c, s.config, {"output"});

  auto& o = s.job.synth;
  o.field.kind = pipeline::synth_field_kind(s.field);
  if (!s.centre.empty()) {
    o.field.centre_x_px = s.centre[0];
    o.field.centre_y_px = s.centre[1];
  }
  if (!s.vane.empty()) {
    if (s.vane[0] != static_cast<int>(s.vane[0]) || s.vane[0] < 1)
      throw ConfigError(fmt::format("--vane: blade count {} must be a positive integer", s.vane[0]));
    o.vane.blades = static_cast<int>(s.vane[0]);
    o.vane.half_width_px = s.vane[1];
    o.vane.radius_px = s.vane[2];
  }
  if (!s.intensity.empty()) {
    o.particles.intensity_min = s.intensity[0];
    o.particles.intensity_max = s.intensity[1];
  }
  if (!s.albedo.empty()) {
    o.beads.albedo_min = s.albedo[0];
    o.beads.albedo_max = s.albedo[1];
  }
  if (s.seed < 0) throw ConfigError(fmt::format("--seed {}: must be >= 0", s.seed));
  o.image.seed = static_cast<std::uint64_t>(s.seed);
  s.job.out_dir = s.out_dir;

  core::ProgressReporter progress("synth: frames", ctx.level);
  const auto summary = pipeline::run_synth_job(s.job, ctx.header(), progress.callback());
  progress.finish();
  if (ctx.level == core::LogLevel::kVerbose)
    for (const auto& [key, value] : summary.resolved_options)
      std::fprintf(stderr, "synth: %s: %s\n", key.c_str(), value.c_str());
  if (ctx.level != core::LogLevel::kQuiet)
    std::printf("wrote %zu files to %s (%d frames, %zu %s)\n", summary.files.size(),
                s.job.out_dir.string().c_str(), summary.frames, summary.tracers,
                synth::texture_kind_name(o.texture));
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_synth(CLI::App& root, Context& ctx) {
  CLI::App* synth = root.add_subcommand("synth", "Render synthetic PIV inputs with exact ground truth");
  synth->require_subcommand(1);

  // Both texture subcommands share the options above; the state lives as long as
  // the returned closures.
  auto particles = std::make_shared<SynthCli>();
  auto beads = std::make_shared<SynthCli>();
  particles->job.synth.texture = synth::TextureKind::kParticles;
  beads->job.synth.texture = synth::TextureKind::kBeads;

  CLI::App* p = synth->add_subcommand("particles", "Gaussian tracer particles (PIV test images)");
  add_common_options(*p, *particles);
  p->add_option("--diameter", particles->job.synth.particles.diameter_px,
                "Particle image e^-2 diameter, px; range: 0.5..50")
      ->capture_default_str();
  p->add_option("--density", particles->job.synth.particles.density_ppp,
                "Particles per pixel; range: 0 < x <= 0.2")
      ->capture_default_str();
  p->add_option("--intensity", particles->intensity,
                "Peak intensity range MIN,MAX, fraction of full scale (default 0.6,1); "
                "range: 0 <= MIN <= MAX <= 10")
      ->expected(2)
      ->delimiter(',');

  CLI::App* b = synth->add_subcommand("beads", "Dense top view of shaded, specular beads");
  add_common_options(*b, *beads);
  b->add_option("--diameter", beads->job.synth.beads.diameter_px,
                "Bead diameter, px; range: 3..200")
      ->capture_default_str();
  b->add_option("--spacing", beads->job.synth.beads.min_spacing,
                "Smallest centre distance, fraction of the diameter; range: 0.5..1.2")
      ->capture_default_str();
  b->add_option("--albedo", beads->albedo,
                "Albedo range MIN,MAX (default 0.55,1); range: 0 <= MIN <= MAX <= 1")
      ->expected(2)
      ->delimiter(',');
  b->add_option("--height-jitter", beads->job.synth.beads.height_jitter,
                "Random bead height, fraction of the diameter; range: 0..1")
      ->capture_default_str();
  b->add_option("--supersample", beads->job.synth.beads.shading.supersample,
                "Anti-aliasing samples per pixel side; range: 1..8")
      ->capture_default_str();

  return {{p, [p, particles, &ctx] { return run_synth(*p, *particles, ctx); }},
          {b, [b, beads, &ctx] { return run_synth(*b, *beads, ctx); }}};
}

}  // namespace shearzone::apps
