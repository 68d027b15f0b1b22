// shearzone/laos/analysis.hpp: LAOS analysis of one oscillation record (a log segment)
// given as plain vectors: amplitudes, drive phase θ, cycles, start-up transient and
// steady state, harmonics and derived measures per amplitude (docs/laos.md).
//
// Steps, per record:
//  1. Amplitudes. Raw cycles are cut at upward crossings of the drive through its mid
//     level (a Schmitt trigger with 2 % of the half range against noise); a new
//     amplitude starts when a raw cycle's half range differs from the previous one by
//     more than `amplitude_change` (5 %). Amplitude blocks without a complete cycle are
//     skipped (counted) when the record holds several blocks.
//  2. Phase θ, per amplitude: with time, a 4-parameter sine fit of x(t) (IEEE-1057
//     style: linear least squares for fixed ω, golden-section search of ω, then
//     Gauss-Newton polishing; with `drift` also a linear drift of the drive, as a creeping
//     angle under torque control has) and θ = ω t + ψ; with `drift` and two or more used
//     cycles (step 3), the drive is refitted over the used cycles only and the amplitude
//     analysed again with that phase; the record's ω (log or option) only
//     seeds the search. Without time: θ = arcsin(x̂) on the rising branch and
//     π − arcsin(x̂) on the falling one (branch from the sign of Δx), unwrapped, with
//     x̂ = (x − c)/x0, c the mid level and x0 the half range; ω then comes from the
//     options or is unknown (rate measures NaN).
//  3. Cycles: θ ∈ [2πk, 2π(k+1)] (upward zero crossings of the fitted drive); partial
//     cycles at the ends are dropped and counted. Per cycle: a harmonic fit, x0,
//     τ_max = min(largest |r| sample, largest |offset + odd harmonics| of the cycle's
//     fit): a single impulsive sample is left out, a plateau kept (the largest |r| is
//     also kept, as r_max_raw: one impulsive contact in a simulated torque log made it
//     4.6x the 99th percentile), loop area E_d. Steady state: the cycles from the first one after
//     which every cycle-to-cycle change of K'_1 and K''_1 is below
//     steady_tolerance·|K*_1|. Default analysis: the steady cycles (none steady: the
//     last cycle only, status "not_steady"); `cycles` (1-based) overrides.
//  4. Harmonic cutoff: M = min(requested, cap); cap = floor(π/√(2Δx/x0)) for
//     angle-sampled records (Δx the median step) and floor((samples per cycle − 1)/2)
//     for timed ones.
//  5. Optional inertia subtraction r − I ẍ, ẍ = −x0 ω² sin θ from the fitted drive.
//
// Guards (NoResultError, exit 3, never a plausible number from a meaningless fit):
//  - --no-split over raw cycles whose amplitudes differ by more than amplitude_change
//    (unless force_one_amplitude);
//  - a drive that is not a steady oscillation: rms misfit of its sine fit above
//    max_drive_misfit of the amplitude (a ramp, a pre-shear rotation, a changing
//    frequency), or used cycles whose amplitudes spread by more than max_amplitude_spread;
//  - a harmonic fit whose |K*_1| is below 5 standard errors (the fit says nothing
//    about the moduli).
// Errors: InputError, prefixed with the caller's `context` and naming sample lines
// when known.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "shearzone/core/sine_fit.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/core/waveform.hpp"
#include "shearzone/laos/harmonics.hpp"

namespace shearzone::laos {

/// The record analysed: the readers' type (io::LogSegment is one, with a label).
using Waveform = core::Waveform;

struct AnalysisOptions {
  int max_harmonic = 9;              ///< requested M (capped by the sampling)
  bool drift = true;                 ///< linear-drift column in the fits
  /// Known ω: seeds the sine fit; required for rates without time.
  double omega_rad_per_s = core::kUnset;
  /// Inertia in response units per (drive unit / s²): I in kg m² for angle/torque.
  double inertia = 0.0;
  double amplitude_change = 0.05;    ///< relative change of raw-cycle amplitude -> new amplitude
  bool split_amplitudes = true;      ///< false: the record is one amplitude
  /// Analyse the record as one amplitude even when its raw cycles' amplitudes differ by
  /// more than amplitude_change (with split_amplitudes false) or its used cycles spread
  /// by more than max_amplitude_spread; otherwise both are NoResultError.
  bool force_one_amplitude = false;
  /// Largest rms misfit of the drive's sine fit, relative to its amplitude, for which
  /// the drive counts as a steady oscillation (timed records); above it NoResultError.
  double max_drive_misfit = 0.1;
  /// Largest spread (max/min − 1) of the used cycles' drive amplitudes.
  double max_amplitude_spread = 0.1;
  double steady_tolerance = 0.02;    ///< relative cycle-to-cycle change of K'_1, K''_1
  std::vector<int> cycles;           ///< 1-based cycles to analyse (empty: the steady ones)
  bool all_cycles = false;           ///< analyse every complete cycle (overrides the steady rule)
  void validate() const;             ///< ConfigError on bad values
};

struct CycleResult {
  int cycle = 0;            ///< 1-based within the amplitude
  double t_start_s = core::kUnset;  ///< time of θ = 2πk (NaN without time)
  double x0 = 0;            ///< half range of the drive samples in the cycle
  double r_max = 0;         ///< min(r_max_raw, max |offset + odd harmonics| of the cycle's fit)
  double r_max_raw = 0;     ///< max |r| over the cycle's samples
  double K1p = 0, K1pp = 0; ///< per-cycle first harmonic
  double E_d = 0;           ///< loop area ∮ r dx over the cycle
  bool steady = false, used = false;
};

/// Which cycles an amplitude's harmonics come from: ok (the steady cycles), not_steady
/// (no steady cycle: the last one), single_cycle (only one complete cycle), all_cycles
/// (--all-cycles), cycles_selected (--cycles) or closed_cycle (one stored period,
/// analyse_closed_cycle).
enum class AmplitudeStatus { kOk, kNotSteady, kSingleCycle, kAllCycles, kCyclesSelected, kClosedCycle };
/// The name written in the outputs ("ok", "not_steady", ...).
const char* amplitude_status_name(AmplitudeStatus s);

struct AmplitudeResult {
  std::size_t first_sample = 0, last_sample = 0;  ///< inclusive, indices into the record
  std::size_t first_line = 0, last_line = 0;      ///< source lines (0 if unknown)
  bool timed = false;
  std::string phase_method;     ///< "sine_fit" or "arcsin"
  double omega = core::kUnset;          ///< rad/s used (NaN: unknown)
  double x0 = 0;                ///< drive amplitude (sine fit or half range)
  double x_offset = 0;          ///< drive mid level c
  double psi = 0;               ///< phase at t = 0 (sine fit), rad
  double theta_origin = 0;      ///< θ at the start of cycle 1 (a multiple of 2π)
  int M_requested = 0, M_cap = 0, M = 0;
  int partial_cycles = 0;       ///< dropped incomplete cycles at the ends
  int first_steady_cycle = 0;   ///< 1-based; 0: none
  std::vector<CycleResult> cycles;
  HarmonicFit fit;              ///< over the used cycles
  Measures measures;
  double r_max = 0;             ///< mean over used cycles of CycleResult::r_max
  double r_max_raw = 0;         ///< mean over used cycles of max|r| of the samples
  double E_d = 0;               ///< mean loop area over used cycles
  double E_d_ratio = 0;         ///< E_d/(π x0² K''_1)
  double phi_d = 0;             ///< E_d/(4 x0 r_max)
  AmplitudeStatus status = AmplitudeStatus::kOk;
  // Samples of the used cycles (for the Lissajous output), response inertia-corrected.
  std::vector<int> sample_cycle;
  std::vector<double> theta, time_s, drive, response;
  std::vector<double> weight;  ///< each sample's quadrature weight in the fit over the used cycles
};

struct RecordResult {
  std::vector<AmplitudeResult> amplitudes;
  int skipped_blocks = 0;  ///< amplitude blocks without a complete cycle
};

/// Sampling cap on M (see step 4). `timed` selects the rule.
int harmonic_cap(const std::vector<double>& drive, double x0, bool timed,
                 double samples_per_cycle);

/// Phase of angle-sampled data (step 2, without time); x0 > 0.
std::vector<double> phase_from_drive(const std::vector<double>& drive, double offset, double x0);

/// The drive's sine fit (core/sine_fit.hpp).
using core::SineFit;
using core::fit_sine;

/// One stored period (an Anton Paar measuring point): samples k = 0..N of exactly one
/// drive period, the last equal to the first (InputError otherwise). The drive's
/// fundamental from its discrete Fourier coefficients gives x0, the offset and the
/// phase ψ (x ≈ c + x0 sin(2πk/N + ψ), θ_k = 2πk/N + ψ); the response's harmonics
/// n <= M = min(requested, (N − 1)/2) are its discrete Fourier coefficients (uniform
/// least squares over the period, no drift column). One cycle, status closed_cycle.
/// `omega` (rad/s, kUnset when unknown) is used for the rate measures only.
AmplitudeResult analyse_closed_cycle(const Waveform& w, const AnalysisOptions& options,
                                     double omega, const std::string& context);

/// The whole analysis of one record. `context` prefixes every message (e.g.
/// `log.csv: segment "2"`).
RecordResult analyse_record(const Waveform& w, const AnalysisOptions& options,
                            const std::string& context);

}  // namespace shearzone::laos
