// shearzone/profile/resample.hpp: resampling the per-pair bin means of a profile,
// for the standard error of v(r) and the bootstrap interval of r_c.
//
// A clip gives, per PIV pair k and radial bin b, the mean |v| of the bin and its
// vector count. Those pair means are neither independent nor identically
// distributed: under oscillatory shear |v| follows the vane's phase (a
// deterministic modulation), and consecutive pairs share a frame and a bead
// configuration (autocorrelation). Resampling them as if they were independent
// draws mixes the modulation into the error (too wide) and ignores the correlation
// (too narrow); a single pair's vectors are correlated too. What is resampled
// therefore depends on the input (Grouping):
//
//   cycles                 at least `min_cycles` oscillation cycles hold data: the
//                          pairs are pooled per cycle and whole cycles are resampled
//                          with replacement. A cycle covers every phase, so its mean
//                          carries no modulation, and cycles are far enough apart
//                          to be treated as independent. (width.hpp widens the
//                          interval for the number of cycles.)
//   pairs_phase_detrended  fewer cycles, oscillation frequency known, >= 8 pairs:
//                          per bin, the pair means are fitted by a Fourier series in
//                          the phase (K harmonics, weighted by the counts; K <= 8
//                          and at most what leaves half the pairs as residual
//                          degrees of freedom). The residuals are modelled as an
//                          AR(1) series: its lag-1 correlation rho is solved from
//                          the residuals' lag-0 and lag-1 sums with the fit's own
//                          distortion accounted for (E[e e'] = sigma^2 M R(rho) M,
//                          M = I - hat matrix), because the fit removes exactly the
//                          slow part of the noise that sets the error of a mean.
//                          Replicates keep each pair's fitted value and add an AR(1)
//                          series driven by pre-whitened residuals drawn as whole
//                          pairs (all bins together, so the radial correlation of a
//                          pair is kept): an AR-sieve bootstrap.
//   pairs                  frequency unknown (e.g. a series of CSV pairs): the same
//                          with the mean alone as the fit; a modulation, if any,
//                          widens the interval (it errs on the safe side).
//   none                   a single pair: no replicate exists; standard errors and
//                          intervals are left empty.
// Measured coverage of 95 % r_c intervals (tests/profile/test_width.cpp, 400 seeds,
// AR(1) noise with rho = 0.5): one cycle of 49 pairs 93.5 %, three cycles 93.5 %,
// ten cycles with 10 % cycle-to-cycle scatter 92.3 %, 24 cycles 95.0 %.
// Known limit: with fewer than `min_cycles` cycles, variation slower than the AR(1)
// model's correlation time (e.g. a drift from cycle to cycle) is not resolved.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace shearzone::profile {

/// Cycles needed before whole cycles are resampled (the default of `--groups auto`).
inline constexpr int kMinBootstrapCycles = 8;

enum class Grouping { kCycles, kPairsPhaseDetrended, kPairs, kNone };
const char* grouping_name(Grouping g);
/// Parses a grouping name; returns false if unknown.
bool parse_grouping(const std::string& name, Grouping& g);

/// Per pair (in time order) and bin: mean |v|, mean v_theta and count.
struct PairSeries {
  static constexpr int kNoCycle = std::numeric_limits<int>::min();
  std::size_t n_bins = 0;
  std::vector<int> cycle;        ///< per pair; kNoCycle when the frequency is unknown
  std::vector<double> phase;     ///< per pair, fraction of a cycle in [0, 1) at mid-pair; NaN if unknown
  std::vector<double> phase_span;///< per pair, f dt: the fraction of a cycle the pair spans (0 if unknown)
  std::vector<double> v_abs;     ///< [pair * n_bins + bin], m/s (0 where the count is 0)
  std::vector<double> v_theta;   ///< [pair * n_bins + bin], signed mean v_theta, m/s (0 where the count is 0)
  std::vector<double> n_vectors; ///< [pair * n_bins + bin]
  std::size_t num_pairs() const { return cycle.size(); }
  /// Appends a pair with empty bins and returns its index.
  std::size_t add_pair(int cycle, double phase, double phase_span = 0.0);
  /// Cycles that hold at least one vector.
  std::size_t num_cycles() const;
  bool phase_known() const;
};

/// The honest grouping for the series (see above). `requested`: kNone = automatic;
/// kCycles forces cycles (ConfigError when fewer than 2 hold data); either pairs
/// kind forces pairs (phase-detrended when every pair's phase is known and there are
/// at least 8 pairs, else pairs about the mean). A single pair always gives kNone.
Grouping choose_grouping(const PairSeries& s, Grouping requested = Grouping::kNone,
                         int min_cycles = kMinBootstrapCycles);

/// Draws replicates of the pooled bin means under a grouping.
class BinMeanBootstrap {
 public:
  BinMeanBootstrap(const PairSeries& s, Grouping g);
  Grouping grouping() const { return g_; }
  /// Resampled units: cycles or pairs (0 for none).
  std::size_t units() const { return units_; }
  /// Lag-1 autocorrelation of the pairs' noise (AR(1) model; 0 for cycles).
  double rho() const { return rho_; }
  /// Harmonics of the phase fit (pairs_phase_detrended; the largest over bins).
  int harmonics() const { return harmonics_; }
  /// Pooled bin means of the data (count-weighted) and counts.
  const std::vector<double>& mean() const { return mean_; }
  const std::vector<double>& count() const { return count_; }
  /// One replicate of the bin means (NaN in bins without data) and counts.
  void draw(std::mt19937_64& rng, std::vector<double>& v, std::vector<double>& n) const;
  /// Standard deviation of `replicates` replicate bin means (NaN for none).
  std::vector<double> standard_errors(int replicates, std::uint64_t seed) const;

 private:
  Grouping g_;
  std::size_t nb_ = 0, units_ = 0;
  int harmonics_ = 0;
  std::vector<double> mean_, count_;
  // Per unit (cycle or pair) and bin: sum of v n (cycles) and of n.
  std::vector<double> unit_s_, unit_n_;
  // Pairs: fitted value, residual and AR(1) innovation per pair and bin.
  std::vector<double> fit_, resid_, innov_;
  double rho_ = 0;
};

}  // namespace shearzone::profile
