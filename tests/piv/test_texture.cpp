// Windows sized to the texture and the gradient residual: bead displacements without the
// large-bead bias (issue 33's gate: 8-64 px per bead, mean within 1 %, >= 90 % valid).
#include <cmath>

#include <catch2/catch.hpp>

#include "shearzone/core/vector_field.hpp"
#include "shearzone/piv/piv.hpp"
#include "shearzone/piv/texture.hpp"
#include "shearzone/synth/generator.hpp"

using namespace shearzone;

namespace {

synth::SynthOptions bead_shift(double d, double u, double v, std::uint64_t seed) {
  synth::SynthOptions s;
  s.texture = synth::TextureKind::kBeads;
  s.beads.diameter_px = d;
  s.field.u_px = u;
  s.field.v_px = v;
  s.image.seed = seed;
  return s;
}

}  // namespace

TEST_CASE("the texture half-width is a fixed fraction of the bead diameter", "[piv]") {
  // Measured on synth beads 8-64 px: 0.21-0.23 diameters (kBeadDiameterPerHalfWidth).
  for (double d : {8.0, 24.0, 64.0}) {
    synth::FrameGenerator gen(bead_shift(d, 0, 0, 3));
    const double hw = piv::texture_half_width_px(gen.next());
    INFO("beads " << d << " px: half-width " << hw << " px");
    CHECK(hw * piv::kBeadDiameterPerHalfWidth == Approx(d).epsilon(0.1));
  }
  synth::SynthOptions particles;  // 3 px particles
  particles.image.seed = 3;
  synth::FrameGenerator gen(particles);
  CHECK(piv::texture_half_width_px(gen.next()) < 1.5);
}

TEST_CASE("windows sized to the texture scale by powers of two within the image", "[piv]") {
  const std::vector<int> base = {64, 32, 16};
  CHECK(piv::windows_for_texture(base, 1.0, {512, 512}) == base);
  CHECK(piv::windows_for_texture(base, 8.1, {512, 512}) == std::vector<int>{128, 64, 32});
  CHECK(piv::windows_for_texture(base, 15.0, {512, 512}) == std::vector<int>{256, 128, 64});
  CHECK(piv::windows_for_texture(base, 15.0, {200, 400}) == std::vector<int>{128, 64, 32});
  CHECK(piv::windows_for_texture(base, 100.0, {2000, 2000}) == std::vector<int>{256, 128, 64});
  CHECK(piv::windows_for_texture(base, std::nan(""), {512, 512}) == base);
}

TEST_CASE("beads of 6.5-10 px get a pass of 8 px windows, particles and larger beads do not", "[piv]") {
  const std::vector<int> base = {64, 32, 16};
  const auto hw = [](double bead_px) { return bead_px / piv::kBeadDiameterPerHalfWidth; };
  // 16 px windows span more than 1.6 beads of 7-9.9 px: one more pass, one bead wide.
  CHECK(piv::windows_for_texture(base, hw(7.1), {512, 512}) == std::vector<int>{64, 32, 16, 8});
  CHECK(piv::windows_for_texture(base, hw(9.9), {512, 512}) == std::vector<int>{64, 32, 16, 8});
  // Textures of 10.3-12 px (the demo study's clips of 10 px beads, 12 px beads): 16 px
  // windows, which measured better there.
  CHECK(piv::windows_for_texture(base, hw(10.3), {512, 512}) == base);
  CHECK(piv::windows_for_texture(base, hw(12.0), {512, 512}) == base);
  // Seeded particles (real pairs measure 2.9-5.3 px) keep 16 px windows.
  CHECK(piv::windows_for_texture(base, hw(5.3), {512, 512}) == base);
  CHECK(piv::windows_for_texture(base, hw(3.0), {512, 512}) == base);
  // Windows already one bead wide are left alone; no window below 8 px is added.
  CHECK(piv::windows_for_texture({32, 16, 8}, hw(8.0), {512, 512}) == std::vector<int>{32, 16, 8});
  CHECK(piv::windows_for_texture({16, 8}, hw(7.0), {512, 512}) == std::vector<int>{16, 8});
}

TEST_CASE("the predictor's fit is quadratic for beads of 6.5 px or more, Gaussian for particles", "[piv]") {
  const auto hw = [](double bead_px) { return bead_px / piv::kBeadDiameterPerHalfWidth; };
  CHECK(piv::predictor_fit_for_texture(hw(6.6)) == piv::PredictorFit::kQuadratic);
  CHECK(piv::predictor_fit_for_texture(hw(64)) == piv::PredictorFit::kQuadratic);
  CHECK(piv::predictor_fit_for_texture(hw(6.4)) == piv::PredictorFit::kGaussian);
  CHECK(piv::predictor_fit_for_texture(hw(3.0)) == piv::PredictorFit::kGaussian);
  CHECK(piv::predictor_fit_for_texture(std::nan("")) == piv::PredictorFit::kGaussian);  // not measured
  // Measured on shaded beads: 8 px beads read as 7.1-8.0 px of texture, above the limit.
  synth::FrameGenerator gen(bead_shift(8, 1.3, -0.6, 3));
  CHECK(piv::predictor_fit_for_texture(piv::texture_half_width_px(gen.next())) == piv::PredictorFit::kQuadratic);
}

// The gate of issue 33. Before: -0.5 % at 8 px, -3 % at 16, -8 % at 24, -19 % at 36,
// -28 % at 48 and -42 % at 64 px (u; v worse), with 84 % valid at 64 px.
TEST_CASE("bead shifts of 8-64 px beads are unbiased with the default settings", "[piv]") {
  constexpr double kU = 1.3, kV = -0.6;
  constexpr double kMaxRelBias = 0.01;   // the gate: mean within 1 % of the truth
  constexpr double kMinValid = 0.90;     // and >= 90 % of the vectors valid
  for (double d : {8.0, 16.0, 24.0, 36.0, 48.0, 64.0}) {
    synth::FrameGenerator gen(bead_shift(d, kU, kV, 3));
    const cv::Mat a = gen.next(), b = gen.next();
    piv::PivOptions o;
    const double hw = piv::texture_half_width_px(a);
    o.windows_px = piv::windows_for_texture(o.windows_px, hw, a.size());
    o.predictor_fit = piv::predictor_fit_for_texture(hw);  // as `piv` chooses them
    const auto r = piv::PivEngine(o).process(a, b);
    const auto& f = r.field;
    double su = 0, sv = 0;
    std::size_t n = 0;
    for (std::size_t k = 0; k < f.size(); ++k)
      if (f.flag[k] == core::VectorFlag::kValid) {
        su += f.u_px[k];
        sv += f.v_px[k];
        ++n;
      }
    REQUIRE(n > 0);
    const double mu = su / static_cast<double>(n), mv = sv / static_cast<double>(n);
    const double valid = static_cast<double>(n) / static_cast<double>(f.size());
    INFO("beads " << d << " px, windows " << o.windows_px.front() << ".." << o.windows_px.back() << ": u " << mu
                  << ", v " << mv << ", valid " << valid);
    CHECK(std::abs(mu / kU - 1) <= kMaxRelBias);
    CHECK(std::abs(mv / kV - 1) <= kMaxRelBias);
    CHECK(valid >= kMinValid);
  }
}

TEST_CASE("the peak residual, kept as an option, reads large beads low", "[piv]") {
  // The cause the default removes: with --residual peak, 36 px beads read >= 10 % low.
  synth::FrameGenerator gen(bead_shift(36, 1.3, -0.6, 3));
  const cv::Mat a = gen.next(), b = gen.next();
  piv::PivOptions o;
  o.residual = piv::Residual::kPeak;
  const auto r = piv::PivEngine(o).process(a, b);
  double su = 0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < r.field.size(); ++k)
    if (r.field.flag[k] == core::VectorFlag::kValid) {
      su += r.field.u_px[k];
      ++n;
    }
  REQUIRE(n > 0);
  CHECK(su / static_cast<double>(n) < 0.9 * 1.3);
}
