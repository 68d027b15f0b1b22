// shearzone/laos/spp.hpp: LAOS within the cycle, Rogers' sequence of physical processes
// (SPP; Rogers & Lettinga, J. Rheol. 56, 1 (2012); Rogers, Rheol. Acta 56, 501 (2017)),
// in the Fourier mode of SPPplus: the response is reconstructed from its odd harmonics,
// the strain and rate from the drive's fundamental, and every derivative is analytic.
//
// The response curve is P(θ) = (γ, γ̇/ω, σ) with γ = x0 sin θ, γ̇/ω = x0 cos θ (x: the
// drive about its mid level; strain, or the vane angle in rad) and σ the response
// (stress, or torque). Its binormal B ∝ P' × P'' gives the transient moduli
//     G'_t = −B_γ/B_σ = (cos θ σ' − sin θ σ'')/x0,
//     G''_t = −B_γ̇/B_σ = −(sin θ σ' + cos θ σ'')/x0,
// (′: d/dθ; B_σ = −x0² for a sinusoidal drive), their rates
//     dG'_t/dθ = −sin θ (σ' + σ''')/x0,   dG''_t/dθ = −cos θ (σ' + σ''')/x0
// (per second: times ω), the transient phase angle δ_t = atan(G''_t/G'_t) + π [G'_t < 0],
// the displacement stress σ_d = σ − G'_t γ − G''_t γ̇/ω and the equilibrium strain
// γ_eq = γ − σ_d/G'_t. A linear viscoelastic response gives G'_t = G', G''_t = G''.
//
// Harmonics: the odd n <= M of a least-squares fit over the amplitude's used cycles
// (the same estimator and weights as the harmonic analysis, harmonics.hpp), M the
// largest odd number <= min(requested, the sampling cap of the analysis). A response
// with a kink (yielding) has harmonics that fall as 1/n², and the truncated series'
// second and third derivatives then ring over the whole cycle (the Dirichlet kernel
// does not decay with M); the coefficients are therefore weighted by Lanczos' σ
// factors sinc(n/(M+2)), divided by the fundamental's so that a linear response is
// reproduced exactly (docs/laos.md, "Within the cycle").
//
// Cycle measures, from the reconstructed steady cycle (the fit over the used cycles) and
// from each used cycle's own fit (same M) where there are several (both loading branches: from an
// upward zero crossing of σ to its maximum, and from a downward crossing to its
// minimum; the values are the mean of the two magnitudes):
//   - cage modulus: G'_t where σ = 0;
//   - static yield stress: σ where G'_t changes sign (+ to −) on the branch, read in the
//     lobe of G'_t <= 0 that holds the branch's lowest G'_t: at its deepest point where
//     the lobe is no wider than 2 kernel widths 2π/(M + 2) (a kink, which the σ factors
//     spread symmetrically about itself), else at its leading zero;
//   - dynamic yield stress: σ where dG'_t/dθ is smallest on the branch.
// Each is checked twice before it is given: against noise (its spread when the odd
// harmonics are redrawn `bootstrap` times from their standard errors) and against the
// truncation (its change from M to the largest odd number <= (M+1)/2, times
// 1/(√2 − 1): the error left at M if it falls no slower than M^(−1/2)). A spread or a
// truncation error above `max_relative_change` of the value gives the status
// noise_limited or truncation_limited and no value; no zero crossing or sign change, or
// (dynamic yield) a branch that keeps more than half its cage modulus: not_found.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "shearzone/core/unset.hpp"
#include "shearzone/laos/analysis.hpp"

namespace shearzone::laos {

struct SppOptions {
  int max_harmonic = 39;             ///< highest odd harmonic requested (SPPplus: 39)
  int bootstrap = 200;               ///< redraws of the harmonics for the noise check
  std::uint64_t seed = 1;            ///< of the redraws
  double max_relative_change = 0.05; ///< noise spread or truncation change, of |value|
  bool drift = true;                 ///< a linear-drift column in the fit (as the analysis's)
  void validate() const;             ///< ConfigError on bad values
};

enum class SppStatus { kOk, kNoiseLimited, kTruncationLimited, kNotFound };
/// The name written in the outputs ("ok", "noise_limited", ...).
const char* spp_status_name(SppStatus s);

/// One cycle measure with the evidence for it. `value` is NaN unless status is ok.
struct SppMeasure {
  double value = core::kUnset;
  double estimate = core::kUnset;        ///< the value at M, whatever the checks say
  double noise_sd = core::kUnset;        ///< standard deviation over the redraws
  double truncation_change = core::kUnset;  ///< estimate at M minus the estimate at M/2
  SppStatus status = SppStatus::kNotFound;
};

/// The transient quantities at one phase (response units r, drive units x).
struct SppPoint {
  double theta = 0;          ///< rad, as in AmplitudeResult::theta
  double x = 0, rate = 0;    ///< x0 sin θ and x0 cos θ (γ and γ̇/ω)
  double r = 0;              ///< the reconstructed response (odd harmonics, σ factors)
  double Gp = 0, Gpp = 0;    ///< G'_t, G''_t, r per x
  /// Standard errors of G'_t, G''_t from those of the odd harmonics (white noise; the
  /// coefficients taken as independent); NaN when none are given.
  double Gp_se = core::kUnset, Gpp_se = core::kUnset;
  double delta = 0;          ///< δ_t, rad in (−π/2, 3π/2)
  double dGp = 0, dGpp = 0;  ///< dG'_t/dθ, dG''_t/dθ, r per x per rad of phase
  double r_d = 0;            ///< displacement stress σ_d
  double x_eq = 0;           ///< equilibrium strain γ_eq
};

/// The cycle measures of one used cycle on its own (its phases only, the same M).
struct SppCycle {
  int cycle = 0;  ///< 1-based, as AmplitudeResult::sample_cycle
  SppMeasure cage_modulus, static_yield, dynamic_yield;
};

struct SppResult {
  int M = 0;                        ///< highest odd harmonic used
  int M_check = 0;                  ///< the truncation check's
  double x0 = 0;
  double omega = core::kUnset;      ///< rad/s (NaN: rates per second unknown)
  std::vector<double> a, b;         ///< σ-weighted odd coefficients: r = Σ a_n sin nθ + b_n cos nθ
  std::vector<double> a_se, b_se;   ///< their standard errors
  SppMeasure cage_modulus, static_yield, dynamic_yield;  ///< over the used cycles
  std::vector<SppCycle> cycles;     ///< each used cycle on its own (when there are several)
  std::vector<SppPoint> points;     ///< at the amplitude's samples (AmplitudeResult::theta)
};

/// The transient quantities at θ from coefficients a, b (index n, odd n used), with the
/// standard errors of G'_t and G''_t when a_se, b_se (same indexing) are given.
SppPoint spp_point(const std::vector<double>& a, const std::vector<double>& b, double x0, double theta,
                   const std::vector<double>* a_se = nullptr, const std::vector<double>* b_se = nullptr);

/// SPP of one analysed amplitude. InputError (prefixed with `context`) when its used
/// cycles hold too few samples for a harmonic fit with M >= 3.
SppResult analyse_spp(const AmplitudeResult& A, const SppOptions& options, const std::string& context);

}  // namespace shearzone::laos
