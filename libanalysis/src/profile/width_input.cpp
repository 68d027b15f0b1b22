// A profile read back from CSV -> the width's input (profile/width_input.hpp).
#include "shearzone/profile/width_input.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::profile {

using io::format_number;

WidthInput width_input(const io::ProfileCsv& p) {
  const std::string& path = p.path.string();
  WidthInput in;
  for (const auto& row : p.rows) {
    in.add_bin(row.r_m, row.v_abs, row.n_vectors, row.v_noise);
    if (p.has_vector_radii) {
      in.radii.mean_m.push_back(row.r_vectors_mean);
      in.radii.sd_m.push_back(row.r_vectors_sd);
    }
    if (p.has_lockin) {
      in.v_abs_lockin.push_back(row.v_abs_lockin);
      in.v_noise_lockin.push_back(row.v_noise_lockin);
    }
  }
  if (p.has_lockin) {
    const double H = p.meta_number("lockin_harmonics");
    if (!(H >= 1 && H <= 31 && H == std::floor(H) && std::fmod(H, 2.0) == 1.0))
      throw InputError(fmt::format("{}: header \"lockin_harmonics: {}\": expected an odd number 1..31 beside the "
                                   "lock-in columns",
                                   path, p.meta("lockin_harmonics")));
    in.lockin_harmonics = static_cast<int>(H);
  }
  // The PIV's bounds (absent: 0, none known): a header value >= 0.
  auto bound = [&](const char* key, const char* expected) {
    const std::string v = p.meta(key);
    if (v.empty()) return 0.0;
    const double x = p.meta_number(key);
    if (!(x >= 0 && x < 1e6)) throw InputError(fmt::format("{}: header \"{}: {}\": expected {}", path, key, v, expected));
    return x;
  };
  in.footprint_var_m2 = bound("velocity_footprint_var_m2", "a variance >= 0 m^2");
  in.velocity_bias_m_per_s = bound("velocity_bias_bound_m_per_s", "a speed >= 0 m/s");
  in.R_m = p.meta_number("R_m");
  if (std::isnan(in.R_m)) {
    const double bin = p.meta_number("bin_m");
    in.R_m = in.r_m.back() + (std::isnan(bin) ? 0.0 : 0.5 * bin);
  }
  const std::string grouping = p.meta("groups");
  if (!grouping.empty() && !parse_grouping(grouping, in.grouping))
    throw InputError(fmt::format("{}: header \"groups: {}\": expected cycles, pairs_phase_detrended, "
                                 "pairs or none",
                                 path, grouping));
  if (in.grouping == Grouping::kNone) return in;
  const std::filesystem::path gpath = io::profile_groups_path(p.path);
  if (!std::filesystem::exists(gpath))
    throw InputError(fmt::format("{}: the per-pair means {} are missing (written beside the profile "
                                 "by `shearzone profile`); the interval needs them",
                                 path, gpath.string()));
  in.pairs.n_bins = in.r_m.size();
  bool theta = true;  // every row carries v_theta (older groups files do not)
  for (const auto& g : io::read_profile_groups_csv(gpath)) {
    const bool known = g.cycle != io::ProfileGroupRow::kNoCycle;
    if (g.pair == in.pairs.num_pairs())
      in.pairs.add_pair(g.cycle, known ? g.phase_deg / 360.0 : core::kUnset, known ? g.phase_span_deg / 360.0 : 0.0);
    theta = theta && std::isfinite(g.v_theta);
    // Bin index from the radius (same bins as the profile, ascending): the nearest
    // of the two bracketing centres, found by bisection (rows x log bins).
    auto it = std::lower_bound(in.r_m.begin(), in.r_m.end(), g.r_m);
    if (it == in.r_m.end() || (it != in.r_m.begin() && g.r_m - *(it - 1) < *it - g.r_m)) --it;
    if (std::abs(*it - g.r_m) > 1e-9 * std::max(1.0, std::abs(g.r_m)) + 1e-12)
      throw InputError(fmt::format("{}:{}: r_m = {} is not a bin of {}", gpath.string(), g.line,
                                   format_number(g.r_m), path));
    const std::size_t idx = g.pair * in.pairs.n_bins + static_cast<std::size_t>(it - in.r_m.begin());
    in.pairs.v_abs[idx] = g.v_abs;
    in.pairs.v_theta[idx] = g.v_theta;
    in.pairs.n_vectors[idx] = g.n_vectors;
  }
  if (!theta) in.pairs.v_theta.clear();  // no lock-in interval without them
  return in;
}

}  // namespace shearzone::profile
