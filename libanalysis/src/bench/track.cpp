// The bead tracker's speed against accuracy (bench/track.hpp).
#include "shearzone/bench/track.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <omp.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/ordered_pool.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/synth/generator.hpp"
#include "shearzone/track/track.hpp"

namespace shearzone::bench {
namespace {

struct Score {
  std::size_t matched = 0;
  double bias_u = 0, bias_v = 0, rms = 0;
};

/// Each tracked bead against the tracer under it (synth::tracer_under: within d/4).
Score score(const track::PairBeads& r, const synth::TracedPair& t, double d) {
  const std::vector<long> who = synth::tracer_under(t.xa, t.ya, r.x_px, r.y_px, 0.25 * d);
  double su = 0, sv = 0, s2 = 0;
  Score s;
  for (std::size_t k = 0; k < r.size(); ++k) {
    if (!r.ok[k] || who[k] < 0) continue;
    const auto i = static_cast<std::size_t>(who[k]);
    const double eu = r.u_px[k] - (t.xb[i] - t.xa[i]), ev = r.v_px[k] - (t.yb[i] - t.ya[i]);
    su += eu;
    sv += ev;
    s2 += eu * eu + ev * ev;
    ++s.matched;
  }
  if (s.matched) {
    const auto n = static_cast<double>(s.matched);
    s.bias_u = su / n;
    s.bias_v = sv / n;
    s.rms = std::sqrt(s2 / (2 * n));
  }
  return s;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

/// Wall-clock seconds to track `pairs` copies of a pair, `threads` at a time (one pair
/// per worker, as the piv job runs a clip: core::OrderedPool, at most threads + 2 in flight).
double clip_seconds(const synth::TracedPair& pair, const track::TrackOptions& to, int threads, int pairs) {
  struct Job {
    track::PairBeads beads;
  };
  const auto t0 = std::chrono::steady_clock::now();
  {
    core::OrderedPool<Job> pool(
        [&](Job& j) { j.beads = track::track_pair(pair.a, pair.b, cv::Mat(), cv::Mat(), to); }, threads);
    for (int k = 0; k < pairs; ++k) {
      while (pool.full()) pool.pop_done(true);
      pool.submit(Job{});
    }
    while (pool.pop_done(true)) {
    }
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string fixed(double v, int digits) { return fmt::format("{:.{}f}", v, digits); }

}  // namespace

BenchTrackSummary run_track_bench(const BenchTrackOptions& o, const core::Metadata& header,
                                  const core::ProgressCallback& progress) {
  if (o.timing_repeats < 1 || o.timing_repeats > 1000)
    throw ConfigError(fmt::format("bench track: --repeats {}: expected 1..1000", o.timing_repeats));
  const int w = o.quick ? 960 : o.width_px, h = o.quick ? 540 : o.height_px;
  if (w < 64 || h < 64 || w > 8192 || h > 8192)
    throw ConfigError(fmt::format("bench track: pair {}x{} px: expected 64..8192 a side", w, h));
  const std::vector<double> diameters = o.quick ? std::vector<double>{35} : o.diameters_px;
  if (diameters.empty()) throw ConfigError("bench track: --diameters: expected at least one");
  for (double d : diameters)
    if (!(d >= 3 && d <= 200 && 4 * d <= std::min(w, h)))
      throw ConfigError(fmt::format("bench track: bead diameter {} px: expected 3..200 and a quarter of the "
                                    "shorter side at most",
                                    d));
  if (o.threads < 0 || o.threads > 1024)
    throw ConfigError(fmt::format("bench track: --threads {}: expected 0 (all cores) to 1024", o.threads));
  const int clip_pairs = o.quick ? 4 : o.clip_pairs;
  if (clip_pairs < 1 || clip_pairs > 10000)
    throw ConfigError(fmt::format("bench track: --clip-pairs {}: expected 1..10000", o.clip_pairs));
  const int threads = o.threads > 0 ? o.threads : omp_get_max_threads();  // piv's "all cores"
  io::AtomicOutputSet out(o.out_dir, o.force);
  out.check("track_speed_accuracy.csv");
  core::Metadata meta = header;
  meta.emplace_back("bench", fmt::format("synthetic {}x{} synth-beads pairs of a shear zone (rigid core {} px, "
                                         "decay 2 d, U0 d/4 px per frame), default tracking options; time = median "
                                         "of {} runs; errors against the tracer within d/4 of each tracked bead; clip: {} pairs tracked {} at "
                                         "a time, one per thread, frames in memory (decoding not counted), median "
                                         "of {} clips",
                                         w, h, std::min(w, h) / 5, o.timing_repeats, clip_pairs, threads,
                                         o.timing_repeats));
  io::CsvWriter csv(out.add("track_speed_accuracy.csv").stream(), meta,
                    {"bead_diameter_px", "beads", "detect_s", "seconds_per_pair_s", "pairs_per_s", "tracked_percent",
                     "matched", "bias_u_px", "bias_v_px", "rms_error_px", "threads", "clip_pairs_per_s"});
  BenchTrackSummary sum;
  std::size_t done = 0;
  for (double d : diameters) {
    synth::SynthOptions s;
    s.texture = synth::TextureKind::kBeads;
    s.beads.diameter_px = d;
    s.image.width_px = w;
    s.image.height_px = h;
    s.image.seed = 2024;
    s.field.kind = synth::FieldKind::kShearZone;
    s.field.r0_px = std::min(w, h) / 5.0;
    s.field.w_px = 2 * d;
    s.field.U0_px = d / 4;
    const synth::TracedPair pair = synth::traced_pair(s);
    track::TrackOptions to;
    to.bead_diameter_px = d;
    to.centre_offset_px = track::disc_centre_offset(pair.a, cv::Mat(), to);  // once per clip, as piv does
    std::vector<double> t_detect, t_pair;
    std::size_t beads = 0;
    track::PairBeads r;
    for (int k = 0; k < o.timing_repeats; ++k) {
      auto t0 = std::chrono::steady_clock::now();
      beads = track::detect_beads(pair.a, cv::Mat(), to).size();
      t_detect.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      t0 = std::chrono::steady_clock::now();
      r = track::track_pair(pair.a, pair.b, cv::Mat(), cv::Mat(), to);
      t_pair.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::vector<double> t_clip;
    for (int k = 0; k < o.timing_repeats; ++k) t_clip.push_back(clip_seconds(pair, to, threads, clip_pairs));
    const double td = median(t_detect), tp = median(t_pair), clip_rate = clip_pairs / median(t_clip);
    const Score sc = score(r, pair, d);
    const double tracked = 100.0 * static_cast<double>(r.tracked()) / static_cast<double>(std::max<std::size_t>(beads, 1));
    csv.row(std::vector<std::string>{io::format_number(d), std::to_string(beads), fixed(td, 4), fixed(tp, 4),
                                     fixed(1.0 / tp, 2), fixed(tracked, 2), std::to_string(sc.matched),
                                     fixed(sc.bias_u, 4), fixed(sc.bias_v, 4), fixed(sc.rms, 4),
                                     std::to_string(threads), fixed(clip_rate, 2)});
    sum.lines.push_back(fmt::format("beads of {} px: {} per pair, {:.3f} s per pair ({:.2f} pairs/s; detection "
                                    "{:.3f} s), {:.1f} % tracked, RMS {:.4f} px; a clip on {} threads: {:.1f} pairs/s",
                                    io::format_number(d), beads, tp, 1.0 / tp, td, tracked, sc.rms, threads,
                                    clip_rate));
    if (progress) progress(++done, diameters.size());
  }
  out.commit_all();
  sum.files = out.final_paths();
  return sum;
}

}  // namespace shearzone::bench
