// Bead tracking between two frames (track/track.hpp), against the synthetic truth.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/synth/generator.hpp"
#include "shearzone/track/track.hpp"

using namespace shearzone;

namespace {

synth::SynthOptions beads(double d, synth::FieldKind kind, std::uint64_t seed) {
  synth::SynthOptions s;
  s.texture = synth::TextureKind::kBeads;
  s.beads.diameter_px = d;
  s.field.kind = kind;
  s.field.u_px = 1.3;
  s.field.v_px = -0.6;
  s.field.omega_rad = 0.004;             // 1 px at 250 px from the centre
  s.field.r0_px = 120;
  s.field.w_px = std::max(60.0, 2 * d);  // a zone two beads wide or more, as in the cup
  s.field.U0_px = 1.5;
  s.image.seed = seed;
  return s;
}

struct Errors {
  std::size_t detected = 0, tracked = 0, matched = 0;
  double bias_u = 0, bias_v = 0, rms = 0;
};

/// Tracks frame 0 -> 1 of `s` and compares each tracked bead with the tracer nearest
/// its centre (within a quarter diameter: the visible bead, not one hidden below it).
Errors track_against_truth(const synth::SynthOptions& s) {
  const synth::TracedPair pair = synth::traced_pair(s);
  const std::vector<double>&xa = pair.xa, &ya = pair.ya, &xb = pair.xb, &yb = pair.yb;
  track::TrackOptions o;
  o.bead_diameter_px = s.beads.diameter_px;
  o.centre_offset_px = track::disc_centre_offset(pair.a, cv::Mat(), o);  // as piv --method track does
  const track::PairBeads r = track::track_pair(pair.a, pair.b, cv::Mat(), cv::Mat(), o);
  Errors e;
  e.detected = r.size();
  e.tracked = r.tracked();
  double su = 0, sv = 0, s2 = 0;
  const double near2 = std::pow(0.25 * s.beads.diameter_px, 2);
  for (std::size_t k = 0; k < r.size(); ++k) {
    if (!r.ok[k]) continue;
    std::size_t best = 0;
    double best2 = 1e300;
    for (std::size_t t = 0; t < xa.size(); ++t) {
      const double d2 = std::pow(xa[t] - r.x_px[k], 2) + std::pow(ya[t] - r.y_px[k], 2);
      if (d2 < best2) best2 = d2, best = t;
    }
    const double tu = xb[best] - xa[best], tv = yb[best] - ya[best];
    if (best2 > near2 || std::hypot(tu, tv) > 5) continue;  // another bead, or wrapped round the domain
    const double eu = r.u_px[k] - tu, ev = r.v_px[k] - tv;
    su += eu;
    sv += ev;
    s2 += eu * eu + ev * ev;
    ++e.matched;
  }
  if (e.matched) {
    e.bias_u = su / static_cast<double>(e.matched);
    e.bias_v = sv / static_cast<double>(e.matched);
    e.rms = std::sqrt(s2 / (2.0 * static_cast<double>(e.matched)));
  }
  return e;
}

}  // namespace

// Issue 36's gate: centre displacements with bias <= 0.01 px and RMS <= 0.05 px at the
// default noise, on 8-64 px beads, uniform shift, rotation and the shear zone.
TEST_CASE("tracked bead displacements: bias within 0.01 px and RMS within 0.05 px at 8-64 px", "[track]") {
  constexpr double kMaxBiasPx = 0.01;
  constexpr double kMaxRmsPx = 0.05;
  constexpr double kMinTracked = 0.95;   // of the beads detected
  constexpr double kMinMatched = 0.80;   // of those tracked: a tracer within d/4 of the centre
  for (auto kind : {synth::FieldKind::kUniform, synth::FieldKind::kRotation, synth::FieldKind::kShearZone})
    for (double d : {8.0, 16.0, 24.0, 36.0, 48.0, 64.0}) {
      const Errors e = track_against_truth(beads(d, kind, 3));
      INFO(synth::field_kind_name(kind) << ", beads " << d << " px: " << e.detected << " detected, " << e.tracked
                                        << " tracked, " << e.matched << " matched; bias " << e.bias_u << ", "
                                        << e.bias_v << " px, RMS " << e.rms << " px");
      REQUIRE(e.detected > 0);
      CHECK(static_cast<double>(e.tracked) >= kMinTracked * static_cast<double>(e.detected));
      CHECK(static_cast<double>(e.matched) >= kMinMatched * static_cast<double>(e.tracked));
      CHECK(std::abs(e.bias_u) <= kMaxBiasPx);
      CHECK(std::abs(e.bias_v) <= kMaxBiasPx);
      CHECK(e.rms <= kMaxRmsPx);
    }
}

TEST_CASE("a bead near a masked pixel is not detected, one whose window reaches the mask in frame b is not kept", "[track]") {
  // 16 px: found on the frame itself; 36 px: on the frame in blocks of 3 px.
  for (double d : {16.0, 36.0}) {
    synth::FrameGenerator gen(beads(d, synth::FieldKind::kUniform, 5));
    const cv::Mat a = gen.next(), b = gen.next();
    track::TrackOptions o;
    o.bead_diameter_px = d;
    cv::Mat mask = cv::Mat::zeros(a.size(), CV_8U);
    mask.colRange(0, 256).setTo(255);
    // A quarter bead of clearance for a centre; a window (>= 7 px) clear of mask b at the end.
    const std::vector<cv::Point2d> found = track::detect_beads(a, mask, o);
    CHECK(found.size() > 10);
    for (const auto& c : found) CHECK(c.x >= 256 + 0.25 * d - 0.5);
    const track::PairBeads r = track::track_pair(a, b, cv::Mat(), mask, o);
    std::size_t kept = 0;
    for (std::size_t k = 0; k < r.size(); ++k)
      if (r.ok[k]) {
        CHECK(r.x_px[k] + r.u_px[k] >= 256 + 3.5 - 0.5);
        ++kept;
      }
    CHECK(kept > 0);
  }
}

TEST_CASE("beads just inside a region's edge are found and tracked: a region bounds centres, it hides nothing", "[track]") {
  // The annulus of interest's inner edge at the vane's radius has beads on both sides:
  // one whose centre lies just inside is all in view. Given as `outside`, the region
  // keeps centres in it out but lets windows reach across; given as a mask, the beads
  // of the first quarter bead are lost.
  for (double d : {16.0, 36.0}) {
    const synth::TracedPair pair = synth::traced_pair(beads(d, synth::FieldKind::kUniform, 5));
    track::TrackOptions o;
    o.bead_diameter_px = d;
    cv::Mat region = cv::Mat::zeros(pair.a.size(), CV_8U);
    region.colRange(0, 256).setTo(255);
    const double edge = 256 - 0.5;  // pixel 256's left edge
    const auto as_mask = track::detect_beads(pair.a, region, o);
    const auto as_region = track::detect_beads(pair.a, cv::Mat(), o, region);
    auto near_edge = [&](const std::vector<cv::Point2d>& cs) {
      return std::count_if(cs.begin(), cs.end(), [&](const cv::Point2d& c) { return c.x < edge + 0.25 * d; });
    };
    for (const auto& c : as_region) CHECK(c.x >= edge);
    CHECK(near_edge(as_mask) == 0);
    CHECK(near_edge(as_region) >= 3);
    CHECK(as_region.size() > as_mask.size());
    // Those beads' displacements as good as anywhere (windows over the region's beads).
    const track::PairBeads r = track::track_pair(pair.a, pair.b, cv::Mat(), cv::Mat(), o, region);
    constexpr double kMaxRmsPx = 0.05;  // the tracker's gate anywhere in the frame
    std::size_t checked = 0;
    double s2 = 0;
    for (std::size_t k = 0; k < r.size(); ++k) {
      CHECK(r.x_px[k] >= edge);
      if (!r.ok[k] || r.x_px[k] >= edge + 0.25 * d) continue;
      std::size_t best = 0;
      double best2 = 1e300;
      for (std::size_t t = 0; t < pair.xa.size(); ++t) {
        const double d2 = std::pow(pair.xa[t] - r.x_px[k], 2) + std::pow(pair.ya[t] - r.y_px[k], 2);
        if (d2 < best2) best2 = d2, best = t;
      }
      if (best2 > std::pow(0.25 * d, 2)) continue;  // a bead half hidden under another
      s2 += std::pow(r.u_px[k] - (pair.xb[best] - pair.xa[best]), 2) +
            std::pow(r.v_px[k] - (pair.yb[best] - pair.ya[best]), 2);
      ++checked;
    }
    REQUIRE(checked >= 3);
    const double rms = std::sqrt(s2 / (2.0 * static_cast<double>(checked)));
    INFO(d << " px: " << checked << " beads within d/4 of the edge, RMS " << rms << " px");
    CHECK(rms <= kMaxRmsPx);
    cv::Mat wrong(8, 8, CV_8U, cv::Scalar(0));
    CHECK_THROWS_AS(track::detect_beads(pair.a, cv::Mat(), o, wrong), InputError);
  }
}

TEST_CASE("beads on the grid: one cell per half bead, the mean of its beads, masked where none", "[track]") {
  track::PairBeads p;
  p.x_px = {10.2, 10.9, 30.0, 50.0};
  p.y_px = {5.0, 6.0, 5.0, 5.0};
  p.u_px = {1.0, 2.0, 0.0, 5.0};
  p.v_px = {-1.0, 0.0, 0.0, 5.0};
  p.fb_px = {0.01, 0.02, 0.5, 0.01};
  p.ok = {1, 1, 0, 1};
  cv::Mat mask = cv::Mat::zeros(32, 64, CV_8U);
  mask.colRange(48, 64).setTo(255);
  const int c = track::grid_cell_px(16);
  REQUIRE(c == 8);
  const core::VectorField f = track::beads_to_grid(p, {64, 32}, c, mask);
  REQUIRE(f.nx() == 8);
  REQUIRE(f.ny() == 4);
  CHECK(f.x_px[1] == 11.5);
  CHECK(f.flag[f.index(0, 1)] == core::VectorFlag::kValid);
  CHECK(f.u_px[f.index(0, 1)] == 1.5f);
  CHECK(f.v_px[f.index(0, 1)] == -0.5f);
  CHECK(f.flag[f.index(0, 3)] == core::VectorFlag::kInvalid);  // the bead at x = 30 failed
  CHECK(f.flag[f.index(0, 6)] == core::VectorFlag::kMasked);   // under the mask
  CHECK(f.flag[f.index(1, 1)] == core::VectorFlag::kMasked);   // no bead
  CHECK(f.count(core::VectorFlag::kValid) == 1);
}

// On frames with no beads (noise) the offset may land anywhere in its search: never
// beyond 0.35 d, so that it always passes TrackOptions::validate (half a bead).
TEST_CASE("the centre offset stays within 0.35 d on any frame", "[track]") {
  cv::RNG rng(7);
  for (double d : {3.0, 4.0, 5.0, 8.0})
    for (int k = 0; k < 5; ++k) {
      cv::Mat noise(128, 128, CV_8U);
      rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
      track::TrackOptions o;
      o.bead_diameter_px = d;
      o.centre_offset_px = track::disc_centre_offset(noise, cv::Mat(), o);
      INFO("d " << d << ": offset " << o.centre_offset_px.x << ", " << o.centre_offset_px.y);
      CHECK(std::hypot(o.centre_offset_px.x, o.centre_offset_px.y) <= 0.35 * d + 1e-9);
      CHECK_NOTHROW(o.validate());
    }
}

TEST_CASE("tracking options out of range are refused", "[track]") {
  track::TrackOptions o;
  CHECK_THROWS_AS(o.validate(), ConfigError);  // no bead diameter
  o.bead_diameter_px = 16;
  o.validate();
  o.pyramid_levels = 7;
  CHECK_THROWS_AS(o.validate(), ConfigError);
  o.pyramid_levels = 3;
  o.fb_tolerance_px = 0;
  CHECK_THROWS_AS(o.validate(), ConfigError);
  o.fb_tolerance_px = 0.1;
  o.centre_offset_px = {6.0, 6.0};  // beyond half a bead
  CHECK_THROWS_AS(o.validate(), ConfigError);
  o.centre_offset_px = {0.0, std::nan("")};
  CHECK_THROWS_AS(o.validate(), ConfigError);
  o.centre_offset_px = {0.0, 0.0};
  // A mask must be 8-bit and of the frame's size.
  const cv::Mat frame(64, 64, CV_8U, cv::Scalar(100));
  CHECK_THROWS_AS(track::detect_beads(frame, cv::Mat::zeros(32, 64, CV_8U), o), InputError);
  CHECK_THROWS_AS(track::detect_beads(frame, cv::Mat::zeros(64, 64, CV_16U), o), InputError);
  CHECK_THROWS_AS(track::track_pair(frame, frame, cv::Mat(), cv::Mat::zeros(64, 32, CV_8U), o), InputError);
}

namespace {

struct LinkCount {
  std::size_t rows = 0, linked = 0;      // detections in pairs 2.. and those continuing a track
  std::size_t judged = 0, wrong = 0;     // linked rows with a tracer on both sides, and those of another bead
  std::size_t continuing = 0, kept = 0;  // beads tracked in a pair and detected in the next frame a; linked
};

/// Tracks a `frames`-frame clip of `s` pair by pair, links the pairs, and checks each
/// link against the tracers' ids (a detection's bead: the tracer within d/4 of it, none
/// within d/2 besides).
LinkCount link_against_truth(synth::SynthOptions s, int frames) {
  s.sequence.frames = frames;
  synth::FrameGenerator gen(s);
  track::TrackOptions o;
  o.bead_diameter_px = s.beads.diameter_px;
  track::Linker linker(o.bead_diameter_px);
  std::vector<double> tx = gen.tracer_x(), ty = gen.tracer_y();
  cv::Mat a = gen.next();
  std::map<std::int64_t, long> last_tracer;    // track id -> tracer at its previous row
  std::map<long, std::int64_t> tracked_before;  // tracer -> track id, beads tracked in the previous pair
  LinkCount c;
  for (int k = 0; k + 1 < frames; ++k) {
    const std::vector<double> tx_b = gen.tracer_x(), ty_b = gen.tracer_y();
    const cv::Mat b = gen.next();
    const track::PairBeads p = track::track_pair(a, b, cv::Mat(), cv::Mat(), o);
    const core::TrackedBeads rows = linker.link(p, k, k + 1, k / 25.0, 1 / 25.0);
    const std::vector<long> who = synth::tracer_under(tx, ty, rows.x_px, rows.y_px, 0.25 * o.bead_diameter_px);
    std::map<long, std::int64_t> tracked_now;
    for (std::size_t r = 0; r < rows.size(); ++r) {
      if (k > 0) {
        ++c.rows;
        c.linked += rows.linked[r];
        if (rows.linked[r] && who[r] >= 0 && last_tracer.count(rows.track_id[r]) && last_tracer[rows.track_id[r]] >= 0) {
          ++c.judged;
          c.wrong += last_tracer[rows.track_id[r]] != who[r];
        }
        const auto before = who[r] >= 0 ? tracked_before.find(who[r]) : tracked_before.end();
        if (before != tracked_before.end()) {
          ++c.continuing;
          c.kept += rows.linked[r] && rows.track_id[r] == before->second;
        }
      }
      last_tracer[rows.track_id[r]] = who[r];
      if (rows.tracked[r] && who[r] >= 0) tracked_now[who[r]] = rows.track_id[r];
    }
    tracked_before = std::move(tracked_now);
    a = b;
    tx = tx_b;
    ty = ty_b;
  }
  return c;
}

}  // namespace

// Issue 36's linking gate: at least 95 % of the beads linked over a 50-frame clip, and
// no wrong link against the synthetic truth's bead ids.
TEST_CASE("beads linked over a 50-frame clip: at least 95 % linked, none to another bead", "[track]") {
  constexpr int kFrames = 50;
  constexpr double kMinLinked = 0.95;     // of the detections of pairs 2..49
  constexpr double kMinKept = 0.99;       // of the beads tracked in a pair and found again in the next
  for (auto kind : {synth::FieldKind::kUniform, synth::FieldKind::kRotation, synth::FieldKind::kShearZone})
    for (double d : {8.0, 24.0, 64.0}) {
      synth::SynthOptions s = beads(d, kind, 3);
      s.image.width_px = 384;
      s.image.height_px = 384;
      s.field.r0_px = 90;
      if (kind == synth::FieldKind::kShearZone) s.sequence.oscillate_f_Hz = 1.0;  // 25 frames per cycle
      const LinkCount c = link_against_truth(s, kFrames);
      INFO(synth::field_kind_name(kind) << ", beads " << d << " px: " << c.linked << " of " << c.rows
                                        << " linked; " << c.wrong << " wrong of " << c.judged << " judged; "
                                        << c.kept << " of " << c.continuing << " continuing beads kept");
      REQUIRE(c.rows > 0);
      CHECK(static_cast<double>(c.linked) >= kMinLinked * static_cast<double>(c.rows));
      CHECK(c.judged >= c.linked * 8 / 10);
      CHECK(c.wrong == 0);
      CHECK(static_cast<double>(c.kept) >= kMinKept * static_cast<double>(c.continuing));
    }
}

TEST_CASE("linking: only consecutive pairs continue tracks, ids in order of appearance", "[track]") {
  track::PairBeads p;
  p.x_px = {10.0, 40.0, 80.0};
  p.y_px = {10.0, 10.0, 10.0};
  p.u_px = {1.0, 0.0, 1.0};
  p.v_px = {0.0, 0.0, 0.0};
  p.fb_px = {0.01, 0.01, 0.01};
  p.ok = {1, 0, 1};
  track::Linker l(16.0);
  const core::TrackedBeads r0 = l.link(p, 0, 1, 0.0, 0.04);
  CHECK(r0.track_id == std::vector<std::int64_t>{0, 1, 2});
  CHECK(r0.linked == std::vector<std::uint8_t>{0, 0, 0});
  CHECK(std::isnan(r0.u_px[1]));  // not tracked: no displacement
  // Next pair: a bead 0.5 px from where bead 0 ended continues it; the bead at 40 px
  // was not tracked, so its bead starts a new track; one 5 px from where bead 2 ended
  // (beyond d/4 = 4 px) too.
  track::PairBeads q = p;
  q.x_px = {11.5, 40.0, 86.0};
  q.ok = {1, 1, 1};
  const core::TrackedBeads r1 = l.link(q, 1, 2, 0.04, 0.04);
  CHECK(r1.track_id == std::vector<std::int64_t>{0, 3, 4});
  CHECK(r1.linked == std::vector<std::uint8_t>{1, 0, 0});
  // A pair that does not start where the last one ended (a frame skipped) links nothing.
  const core::TrackedBeads r2 = l.link(q, 3, 4, 0.12, 0.04);
  CHECK(r2.linked == std::vector<std::uint8_t>{0, 0, 0});
  CHECK(l.tracks() == 8);
}

// Under a light from one side (synth's 135 degrees, 50 degrees up) the smoothed peak of a
// bead lies towards the light, 0.125 d along each axis; the camera's truth is the disc's
// centre. disc_centre_offset() measures the offset on the frame: after it, the centres'
// mean offset from the tracers under them is at most 0.04 d per axis (measured 0.003-0.030
// d), with or without a mask over a third of the frame.
TEST_CASE("bead centres: the offset from the lit peak to the disc's centre, measured on the frame", "[track]") {
  constexpr double kMaxResidual = 0.04;  // of d, per axis (uncorrected: 0.125)
  for (bool masked : {false, true})
    for (double d : {8.0, 16.0, 24.0, 36.0, 50.0, 64.0}) {
      synth::SynthOptions s = beads(d, synth::FieldKind::kUniform, 3);
      s.image.width_px = 960;
      s.image.height_px = 540;
      const synth::TracedPair pair = synth::traced_pair(s);
      cv::Mat mask;
      if (masked) {
        mask = cv::Mat::zeros(pair.a.size(), CV_8U);
        mask.colRange(0, 320).setTo(255);
      }
      track::TrackOptions o;
      o.bead_diameter_px = d;
      o.centre_offset_px = track::disc_centre_offset(pair.a, mask, o);
      const auto c = track::detect_beads(pair.a, mask, o);
      std::vector<double> x, y;
      for (const auto& p : c) x.push_back(p.x), y.push_back(p.y);
      const auto under = synth::tracer_under(pair.xa, pair.ya, x, y, 0.45 * d);
      double sx = 0, sy = 0;
      int n = 0;
      for (std::size_t k = 0; k < x.size(); ++k)
        if (under[k] >= 0) sx += x[k] - pair.xa[under[k]], sy += y[k] - pair.ya[under[k]], ++n;
      INFO("beads of " << d << " px" << (masked ? ", a third masked" : "") << ": offset " << o.centre_offset_px.x
                       << ", " << o.centre_offset_px.y << " px; " << n << " centres against their tracers: mean "
                       << sx / n << ", " << sy / n << " px");
      REQUIRE(n >= 30);
      CHECK(std::abs(sx / n) <= kMaxResidual * d);
      CHECK(std::abs(sy / n) <= kMaxResidual * d);
    }
}
