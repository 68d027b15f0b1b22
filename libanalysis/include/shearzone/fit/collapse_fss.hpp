// shearzone/fit/collapse_fss.hpp: non-parametric finite-size-scaling data collapse
// (`shearzone collapse fss`), after Houdayer & Hartmann, PRB 70, 014418 (2004).
//
// Data: curves y(x) with errors dy, one per system size L (chain length N, lattice
// size, ...). Scaling ansatz (the form autoScale uses):
//     x~ = (x - x_c) L^a,   y~ = y L^b,   dy~ = dy L^b.
// Quality S: for every point (x~, y~, dy~) of size L whose x~ lies in the window
// [lo, hi], each OTHER size L' contributes the two of its points that bracket x~
// (the largest x~' <= x~ and the smallest x~' > x~; a size that does not bracket x~
// contributes nothing). A straight line through all these points, weighted by
// 1/dy~'^2, gives the master-curve value Y and its standard error dY at x~. Then
//     S = (1/N_terms) sum (y~ - Y)^2 / (dy~^2 + dY^2)
// over the points where Y is defined. S ~ 1 for a good collapse with correct errors.
//
// S is DISCONTINUOUS in (x_c, a, b): when a scaled point crosses a point of another
// size, the bracketing pair changes and S jumps. It is minimised with a
// derivative-free method (GSL Nelder-Mead simplex, nmsimplex2, restarted from its
// own optimum until it stops improving); gradients would be meaningless.
//
// Errors:
//  - "S+1": one parameter moves, the others stay at the optimum, until S reaches
//    S_min + 1 (an expanding scan, then bisection), on each side: asymmetric errors.
//    S is a mean over N_terms terms, so S+1 is Delta chi^2 = N_terms, a conservative
//    scale; correlations are ignored.
//  - Bootstrap: replicates that resample points within each size (kPoints) or whole
//    sizes (kCurves) with replacement, each re-minimised from the optimum; percentile
//    confidence intervals. Deterministic for a given seed: std::mt19937_64 mapped to
//    indices by an explicit modulo (std distributions are implementation-defined).
// No GSL types appear here; GSL is private to the library.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "shearzone/core/unset.hpp"

namespace shearzone::fit {

/// One system size: points sorted by x (ascending; ties keep input order).
struct FssCurve {
  double L = 0.0;
  std::vector<double> x, y, dy;
  std::vector<std::size_t> rows;  ///< index of each point in the input arrays
};

/// The curves, sorted by L ascending.
struct FssDataSet {
  std::vector<FssCurve> curves;
  std::size_t num_points() const;
};

/// Groups long-form data by L (exact equality) and sorts each size by x.
/// `dy` empty: every point gets dy = 1 (see FssFitOptions::rescale_errors).
/// Throws InputError on length mismatch, non-finite values, L <= 0 or dy <= 0
/// (naming the 0-based row; the job layer checks files with their line numbers first).
FssDataSet make_fss_dataset(const std::vector<double>& L, const std::vector<double>& x,
                            const std::vector<double>& y, const std::vector<double>& dy);

/// Scaling parameters. Index order everywhere: 0 = x_c, 1 = a, 2 = b.
using FssParams = std::array<double, 3>;
/// "x_c", "a", "b".
const char* fss_param_name(std::size_t k);

/// Window on the scaled x of the points whose terms enter S (inclusive).
struct FssWindow {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
};

struct FssQuality {
  double S = core::kUnset;  ///< NaN when n_terms == 0
  std::size_t n_terms = 0;
};

/// Bootstrap multiplicities: weights[c][i] >= 0 for point i of curve c. A point with
/// weight 0 is absent (no term, not a bracket point); weight w counts its term w
/// times. Empty: every point has weight 1.
using FssWeights = std::vector<std::vector<double>>;

/// The quality S at `p`.
FssQuality fss_quality(const FssDataSet& data, const FssParams& p, const FssWindow& window,
                       const FssWeights& weights = {});

/// One point with its scaled coordinates and master-curve value.
struct FssPoint {
  std::size_t curve = 0, index = 0;  ///< position in FssDataSet
  double L = 0, x = 0, y = 0, dy = 0;
  double x_scaled = 0, y_scaled = 0, dy_scaled = 0;
  bool in_window = false;
  bool has_master = false;  ///< Y defined (at least one other size brackets x_scaled)
  double Y = core::kUnset;
  double dY = core::kUnset;
  double term = core::kUnset;  ///< (y~-Y)^2/(dy~^2+dY^2)
};

/// Every point (curve by curve, x ascending) at `p`.
std::vector<FssPoint> fss_points(const FssDataSet& data, const FssParams& p,
                                 const FssWindow& window);

enum class FssBootstrapMode { kPoints, kCurves };
/// "points" / "curves"; ConfigError otherwise.
FssBootstrapMode fss_bootstrap_mode_from_name(const std::string& name);
const char* fss_bootstrap_mode_name(FssBootstrapMode m);

struct FssFitOptions {
  FssParams start{0.0, 1.0, 0.0};
  /// Initial simplex step per parameter; NaN: x_c 1 % of the x range of the data,
  /// a and b 0.01. The simplex works in units of these steps.
  FssParams step{core::kUnset,
                 core::kUnset,
                 core::kUnset};
  std::array<bool, 3> fixed{false, false, false};  ///< fixed parameters keep `start`
  FssWindow window;
  double tolerance = 1e-6;     ///< stop when the simplex size < tolerance (step units)
  int max_iterations = 20000;  ///< per Nelder-Mead run
  int max_restarts = 10;       ///< restarts from the optimum while S still improves
  /// Scale every dy by sqrt(S_min) after the minimisation, so that S_min = 1 and the
  /// S+1 errors read as for a chi^2 with errors estimated from the scatter. The
  /// fallback when the data have no errors (make_fss_dataset with empty dy).
  bool rescale_errors = false;
  bool s_plus_one = true;      ///< compute the S+1 errors
  int bootstrap = 0;           ///< replicates (0: none)
  std::uint64_t seed = 1;
  FssBootstrapMode bootstrap_mode = FssBootstrapMode::kPoints;
  double ci_level = 0.95;      ///< central percentile interval of the bootstrap

  /// ConfigError on bad values (steps <= 0, window lo >= hi, ci outside (0,1), ...).
  void validate() const;
};

struct FssFitResult {
  FssParams best{};
  FssQuality quality;          ///< at `best` (after any error rescaling)
  double dy_scale = 1.0;       ///< factor applied to every dy (rescale_errors), else 1
  FssParams step{};            ///< steps used
  int evaluations = 0;         ///< S evaluations of the minimisation
  int restarts = 0;
  bool converged = false;      ///< last simplex reached `tolerance`
  /// S+1 errors (positive distances below/above best); +inf: S never reached
  /// S_min + 1 within 1e6 steps; NaN: fixed parameter or not computed.
  FssParams err_low{}, err_high{};
  /// Bootstrap percentile interval (NaN: none / fixed).
  FssParams ci_low{}, ci_high{};
  std::size_t bootstrap_ok = 0, bootstrap_failed = 0;
  std::vector<FssParams> bootstrap_samples;  ///< optimum of each successful replicate
};

/// Minimises S from options.start. Throws NoResultError when fewer than two sizes
/// exist or no point of one size is bracketed by another inside the window at the
/// start (S undefined), and ConfigError on bad options.
FssFitResult fit_fss_collapse(const FssDataSet& data, const FssFitOptions& options);

}  // namespace shearzone::fit
