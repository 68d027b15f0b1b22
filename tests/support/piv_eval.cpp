#include "support/piv_eval.hpp"

namespace shearzone::testing {

SynthPairRun run_piv_on_synth(const synth::SynthOptions& synth, const piv::PivOptions& options,
                              const cv::Mat& mask_a, const cv::Mat& mask_b) {
  synth::FrameGenerator gen(synth);
  const cv::Mat a = gen.next(), b = gen.next();
  const piv::PivEngine engine(options);
  SynthPairRun run;
  run.result = engine.process(a, b, mask_a, mask_b);
  run.resolved = gen.options();
  run.pair_scale = gen.frame_time(0).pair_scale;
  return run;
}

}  // namespace shearzone::testing
