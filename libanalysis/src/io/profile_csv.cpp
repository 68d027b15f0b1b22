#include "shearzone/io/profile_csv.hpp"

#include <cmath>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::io {

std::string ProfileCsv::meta(const std::string& key) const { return core::metadata_value(metadata, key); }

double ProfileCsv::meta_number(const std::string& key) const {
  double v = 0;
  const std::string s = meta(key);
  return !s.empty() && parse_number(s, false, v) ? v : core::kUnset;
}

std::filesystem::path profile_groups_path(const std::filesystem::path& profile) {
  return profile.parent_path() / (profile.stem().string() + "_groups.csv");
}

void write_profile_csv(std::ostream& out, const core::Metadata& metadata, const std::vector<ProfileCsvRow>& rows) {
  CsvWriter w(out, metadata,
              {"r_m", "v_abs_m_per_s", "v_theta_m_per_s", "v_r_m_per_s", "v_abs_rms_m_per_s", "v_abs_sem_m_per_s",
               "v_noise_m_per_s", "n_vectors", "n_masked", "n_invalid", "v_theta_amp_m_per_s",
               "v_theta_amp_se_m_per_s", "v_theta_lag_deg", "v_theta_inphase_m_per_s", "v_abs_lockin_m_per_s",
               "v_abs_lockin_se_m_per_s", "v_noise_lockin_m_per_s", "lockin_n_eff", "r_vectors_mean_m", "r_vectors_sd_m",
               "dv_theta_measured_m_per_s", "dv_theta_m_per_s"});
  for (const auto& b : rows) {
    const bool have = b.n_vectors > 0;
    auto cell = [&](double v) { return have ? format_number_or_empty(v) : std::string(); };
    w.row(std::vector<std::string>{format_number(b.r_m), cell(b.v_abs), cell(b.v_theta), cell(b.v_r),
                                   cell(b.v_abs_rms), cell(b.v_abs_sem), format_number(b.v_noise),
                                   std::to_string(b.n_vectors), std::to_string(b.n_masked),
                                   std::to_string(b.n_invalid), cell(b.amp), cell(b.amp_se), cell(b.lag_deg),
                                   cell(b.in_phase), cell(b.v_abs_lockin), cell(b.v_abs_lockin_se),
                                   cell(b.v_noise_lockin), cell(b.n_eff), cell(b.r_vectors_mean),
                                   cell(b.r_vectors_sd), cell(b.dv_theta_measured), cell(b.dv_theta)});
  }
}

void write_profile_groups_csv(std::ostream& out, const core::Metadata& metadata,
                              const std::vector<ProfileGroupRow>& rows) {
  core::Metadata m = metadata;
  m.emplace_back("pair", "index of the pair among the selected ones, in time order");
  m.emplace_back("cycle", "oscillation cycle floor(f (t - t0)); empty when f is unknown");
  m.emplace_back("phase_deg", "oscillation phase at the pair's mid-time; empty when f is unknown");
  m.emplace_back("phase_span_deg", "drive phase spanned by the pair (360 f dt); empty when f is unknown");
  CsvWriter w(out, m, {"pair", "cycle", "phase_deg", "phase_span_deg", "r_m", "v_abs_m_per_s", "v_theta_m_per_s",
                       "n_vectors"});
  for (const auto& g : rows) {
    const bool known = g.cycle != ProfileGroupRow::kNoCycle;
    w.row(std::vector<std::string>{std::to_string(g.pair), known ? std::to_string(g.cycle) : "",
                                   known ? format_number(g.phase_deg) : "",
                                   known ? format_number(g.phase_span_deg) : "", format_number(g.r_m),
                                   format_number(g.v_abs), format_number_or_empty(g.v_theta),
                                   format_number(g.n_vectors)});
  }
}

ProfileCsv read_profile_csv(const std::filesystem::path& path) {
  const CsvTable t = read_csv(path);
  if (t.num_rows() == 0) throw InputError(fmt::format("{}: the profile has no rows", path.string()));
  ProfileCsv p;
  p.path = path;
  p.metadata = t.metadata;
  p.rows.resize(t.num_rows());
  const auto r = t.numeric_column("r_m");
  const auto noise = t.numeric_column("v_noise_m_per_s");
  const auto nv = t.numeric_column("n_vectors");
  for (std::size_t k = 0; k < nv.size(); ++k) {
    const double x = nv[k];
    if (!(x >= 0 && x == std::floor(x)))
      throw InputError(fmt::format("{}: column \"n_vectors\": {} is not a count", path.string(), x));
    p.rows[k].r_m = r[k];
    p.rows[k].v_noise = noise[k];
    p.rows[k].n_vectors = static_cast<std::size_t>(x);
  }
  // v_abs is empty in bins without vectors; a bin with vectors must carry a number.
  const std::size_t cv = t.column_index("v_abs_m_per_s");
  for (std::size_t k = 0; k < t.num_rows(); ++k)
    p.rows[k].v_abs = p.rows[k].n_vectors == 0 && t.cell_empty(k, cv) ? core::kUnset
                                                                       : t.number(k, cv);
  // The vectors' radii: optional (files written before the columns existed); both or
  // neither in a bin with vectors.
  if (t.has_column("r_vectors_mean_m") && t.has_column("r_vectors_sd_m")) {
    const std::size_t cm = t.column_index("r_vectors_mean_m"), cs = t.column_index("r_vectors_sd_m");
    for (std::size_t k = 0; k < t.num_rows(); ++k) {
      if (p.rows[k].n_vectors == 0) continue;
      if (t.cell_empty(k, cm) || t.cell_empty(k, cs))
        throw InputError(fmt::format("{}:{}: columns \"r_vectors_mean_m\", \"r_vectors_sd_m\": empty in a bin with "
                                     "vectors; expected both",
                                     path.string(), t.row_lines[k]));
      p.rows[k].r_vectors_mean = t.number(k, cm);
      p.rows[k].r_vectors_sd = t.number(k, cs);
      if (!(p.rows[k].r_vectors_sd >= 0))
        throw InputError(fmt::format("{}:{}: column \"r_vectors_sd_m\": {}; expected a standard deviation >= 0",
                                     path.string(), t.row_lines[k], format_number(p.rows[k].r_vectors_sd)));
    }
    p.has_vector_radii = true;
  }
  // Lock-in columns: optional (profiles written without a known drive phase, or by an
  // older version, have them empty or absent); a value needs its floor.
  if (t.has_column("v_abs_lockin_m_per_s") && t.has_column("v_noise_lockin_m_per_s")) {
    const std::size_t cl = t.column_index("v_abs_lockin_m_per_s"), cn = t.column_index("v_noise_lockin_m_per_s");
    for (std::size_t k = 0; k < t.num_rows(); ++k) {
      if (t.cell_empty(k, cl)) continue;
      p.rows[k].v_abs_lockin = t.number(k, cl);
      if (t.cell_empty(k, cn))
        throw InputError(fmt::format("{}:{}: column \"v_noise_lockin_m_per_s\": empty beside a lock-in value; "
                                     "expected its floor",
                                     path.string(), t.row_lines[k]));
      p.rows[k].v_noise_lockin = t.number(k, cn);
      p.has_lockin = true;
    }
  }
  return p;
}

std::vector<ProfileGroupRow> read_profile_groups_csv(const std::filesystem::path& path) {
  const CsvTable g = read_csv(path);
  const std::size_t cc = g.column_index("cycle"), cph = g.column_index("phase_deg");
  const bool has_span = g.has_column("phase_span_deg"), has_theta = g.has_column("v_theta_m_per_s");
  const std::size_t csp = has_span ? g.column_index("phase_span_deg") : 0;
  const std::size_t cth = has_theta ? g.column_index("v_theta_m_per_s") : 0;
  const auto pair = g.numeric_column("pair"), r = g.numeric_column("r_m"), v = g.numeric_column("v_abs_m_per_s"),
             nv = g.numeric_column("n_vectors");
  std::vector<ProfileGroupRow> rows(g.num_rows());
  std::size_t pairs = 0;  // pairs seen so far
  for (std::size_t k = 0; k < g.num_rows(); ++k) {
    if (!(pair[k] >= 0 && pair[k] == std::floor(pair[k]) && pair[k] < 1e8))
      throw InputError(fmt::format("{}:{}: column \"pair\": {} is not a pair index", path.string(), g.row_lines[k],
                                   format_number(pair[k])));
    const auto pk = static_cast<std::size_t>(pair[k]);
    if (pk + 1 < pairs || pk > pairs)
      throw InputError(fmt::format("{}:{}: pair {} out of order: rows must come pair by pair", path.string(),
                                   g.row_lines[k], pk));
    auto& row = rows[k];
    row.pair = pk;
    row.line = g.row_lines[k];
    if (pk == pairs) {  // a pair's cycle and phase are read from its first row
      ++pairs;
      if (!g.cell_empty(k, cc)) {
        row.cycle = static_cast<int>(g.number(k, cc));
        row.phase_deg = g.number(k, cph);
        if (has_span && !g.cell_empty(k, csp)) row.phase_span_deg = g.number(k, csp);
      }
    }
    row.r_m = r[k];
    row.v_abs = v[k];
    if (has_theta && !g.cell_empty(k, cth)) row.v_theta = g.number(k, cth);
    row.n_vectors = nv[k];
  }
  return rows;
}

}  // namespace shearzone::io
