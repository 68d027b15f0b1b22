// shearzone/profile/radial_profile.hpp: the mean bead velocity v(r) against the
// distance r from the cup axis, averaged over the angle and over pairs.
//
// Each vector of a field (displacement in px over dt seconds) becomes a velocity in
// m/s, u * m_per_px / dt, decomposed about the cup centre with the project's
// convention (core/conventions.hpp: v_theta > 0 counter-clockwise as the camera
// sees it, v_r > 0 outwards). Vectors are binned by r: bin k covers
// [r_min + k w, r_min + (k+1) w) and is reported at its centre. Masked and invalid
// vectors are excluded and counted; `replaced` vectors (interpolated from valid
// neighbours) are used unless exclude_replaced is set.
//
// Per bin: mean |v| (the paper's v(r)), mean v_theta, mean v_r, RMS of |v|, the
// standard error of mean |v| and the counts. Bins without vectors carry no value
// (NaN), never a zero. The standard error is the standard deviation of bootstrap
// replicates of the bin mean under the grouping of profile/resample.hpp (whole
// cycles, or pairs with the oscillation's phase modulation removed and the
// residuals an AR(1) series); vectors of one pair are correlated, so a single
// pair gives no standard error (NaN).
//
// Noise floor: |v| of pure PIV noise is not zero. With Gaussian noise of standard
// deviation sigma per component, |v| follows a Rayleigh law of mean
// sigma sqrt(pi/2), which averaging does not remove. v_noise is that mean, with
// sigma estimated either from a region (by default the outer 15 % of the annulus,
// where the pile is jammed) as the scatter of the radial component v_r there (the
// azimuthal flow of the cup does not feed v_r, so the estimate holds even where the
// ring still moves; real radial fluctuations of the beads count as noise, which
// errs on the safe side), or, per bin, as the mean |v| of a static reference
// measurement.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "shearzone/core/point_vectors.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/core/vector_field.hpp"
#include "shearzone/profile/lockin.hpp"
#include "shearzone/profile/resample.hpp"

namespace shearzone::profile {

struct ProfileOptions {
  double centre_x_px = 0, centre_y_px = 0;  ///< cup centre, px
  double m_per_px = 0;                      ///< scale, m per px (> 0)
  double r_min_m = 0;                       ///< first bin edge (the vane radius), m
  double r_max_m = 0;                       ///< last bin edge (the cup radius R), m
  double bin_m = 0;                         ///< bin width, m (> 0)
  bool exclude_replaced = false;            ///< also drop `replaced` vectors
  /// What the standard errors resample: kNone = automatic (choose_grouping),
  /// kCycles or kPairsPhaseDetrended/kPairs (= "pairs") to force one.
  Grouping grouping = Grouping::kNone;
  int se_replicates = 1000;                 ///< bootstrap replicates for the standard errors
  std::uint64_t seed = 1;                   ///< their seed (deterministic)
  /// Lock-in estimator (profile/lockin.hpp): highest odd harmonic H, 0 = off. It runs
  /// only when every pair's drive phase is known.
  int lockin_harmonics = 1;
  /// Throws ConfigError naming the option.
  void validate() const;
  /// (r_max - r_min) / bin rounded to the nearest whole number (at least 1): every bin
  /// centre lies inside [r_min, r_max].
  std::size_t num_bins() const;
  double bin_centre_m(std::size_t k) const;
};

inline constexpr double kNoValue = core::kUnset;
/// The fluctuation is reported less the noise only where its square exceeds this many
/// times the noise's (the beads' own fluctuation at least as large as the noise); below,
/// a noise estimate off by 10 % would move it by more than 10 %.
inline constexpr double kFluctuationAboveNoise = 2.0;

struct ProfileBin {
  double r_m = 0;
  double v_abs = kNoValue, v_theta = kNoValue, v_r = kNoValue;  ///< means, m/s (NaN: no vector)
  double v_abs_rms = kNoValue;             ///< sqrt(mean |v|^2), m/s
  double v_abs_sem = kNoValue;             ///< standard error of v_abs, m/s (NaN: none)
  double v_noise = 0;                      ///< noise floor of v_abs, m/s
  std::size_t n_vectors = 0, n_masked = 0, n_invalid = 0;
  /// Mean and standard deviation of the radii of the vectors averaged, m (NaN: no
  /// vector). A grid of vectors fills a bin unevenly: its mean lies up to a grid step
  /// from the bin centre, and width interpolates at it.
  double r_vectors_mean_m = kNoValue, r_vectors_sd_m = kNoValue;
  LockinBin lockin;                        ///< phase-locked v_theta (ok = false: none)
  /// The velocity fluctuation about the local mean (granular temperature sqrt(T)), m/s,
  /// measurement noise included (NaN: too few vectors): within each pair, the RMS of
  /// the bin's v_theta about a straight line in r fitted to them (so neither the
  /// mean's change across the bin nor its change from pair to pair counts), pooled
  /// over the pairs with n - 2 degrees of freedom each (pairs with >= 3 vectors).
  double dv_theta = kNoValue;
};

struct RadialProfile {
  std::vector<ProfileBin> bins;
  PairSeries pairs;              ///< per-pair bin means, for the bootstrap of r_c
  Grouping grouping = Grouping::kNone;  ///< what the standard errors resampled
  std::size_t n_pairs = 0;
  std::size_t n_replaced_used = 0;  ///< `replaced` vectors averaged (0 with exclude_replaced)
  std::size_t n_groups = 0;      ///< units resampled: cycles or pairs (0: none)
  double rho = 0;                ///< lag-1 autocorrelation of the pairs' noise (pairs groupings)
  double noise_sigma_m_per_s = 0;  ///< per-component noise (outer-region method), m/s
  // Lock-in estimator (when it ran): harmonics, clustering of its standard errors.
  bool lockin = false;
  int lockin_harmonics = 0;
  std::string lockin_clusters;     ///< "cycles" or "pair_blocks"
  std::size_t lockin_n_clusters = 0, lockin_block_pairs = 0;
  double lockin_rho = 0;
};

/// Accumulates fields pair by pair (a clip is never held whole).
class ProfileAccumulator {
 public:
  explicit ProfileAccumulator(ProfileOptions options);
  /// Adds one pair: displacements in px over dt_s seconds, with its oscillation
  /// cycle and phase (fraction of a cycle in [0, 1), at mid-pair) when the frequency
  /// is known, and the fraction of a cycle the pair spans (f dt_s).
  /// Pairs must come in time order. Throws InputError if dt_s is not positive or
  /// the arrays do not match the grid.
  void add(const core::VectorField& field, double dt_s, int cycle = PairSeries::kNoCycle,
           double phase = kNoValue, double phase_span = 0.0);
  /// The same for displacements at scattered points (tracked beads: each bead one
  /// vector of its bin, at the point given).
  void add(const core::PointVectors& points, double dt_s, int cycle = PairSeries::kNoCycle,
           double phase = kNoValue, double phase_span = 0.0);
  std::size_t num_pairs() const { return n_pairs_; }
  const ProfileOptions& options() const { return opt_; }
  /// The lock-in's highest harmonic (0: off), e.g. capped once the pairs are known.
  void set_lockin_harmonics(int h) { opt_.lockin_harmonics = h; }

  /// Noise from the bins whose centre lies in [noise_r_min_m, noise_r_max_m] (a
  /// region that does not move). Throws NoResultError if no usable vector lies there.
  RadialProfile finish_with_region_noise(double noise_r_min_m, double noise_r_max_m) const;
  /// Noise per bin as the mean |v| of `reference` (a static measurement processed
  /// with the same options); bins the reference does not cover get its overall mean.
  RadialProfile finish_with_reference_noise(const ProfileAccumulator& reference) const;
  /// Noise known in advance: Gaussian scatter `sigma_m_per_s` per velocity component
  /// (0 for exact fields such as a simulator's truth): floor sigma sqrt(pi/2).
  RadialProfile finish_with_known_noise(double sigma_m_per_s) const;

 private:
  struct Sums {
    double s_abs = 0, s_abs2 = 0, s_theta = 0, s_r = 0;
    double s_dr = 0, s_dr2 = 0;  // radius - bin centre of the vectors averaged, m
    double fluct_ss = 0, fluct_dof = 0;  // v_theta about each pair's line in r: squares, degrees of freedom
    std::size_t n = 0, masked = 0, invalid = 0;
  };
  struct NoiseSums {
    double s = 0, s2 = 0;  // radial velocity component
    std::size_t n = 0;
  };
  RadialProfile finish_common() const;

  ProfileOptions opt_;
  std::vector<Sums> bins_;
  std::vector<int> pair_cycle_;
  std::vector<double> pair_phase_, pair_span_;
  std::vector<double> pair_s_, pair_st_, pair_n_;  // [pair * bins + bin]: sum |v|, sum v_theta, count
  std::vector<NoiseSums> noise_by_bin_;          // v_r sums per bin
  std::size_t n_pairs_ = 0;
  std::size_t replaced_used_ = 0;
  core::PointVectors points_;  // a grid's nodes, reused from pair to pair
};

/// Oscillation cycle and phase of a time t (s) for a vane angle
/// phi(t) = phi0 sin(2 pi f (t - t0)): cycle = floor(f (t - t0)), phase in degrees
/// in [0, 360). t0 is the time of an upward zero crossing.
struct CyclePhase {
  int cycle = 0;
  double phase_deg = 0;
};
CyclePhase cycle_phase(double t_s, double f_Hz, double t0_s);

}  // namespace shearzone::profile
