// tests/support/piv_eval.hpp: run PIV on a synthetic pair and score it against the
// generator's exact field.
#pragma once

#include <cmath>
#include <cstddef>

#include "shearzone/piv/piv.hpp"
#include "shearzone/synth/generator.hpp"

namespace shearzone::testing {

struct PivScore {
  double bias_u = 0, bias_v = 0;  ///< mean error, px
  double rms = 0;                 ///< sqrt(mean |error|^2), px
  std::size_t n = 0;              ///< vectors scored (unmasked, inside the border)
  std::size_t valid = 0;          ///< of which flagged valid
};

/// Border excluded from scoring, px (48 px, as in the accuracy gates of docs/piv.md).
constexpr double kScoreBorderPx = 48.0;

/// A processed synthetic pair and what is needed to score it.
struct SynthPairRun {
  piv::PivResult result;
  synth::SynthOptions resolved;  ///< the generator's options (centre resolved)
  double pair_scale = 1.0;       ///< s_0: the pair's displacement scale
};

/// Renders the first pair of `synth` and processes it (masks optional).
SynthPairRun run_piv_on_synth(const synth::SynthOptions& synth, const piv::PivOptions& piv,
                              const cv::Mat& mask_a = {}, const cv::Mat& mask_b = {});

/// Scores a field against the exact field, skipping masked vectors and the border.
/// `keep(x, y)` may exclude more points.
template <class Keep>
PivScore score(const SynthPairRun& run, Keep keep) {
  const core::VectorField& f = run.result.field;
  const synth::DisplacementField field(run.resolved.field);
  const double s = run.pair_scale;
  const double w = run.resolved.image.width_px, h = run.resolved.image.height_px;
  PivScore r;
  double su = 0, sv = 0, s2 = 0;
  for (std::size_t i = 0; i < f.ny(); ++i)
    for (std::size_t j = 0; j < f.nx(); ++j) {
      const double x = f.x_px[j], y = f.y_px[i];
      if (x < kScoreBorderPx || y < kScoreBorderPx || x > w - 1 - kScoreBorderPx ||
          y > h - 1 - kScoreBorderPx || !keep(x, y))
        continue;
      const std::size_t k = f.index(i, j);
      if (f.flag[k] == core::VectorFlag::kMasked) continue;
      const auto d = field(x, y);
      const double eu = f.u_px[k] - s * d[0], ev = f.v_px[k] - s * d[1];
      su += eu;
      sv += ev;
      s2 += eu * eu + ev * ev;
      ++r.n;
      r.valid += f.flag[k] == core::VectorFlag::kValid;
    }
  if (r.n) {
    r.bias_u = su / r.n;
    r.bias_v = sv / r.n;
    r.rms = std::sqrt(s2 / r.n);
  }
  return r;
}

inline PivScore score(const SynthPairRun& run) {
  return score(run, [](double, double) { return true; });
}

}  // namespace shearzone::testing
