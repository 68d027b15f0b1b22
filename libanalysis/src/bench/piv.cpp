#include "shearzone/bench/piv.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/piv/piv.hpp"
#include "shearzone/synth/generator.hpp"

namespace shearzone::bench {
namespace {

constexpr double kBorderPx = 48.0;

struct Score {
  double rms = 0, bias_u = 0, bias_v = 0, invalid_pct = 0, outlier_pct = 0;
};

/// Errors of a field against the generator's exact field (border excluded).
Score score(const core::VectorField& f, const synth::SynthOptions& resolved, double scale) {
  const synth::DisplacementField field(resolved.field);
  const double w = resolved.image.width_px, h = resolved.image.height_px;
  double s2 = 0, su = 0, sv = 0;
  std::size_t n = 0, invalid = 0, outliers = 0;
  for (std::size_t i = 0; i < f.ny(); ++i)
    for (std::size_t j = 0; j < f.nx(); ++j) {
      const double x = f.x_px[j], y = f.y_px[i];
      if (x < kBorderPx || y < kBorderPx || x > w - 1 - kBorderPx || y > h - 1 - kBorderPx) continue;
      const std::size_t k = f.index(i, j);
      if (f.flag[k] == core::VectorFlag::kMasked) continue;
      const auto d = field(x, y);
      const double eu = f.u_px[k] - scale * d[0], ev = f.v_px[k] - scale * d[1];
      s2 += eu * eu + ev * ev;
      su += eu;
      sv += ev;
      ++n;
      invalid += f.flag[k] == core::VectorFlag::kInvalid;
      outliers += std::hypot(eu, ev) > 0.5;
    }
  Score s;
  if (n == 0) return s;
  s.rms = std::sqrt(s2 / n);
  s.bias_u = su / n;
  s.bias_v = sv / n;
  s.invalid_pct = 100.0 * invalid / n;
  s.outlier_pct = 100.0 * outliers / n;
  return s;
}

struct Pair {
  cv::Mat a, b;
  synth::SynthOptions resolved;
  double scale = 1.0;
};

Pair render(const synth::SynthOptions& o) {
  synth::FrameGenerator g(o);
  Pair p;
  p.a = g.next();
  p.b = g.next();
  p.resolved = g.options();
  p.scale = g.frame_time(0).pair_scale;
  return p;
}

using io::format_number;
std::string fixed(double v, int digits) { return fmt::format("{:.{}f}", v, digits); }

}  // namespace

BenchPivSummary run_piv_bench(const BenchPivOptions& o, const core::Metadata& header,
                              const core::ProgressCallback& progress) {
  if (o.timing_repeats < 1 || o.timing_repeats > 1000)
    throw ConfigError(fmt::format("bench piv: --repeats {}: expected 1..1000", o.timing_repeats));
  io::AtomicOutputSet out(o.out_dir, o.force);
  out.check("piv_speed_accuracy.csv");
  out.check("piv_failure_map.csv");

  // Step 1: the settings grid.
  std::vector<piv::PivOptions> grid;  // every other option at its default
  const std::vector<std::vector<int>> lists =
      o.quick ? std::vector<std::vector<int>>{{64, 32, 16}}
              : std::vector<std::vector<int>>{{64, 32, 16}, {32, 16}, {64, 32, 16, 8}};
  const std::vector<piv::Interpolation> interps =
      o.quick ? std::vector<piv::Interpolation>{piv::Interpolation::kBilinear, piv::Interpolation::kBSpline5}
              : std::vector<piv::Interpolation>{piv::Interpolation::kBilinear, piv::Interpolation::kBicubic,
                                                piv::Interpolation::kBSpline, piv::Interpolation::kBSpline5};
  for (const auto& l : lists)
    for (auto in : interps)
      for (auto sp : {piv::Subpixel::kGauss3, piv::Subpixel::kGauss2D})
        for (int rep : {0, 1}) {
          if (sp == piv::Subpixel::kGauss2D && (in != piv::Interpolation::kBSpline5 || rep != 1)) continue;
          piv::PivOptions po;
          po.windows_px = l;
          po.interpolation = in;
          po.subpixel = sp;
          po.final_pass_repeats = rep;
          grid.push_back(po);
        }

  // Every preset is a setting of the chart (the quick grid lacks some).
  for (const auto& pr : piv::piv_presets()) {
    bool have = false;
    for (const auto& po : grid) have |= pr.matches(po);
    if (!have) pr.apply(grid.emplace_back());
  }

  // Step 2: failure-map studies (512 x 512, default settings).
  struct Study {
    std::string name, unit;
    std::vector<double> values;
  };
  const std::vector<Study> studies = {
      {"displacement", "px", o.quick ? std::vector<double>{1, 8, 24, 40} : std::vector<double>{0.5, 2, 4, 8, 12, 16, 20, 24, 28, 32, 36, 40, 48, 56, 64}},
      {"density", "particles_per_px", o.quick ? std::vector<double>{0.005, 0.02} : std::vector<double>{0.002, 0.005, 0.01, 0.02, 0.05, 0.1}},
      {"noise", "fraction_of_full_scale", o.quick ? std::vector<double>{0.0, 0.1} : std::vector<double>{0.0, 0.02, 0.05, 0.1, 0.2}},
      {"bead_diameter", "px", o.quick ? std::vector<double>{8, 16} : std::vector<double>{6, 8, 12, 16, 20, 24}}};
  std::size_t total = grid.size();
  for (const auto& s : studies) total += s.values.size();
  std::size_t done = 0;

  // Step 3: speed against accuracy.
  synth::SynthOptions big;
  big.image.width_px = o.quick ? 960 : o.width_px;
  big.image.height_px = o.quick ? 540 : o.height_px;
  big.field.kind = synth::FieldKind::kShearZone;
  big.field.r0_px = 200;
  big.field.w_px = 80;
  big.field.U0_px = 4;
  big.image.seed = 2024;
  const Pair pair = render(big);
  core::Metadata meta = header;
  meta.emplace_back("bench", fmt::format("synthetic {}x{} shear-zone pair (r0 200 px, w 80 px, U0 4 "
                                         "px, 3 px particles, 0.02 ppp, noise 0.01); {} px border "
                                         "excluded; time = median of {} runs",
                                         big.image.width_px, big.image.height_px, format_number(kBorderPx),
                                         o.timing_repeats));
  std::vector<std::vector<std::string>> rows;
  std::string best;
  for (const piv::PivOptions& po : grid) {
    const piv::PivEngine engine(po);
    std::vector<double> times;
    piv::PivResult r;
    for (int k = 0; k < o.timing_repeats; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      r = engine.process(pair.a, pair.b);
      times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(times.begin(), times.end());
    const double t = times[times.size() / 2];
    const Score sc = score(r.field, pair.resolved, pair.scale);
    std::string preset;
    for (const auto& pr : piv::piv_presets())
      if (pr.matches(po)) preset = pr.name;
    const std::string windows = fmt::format("{}", fmt::join(po.windows_px, "-"));
    std::string name = fmt::format("{} {} {} r{}", windows, piv::interpolation_name(po.interpolation),
                                   piv::subpixel_name(po.subpixel), po.final_pass_repeats);
    if (po.predictor_smoothing != piv::PivOptions{}.predictor_smoothing)
      name += " s" + format_number(po.predictor_smoothing);
    if (po.predictor_fit != piv::PivOptions{}.predictor_fit)
      name += std::string(" ") + piv::predictor_fit_name(po.predictor_fit);
    rows.push_back({name, windows, piv::interpolation_name(po.interpolation), piv::subpixel_name(po.subpixel),
                    std::to_string(po.final_pass_repeats), fixed(t, 4), fixed(1.0 / t, 3), fixed(sc.rms, 4),
                    fixed(sc.bias_u, 4), fixed(sc.bias_v, 4), fixed(sc.invalid_pct, 2), preset});
    if (preset == "default")  // the defaults (a test holds them equal)
      best = fmt::format("default {}: {:.3f} s per pair ({:.2f} pairs/s), RMS {:.4f} px", name, t,
                         1.0 / t, sc.rms);
    if (progress) progress(++done, total);
  }
  {
    io::CsvWriter w(out.add("piv_speed_accuracy.csv").stream(), meta,
                    {"setting", "windows_px", "interpolation", "subpixel", "repeats",
                     "seconds_per_pair_s", "pairs_per_s", "rms_error_px", "bias_u_px", "bias_v_px",
                     "invalid_percent", "preset"});
    for (const auto& r : rows) w.row(r);
  }

  // Step 4: failure map.
  core::Metadata fmeta = header;
  fmeta.emplace_back("bench", "default PIV settings on 512x512 synthetic pairs; 48 px border "
                              "excluded; outlier = error > 0.5 px");
  io::CsvWriter fw(out.add("piv_failure_map.csv").stream(), fmeta,
                   {"study", "unit", "value", "rms_error_px", "bias_u_px", "bias_v_px",
                    "invalid_percent", "outlier_percent"});
  const piv::PivEngine engine{piv::PivOptions{}};
  for (const auto& st : studies)
    for (double v : st.values) {
      synth::SynthOptions s;
      s.image.seed = 77;
      if (st.name == "displacement") {
        s.field.u_px = v;
        s.field.v_px = 0.3 * v;
      } else if (st.name == "density") {
        s.particles.density_ppp = v;
        s.field.u_px = 2.3;
        s.field.v_px = -1.2;
      } else if (st.name == "noise") {
        s.image.noise = v;
        s.field.u_px = 2.3;
        s.field.v_px = -1.2;
      } else {
        s.texture = synth::TextureKind::kBeads;
        s.beads.diameter_px = v;
        s.field.kind = synth::FieldKind::kShearZone;
        s.field.r0_px = 120;
        s.field.U0_px = 0.5 * v;
        s.field.w_px = 2 * v;
      }
      const Pair p = render(s);
      const Score sc = score(engine.process(p.a, p.b).field, p.resolved, p.scale);
      fw.row(std::vector<std::string>{st.name, st.unit, format_number(v), fixed(sc.rms, 4),
                                      fixed(sc.bias_u, 4), fixed(sc.bias_v, 4), fixed(sc.invalid_pct, 2),
                                      fixed(sc.outlier_pct, 2)});
      if (progress) progress(++done, total);
    }
  out.commit_all();
  BenchPivSummary sum;
  sum.files = out.final_paths();
  sum.best_line = best;
  return sum;
}

}  // namespace shearzone::bench
