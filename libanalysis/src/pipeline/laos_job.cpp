// `shearzone laos`: logs -> laos stage -> summary, cycles, harmonics, Lissajous CSVs.
#include "shearzone/pipeline/laos_job.hpp"

#include <cmath>
#include <memory>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/units.hpp"

namespace shearzone::pipeline {

namespace fs = std::filesystem;

namespace {

/// Column-name vocabulary of one unit system.
struct Names {
  std::string x0, r_max, K, K_s, E, x, xn, xdotn, r, r_max_raw;
};
Names names(bool ss) {
  if (ss) return {"gamma0", "sigma_max_Pa", "Pa", "Pa_s", "E_d_J_per_m3", "gamma", "gamma_over_gamma0",
                  "gammadot_over_gammadot_max", "sigma_Pa", "sigma_max_raw_Pa"};
  return {"phi0_rad", "tau_max_N_m", "N_m_per_rad", "N_m_s_per_rad", "E_d_J", "phi_rad",
          "phi_over_phi0", "phidot_over_phidot_max", "tau_N_m", "tau_max_raw_N_m"};
}

using io::format_number_nan_empty;

std::string join_ints(const std::vector<int>& v) {
  std::string s;
  for (int x : v) s += (s.empty() ? "" : ",") + std::to_string(x);
  return s.empty() ? "steady" : s;
}

/// x rounded to 3 significant digits: a grouping key for `fit power --group`.
double nominal(double x) {
  if (!(x > 0) || !std::isfinite(x)) return x;
  const int k = 2 - static_cast<int>(std::floor(std::log10(x)));
  const double p = std::pow(10.0, std::abs(k));  // exact for |k| <= 22
  return k >= 0 ? std::round(x * p) / p : std::round(x / p) * p;
}

/// What the instrument reported for a segment (kUnset when absent).
struct Instrument {
  double f_Hz = core::kUnset, G_prime_Pa = core::kUnset, G_dprime_Pa = core::kUnset;
  double torque_N_m = core::kUnset;
};

struct Item {
  std::string source, segment, N;
  laos::AmplitudeResult A;
  Instrument instrument;
};

}  // namespace

void LaosJobOptions::validate() const {
  if (inputs.empty()) throw ConfigError("laos: no input log given");
  if (output.empty()) throw ConfigError("laos: no output folder given (-o)");
  analysis.validate();
  // Unit overrides: a unit of one of the kinds the column can hold (a vendor log decides
  // between angle/torque and strain/stress only when read).
  const auto unit_ok = [](const std::string& unit, const char* option, io::UnitKind a, io::UnitKind b) {
    if (unit.empty() || io::find_unit_scale(unit, a) || io::find_unit_scale(unit, b)) return;
    throw ConfigError(fmt::format("{} \"{}\": not a unit of {} (expected {}) or {} (expected {})", option, unit,
                                  io::unit_kind_name(a), io::accepted_units(a), io::unit_kind_name(b),
                                  io::accepted_units(b)));
  };
  unit_ok(read.time_unit, "--time-unit", io::UnitKind::kTime, io::UnitKind::kTime);
  unit_ok(read.angle_unit, "--angle-unit", io::UnitKind::kAngle, io::UnitKind::kStrain);
  unit_ok(read.torque_unit, "--torque-unit", io::UnitKind::kTorque, io::UnitKind::kStress);
  if (!std::isnan(f_Hz) && !(f_Hz > 0 && std::isfinite(f_Hz)))
    throw ConfigError(fmt::format("laos: --f-hz {}; expected a frequency > 0", f_Hz));
  if (!std::isfinite(inertia_kg_m2) || inertia_kg_m2 < 0)
    throw ConfigError(fmt::format("laos: --inertia-kg-m2 {}; expected >= 0", inertia_kg_m2));
  const bool s = !std::isnan(stress_constant_Pa_per_N_m), g = !std::isnan(strain_constant_per_rad);
  if (s != g)
    throw ConfigError("laos: --stress-constant and --strain-constant go together; expected both");
  if (s && !(stress_constant_Pa_per_N_m > 0 && strain_constant_per_rad > 0))
    throw ConfigError(fmt::format("laos: vane constants {} Pa/(N m), {} 1/rad; expected both > 0",
                                  stress_constant_Pa_per_N_m, strain_constant_per_rad));
  if (s && log_constants)
    throw ConfigError("laos: --stress-constant/--strain-constant and --log-constants exclude each other");
  for (const auto& [k, v] : tags)
    if (k.empty()) throw ConfigError(fmt::format("laos: --tag \"={}\": expected KEY=VALUE", v));
  if (spp) spp_options.validate();
}

namespace {

/// Every input log read and analysed (each segment, each amplitude), with the
/// quantity of the logs (strain/stress: true), which all must share.
struct Analysed {
  std::vector<Item> items;
  std::optional<bool> native_ss;
};
Analysed analyse_logs(const LaosJobOptions& o, bool convert, const std::string& tag_N, LaosJobSummary& sum) {
  Analysed an;
  std::vector<Item>& items = an.items;
  // The logs' own quantity (a RheoCompass waveform in strain/stress, a RepTate file) or
  // the options'; all inputs must agree, since the output columns follow it.
  std::optional<bool>& native_ss = an.native_ss;
  for (const auto& path : o.inputs) {
    const io::OscillationLog log = io::read_oscillation_log(path, o.read);
    ++sum.logs;
    const bool log_ss = log.quantity == io::LogQuantity::kStrainStress;
    if (native_ss && *native_ss != log_ss)
      throw InputError(fmt::format("{}: holds {} while an earlier input holds {}; expected one "
                                   "quantity for all inputs",
                                   log.source, log_ss ? "strain/stress" : "angle/torque",
                                   log_ss ? "angle/torque" : "strain/stress"));
    native_ss = log_ss;
    if (convert && log_ss)
      throw ConfigError(fmt::format("laos: {}: vane constants convert angle/torque logs; this log "
                                    "is already strain/stress",
                                    log.source));
    if (log_ss && o.inertia_kg_m2 > 0)
      throw ConfigError(fmt::format("laos: {}: --inertia-kg-m2 needs an angle/torque log (or vane "
                                    "constants); this log is strain/stress",
                                    log.source));
    laos::AnalysisOptions ao = o.analysis;
    ao.omega_rad_per_s = !std::isnan(o.f_Hz) ? 2 * std::numbers::pi * o.f_Hz : log.omega_rad_per_s;
    double Cs = 1, Cg = 1;
    if (convert) {
      Cs = o.log_constants ? log.stress_constant_Pa_per_N_m : o.stress_constant_Pa_per_N_m;
      Cg = o.log_constants ? log.strain_constant_per_rad : o.strain_constant_per_rad;
      if (!(Cs > 0) || !(Cg > 0)) {
        std::string why = core::metadata_value(log.parameters, "stress_constant_Pa_per_N_m_unparsed");
        if (why.empty()) why = core::metadata_value(log.parameters, "strain_constant_per_rad_unparsed");
        throw InputError(fmt::format("{}: --log-constants: the log gives no usable stress and strain "
                                     "constants (found {} Pa/(N m), {} 1/rad){}; expected both > 0",
                                     log.source, Cs, Cg, why.empty() ? "" : " (" + why + ")"));
      }
    }
    ao.inertia = o.inertia_kg_m2 * Cs / Cg;
    const std::string N = !tag_N.empty() ? tag_N : core::metadata_value(log.parameters, "N");
    if (log.segments.empty())
      throw InputError(fmt::format("{}: no data rows; expected an oscillation log", log.source));
    for (const auto& seg : log.segments) {
      core::Waveform w = seg;  // a copy: the conversion below scales it
      if (convert) {
        for (auto& v : w.drive) v *= Cg;
        for (auto& v : w.response) v *= Cs;
      }
      const std::string context = log.segments.size() > 1
                                      ? fmt::format("{}: segment \"{}\"", log.source, seg.label)
                                      : log.source;
      const Instrument ins{seg.instrument_frequency_Hz, seg.instrument_G_prime_Pa,
                           seg.instrument_G_dprime_Pa, seg.instrument_torque_N_m};
      if (seg.closed_cycle) {
        // One stored period: ω from the option, else the instrument's frequency of the point.
        double omega = ao.omega_rad_per_s;
        if (std::isnan(o.f_Hz) && !std::isnan(seg.instrument_frequency_Hz))
          omega = 2 * std::numbers::pi * seg.instrument_frequency_Hz;
        items.push_back({log.source, seg.label, N, laos::analyse_closed_cycle(w, ao, omega, context), ins});
        continue;
      }
      auto rec = laos::analyse_record(w, ao, context);
      sum.skipped_blocks += static_cast<std::size_t>(rec.skipped_blocks);
      for (auto& A : rec.amplitudes) items.push_back({log.source, seg.label, N, std::move(A), ins});
    }
  }
  return an;
}

/// The header of every table: conventions, options, model.
core::Metadata laos_metadata(const LaosJobOptions& o, const core::Metadata& header, bool ss, bool convert,
                             const Names& nm) {
  core::Metadata meta = header;
  auto add = [&](const std::string& k, const std::string& v) { meta.emplace_back(k, v); };
  std::string ins;
  for (const auto& p : o.inputs) ins += (ins.empty() ? "" : " ") + p.string();
  add("inputs", ins);
  add("format", io::log_format_name(o.read.format));
  add("quantity", ss ? (convert ? "strain_stress_from_vane_constants" : "strain_stress") : "angle_torque");
  add("harmonics_requested_M", std::to_string(o.analysis.max_harmonic));
  add("harmonic_cap", "M = min(requested, cap); cap = floor(pi/sqrt(2 dphi/phi0)) angle-sampled, "
                      "floor((samples per cycle - 1)/2) timed; M used per amplitude in column M");
  add("drift_column", o.analysis.drift ? "true" : "false");
  add("split_amplitudes", o.analysis.split_amplitudes ? "true" : "false");
  add("amplitude_change", format_number_nan_empty(o.analysis.amplitude_change));
  add("steady_tolerance", format_number_nan_empty(o.analysis.steady_tolerance));
  add("cycles", o.analysis.all_cycles ? "all" : join_ints(o.analysis.cycles));
  add("f_Hz", format_number_nan_empty(o.f_Hz));
  add("inertia_kg_m2", format_number_nan_empty(o.inertia_kg_m2));
  add("stress_constant_Pa_per_N_m", format_number_nan_empty(o.stress_constant_Pa_per_N_m));
  add("strain_constant_per_rad", format_number_nan_empty(o.strain_constant_per_rad));
  add("log_constants", o.log_constants ? "true" : "false");
  for (const auto& [k, v] : o.tags) add("tag_" + k, v);
  add("laos_model", "response = x0 sum_{n=1..M} [K'_n sin(n theta) + K''_n cos(n theta)] + offset + "
                    "drift; drive x = x0 sin(theta) + c; quadrature-weighted least squares in theta");
  add("laos_phase", "theta = omega t + psi from a 4-parameter sine fit of the drive (timed logs), "
                    "else arcsin(x/x0) / pi - arcsin by the sign of dx; Phi_n = delta_n - n delta_1 "
                    "mod 2 pi, delta_n = atan2(K''_n, K'_n); a closed cycle (one stored period of N "
                    "samples, phase_method closed_cycle_dft): theta_k = 2 pi k/N + psi, harmonics "
                    "by the discrete Fourier transform of the period, no drift column");
  add("tau_max", fmt::format("{}: mean over the used cycles of the largest |offset + sum over odd n of the "
                              "harmonics| of each cycle's fit (the symmetric response without drift: robust to "
                              "a single impulsive sample); {}: mean over the used cycles of the largest |sample|",
                              nm.r_max, nm.r_max_raw));
  add("instrument_columns", "instrument_*: what the instrument itself reported for the segment "
                            "(frequency, G', G'', torque amplitude); empty when the log has none");
  add("laos_sign", "phi > 0 counter-clockwise as the camera sees it; tau > 0 when the motor drives "
                   "towards +phi; an elastic sample has K' > 0");
  if (o.spp) {
    add("spp_model", "Rogers' sequence of physical processes, Fourier mode: P = (x, xdot/omega, r) with x = x0 "
                     "sin(theta), xdot/omega = x0 cos(theta) (the drive's fundamental about its mid level) and r "
                     "from the odd harmonics n <= M_spp of a fit over the used cycles, weighted by Lanczos "
                     "sigma factors sinc(n/(M_spp+2))/sinc(1/(M_spp+2)); G't = -B_x/B_r, G''t = -B_xdot/B_r "
                     "(B: the binormal of P), delta_t = atan(G''t/G't) + pi [G't < 0], r_d = r - G't x - G''t "
                     "xdot/omega, x_eq = x - r_d/G't; rates d/dt = omega d/dtheta");
    add("spp_harmonics_requested", std::to_string(o.spp_options.max_harmonic));
    add("spp_cycle_measures", "on both loading branches (from a zero crossing of r to its extremum), the mean "
                              "of the magnitudes: cage = G't where r = 0; static yield = r where G't changes "
                              "sign + to -, in the lobe of G't <= 0 holding the branch's lowest G't: at its "
                              "deepest point where the lobe is at most 2 kernel widths 2 pi/(M_spp+2) wide (a "
                              "kink), else at its leading zero; dynamic yield = r at the smallest dG't/dtheta (where G't "
                              "falls below half the cage value)");
    add("spp_checks", fmt::format("a measure is given (status ok) when its spread over {} redraws of the odd "
                                  "harmonics from their standard errors and its change from M_spp to M_check "
                                  "(the largest odd number <= (M_spp+1)/2) times 1/(sqrt(2) - 1) are both "
                                  "within {:.3g} % of it; "
                                  "else noise_limited or truncation_limited and no value (the _unchecked "
                                  "column keeps it); G't and G''t per sample carry standard errors from those "
                                  "of the harmonics",
                                  o.spp_options.bootstrap, 100 * o.spp_options.max_relative_change));
  }
  add("laos_chebyshev", "e_n = K'_n (-1)^((n-1)/2), v_n = K''_n/omega, K_M = sum n K'_n, K_L = sum e_n, "
                        "eta_M = sum n v_n (-1)^((n-1)/2), eta_L = sum v_n (odd n <= M); S = (K_L - "
                        "K_M)/K_L, T = (eta_L - eta_M)/eta_L");

  return meta;
}

/// summary.csv's columns: the tags, then the measures in the log's units.
std::vector<std::string> summary_columns(const std::vector<std::pair<std::string, std::string>>& extra_tags,
                                         bool ss, const Names& nm) {
  std::vector<std::string> cols = {"source", "segment", "amplitude", "N"};
  for (const auto& kv : extra_tags) cols.push_back(kv.first);
  const std::string K = nm.K, Ks = nm.K_s;
  const std::string Kp = ss ? "G1_prime_" + K : "K1_prime_" + K;
  const std::string Kpp = ss ? "G1_dprime_" + K : "K1_dprime_" + K;
  const std::string Kpse = ss ? "G1_prime_se_" + K : "K1_prime_se_" + K;
  const std::string Kppse = ss ? "G1_dprime_se_" + K : "K1_dprime_se_" + K;
  const std::string pre = ss ? "G" : "K";
  for (const std::string& c :
       {std::string("first_line"), std::string("last_line"), nm.x0, ss ? std::string("gamma0_nominal") : std::string("phi0_nominal_rad"),
        std::string("omega_rad_per_s"),
        nm.r_max, nm.r_max_raw, Kp, Kpse, Kpp, Kppse, std::string("tan_delta_1"), std::string("I2_over_I1"),
        std::string("I3_over_I1"), std::string("Phi3_rad"), "e1_" + K, std::string("e3_over_e1"),
        "v1_" + Ks, std::string("v3_over_v1"), pre + "_M_prime_" + K, pre + "_L_prime_" + K,
        "eta_M_" + Ks, "eta_L_" + Ks, std::string("S"), std::string("T"), nm.E,
        std::string("E_d_ratio"), std::string("phi_d"), std::string("n_cycles"),
        std::string("n_cycles_complete"), std::string("n_partial_cycles"),
        std::string("first_steady_cycle"), std::string("M"), std::string("M_cap"),
        std::string("phase_method"), std::string("drive_offset"), std::string("status"),
        std::string("instrument_f_Hz"), std::string("instrument_G_prime_Pa"),
        std::string("instrument_G_dprime_Pa"), std::string("instrument_torque_N_m")})
    cols.push_back(c);

  return cols;
}

/// summary.csv: a row per amplitude (and the job summary's rows).
void write_summary(io::AtomicOutputSet& set, const core::Metadata& meta, const std::vector<std::string>& cols,
                   const std::vector<Item>& items, const std::vector<std::pair<std::string, std::string>>& extra_tags,
                   LaosJobSummary& sum) {
  auto& f = set.add("summary.csv");
  io::CsvWriter w(f.stream(), meta, cols);
  for (std::size_t i = 0; i < items.size(); ++i) {
    const auto& it = items[i];
    const auto& A = it.A;
    const auto& m = A.measures;
    int used = 0;
    for (const auto& c : A.cycles) used += c.used ? 1 : 0;
    std::vector<std::string> row = {it.source, it.segment, std::to_string(i + 1), it.N};
    for (const auto& kv : extra_tags) row.push_back(kv.second);
    const std::vector<double> vals = {
        static_cast<double>(A.first_line), static_cast<double>(A.last_line), A.x0,
        nominal(A.x0), A.omega,
        A.r_max, A.r_max_raw, m.K1p, m.K1p_se, m.K1pp, m.K1pp_se, m.tan_delta, m.I2_over_I1, m.I3_over_I1,
        A.M >= 3 ? m.Phi[3] : core::kUnset, m.e[1], m.e3_over_e1, m.v[1], m.v3_over_v1, m.K_M,
        m.K_L, m.eta_M, m.eta_L, m.S, m.T, A.E_d, A.E_d_ratio, A.phi_d,
        static_cast<double>(used), static_cast<double>(A.cycles.size()),
        static_cast<double>(A.partial_cycles), static_cast<double>(A.first_steady_cycle),
        static_cast<double>(A.M), static_cast<double>(A.M_cap)};
    for (double v : vals) row.push_back(format_number_nan_empty(v));
    if (A.first_line == 0) row[row.size() - vals.size()] = row[row.size() - vals.size() + 1] = "";
    if (A.first_steady_cycle == 0) row[row.size() - 4] = "";
    row.push_back(A.phase_method);
    row.push_back(format_number_nan_empty(A.x_offset));
    row.push_back(laos::amplitude_status_name(A.status));
    for (double v : {it.instrument.f_Hz, it.instrument.G_prime_Pa, it.instrument.G_dprime_Pa,
                     it.instrument.torque_N_m})
      row.push_back(format_number_nan_empty(v));
    w.row(row);
    sum.rows.push_back({it.source, it.segment, A.status, i + 1, A.x0, A.r_max, m.K1p, m.K1pp,
                        m.tan_delta, m.I3_over_I1, A.phi_d, A.M, used,
                        static_cast<int>(A.cycles.size())});
  }
}

/// cycles.csv: a row per cycle of every amplitude.
void write_cycles(io::AtomicOutputSet& set, const core::Metadata& meta, const std::vector<Item>& items, bool ss,
                  const Names& nm) {
  const std::string& K = nm.K;
  auto& f = set.add("cycles.csv");
  io::CsvWriter w(f.stream(), meta,
                  {"source", "segment", "amplitude", "cycle", "t_start_s", nm.x0, nm.r_max, nm.r_max_raw,
                   (ss ? "G1_prime_" : "K1_prime_") + K, (ss ? "G1_dprime_" : "K1_dprime_") + K,
                   nm.E, "steady", "used"});
  for (std::size_t i = 0; i < items.size(); ++i)
    for (const auto& c : items[i].A.cycles)
      w.row(std::vector<std::string>{
          items[i].source, items[i].segment, std::to_string(i + 1), std::to_string(c.cycle),
          format_number_nan_empty(c.t_start_s), format_number_nan_empty(c.x0),
          format_number_nan_empty(c.r_max), format_number_nan_empty(c.r_max_raw), format_number_nan_empty(c.K1p), format_number_nan_empty(c.K1pp),
          format_number_nan_empty(c.E_d), c.steady ? "1" : "0", c.used ? "1" : "0"});
}

/// harmonics.csv: a row per harmonic of every amplitude.
void write_harmonics(io::AtomicOutputSet& set, const core::Metadata& meta, const std::vector<Item>& items, bool ss,
                     const Names& nm) {
  const std::string& K = nm.K;
  auto& f = set.add("harmonics.csv");
  const std::string a = ss ? "G" : "K";
  io::CsvWriter w(f.stream(), meta,
                  {"source", "segment", "amplitude", "n", a + "_prime_n_" + K, a + "_prime_n_se_" + K,
                   a + "_dprime_n_" + K, a + "_dprime_n_se_" + K, "I_n_over_I1", "Phi_n_rad", "M"});
  for (std::size_t i = 0; i < items.size(); ++i) {
    const auto& A = items[i].A;
    for (int n = 1; n <= A.M; ++n)
      w.row(std::vector<std::string>{
          items[i].source, items[i].segment, std::to_string(i + 1), std::to_string(n),
          format_number_nan_empty(A.fit.Kp[n]), format_number_nan_empty(A.fit.Kp_se[n]),
          format_number_nan_empty(A.fit.Kpp[n]), format_number_nan_empty(A.fit.Kpp_se[n]),
          format_number_nan_empty(A.measures.I_over_I1[n]), format_number_nan_empty(A.measures.Phi[n]),
          std::to_string(A.M)});
  }
}

/// lissajous_NN.csv: every sample of amplitude NN with the fit and its elastic and
/// viscous parts.
void write_lissajous(io::AtomicOutputSet& set, const core::Metadata& meta, const std::vector<Item>& items,
                     const Names& nm) {
  for (std::size_t i = 0; i < items.size(); ++i) {
    const auto& A = items[i].A;
    core::Metadata lm = meta;
    lm.emplace_back("source", items[i].source);
    lm.emplace_back("segment", items[i].segment);
    lm.emplace_back("amplitude", std::to_string(i + 1));
    if (!items[i].N.empty()) lm.emplace_back("N", items[i].N);
    lm.emplace_back("phi0_rad", format_number_nan_empty(A.x0));
    lm.emplace_back("M", std::to_string(A.M));
    lm.emplace_back("decomposition", "elastic = x0 sum_odd K'_n sin(n theta), viscous = x0 sum_odd "
                                     "K''_n cos(n theta) (odd harmonics of the fit; offset and "
                                     "drift in the fit column only)");
    auto& f = set.add(fmt::format("lissajous_{:02d}.csv", i + 1));
    const std::string rr = nm.r.substr(0, nm.r.find('_'));
    const std::string ru = nm.r.substr(nm.r.find('_'));
    io::CsvWriter w(f.stream(), lm,
                    {"cycle", "theta_rad", "t_s", nm.x, nm.xn, nm.xdotn, nm.r, rr + "_fit" + ru,
                     rr + "_elastic" + ru, rr + "_viscous" + ru});
    // θ is written from the start of cycle 1: cycle c spans [2π(c − 1), 2πc].
    const double th0 = A.theta_origin;
    for (std::size_t k = 0; k < A.theta.size(); ++k) {
      const double th = A.theta[k];
      w.row(std::vector<std::string>{
          std::to_string(A.sample_cycle[k]), format_number_nan_empty(th - th0),
          A.timed ? format_number_nan_empty(A.time_s[k]) : "", format_number_nan_empty(A.drive[k]),
          format_number_nan_empty((A.drive[k] - A.x_offset) / A.x0), format_number_nan_empty(std::cos(th)),
          format_number_nan_empty(A.response[k]), format_number_nan_empty(A.fit.evaluate(th)),
          format_number_nan_empty(A.fit.odd_sin_part(th)), format_number_nan_empty(A.fit.odd_cos_part(th))});
    }
  }
}

/// The SPP of one amplitude, or why it has none (a record too coarse for n = 3).
struct SppItem {
  std::optional<laos::SppResult> R;
  std::string refused;
};

std::vector<SppItem> spp_of(const LaosJobOptions& o, const std::vector<Item>& items) {
  std::vector<SppItem> out;
  laos::SppOptions so = o.spp_options;
  so.drift = o.analysis.drift;
  for (std::size_t i = 0; i < items.size(); ++i) {
    SppItem s;
    const std::string context = fmt::format("{}: amplitude {}", items[i].source, i + 1);
    try {
      s.R = laos::analyse_spp(items[i].A, so, context);
    } catch (const InputError& e) {
      s.refused = e.what();
    }
    out.push_back(std::move(s));
  }
  return out;
}

/// The 15 columns of the three cycle measures (value, unchecked, noise spread,
/// truncation change, status each), in the log's units.
std::vector<std::string> spp_measure_columns(bool ss, const Names& nm) {
  const std::string ru = nm.r.substr(nm.r.find('_'));
  std::vector<std::string> cols;
  for (const auto& [name, unit] : {std::pair{std::string(ss ? "cage_modulus" : "cage_stiffness"), "_" + nm.K},
                                   std::pair{std::string(ss ? "static_yield_stress" : "static_yield_torque"), ru},
                                   std::pair{std::string(ss ? "dynamic_yield_stress" : "dynamic_yield_torque"), ru}}) {
    for (const char* what : {"", "_unchecked", "_noise_sd", "_truncation_change"}) cols.push_back(name + what + unit);
    cols.push_back(name + "_status");
  }
  return cols;
}

/// The cells of spp_measure_columns for one measure (none: all empty).
void append_measure(std::vector<std::string>& row, const laos::SppMeasure* m) {
  const laos::SppMeasure none;
  const laos::SppMeasure& v = m != nullptr ? *m : none;
  for (double x : {v.value, v.estimate, v.noise_sd, v.truncation_change}) row.push_back(format_number_nan_empty(x));
  row.push_back(m != nullptr ? laos::spp_status_name(v.status) : "");
}

/// spp_summary.csv: a row per amplitude, the cycle measures with their checks.
void write_spp_summary(io::AtomicOutputSet& set, const core::Metadata& meta, const std::vector<Item>& items,
                       const std::vector<SppItem>& spp, bool ss, const Names& nm) {
  std::vector<std::string> cols = {"source", "segment", "amplitude", "N", nm.x0, "M_spp", "M_check"};
  for (auto& c : spp_measure_columns(ss, nm)) cols.push_back(std::move(c));
  cols.push_back("spp_status");
  auto& f = set.add("spp_summary.csv");
  io::CsvWriter w(f.stream(), meta, cols);
  for (std::size_t i = 0; i < items.size(); ++i) {
    std::vector<std::string> row = {items[i].source, items[i].segment, std::to_string(i + 1), items[i].N,
                                    format_number_nan_empty(items[i].A.x0)};
    const auto& R = spp[i].R;
    row.push_back(R ? std::to_string(R->M) : "");
    row.push_back(R ? std::to_string(R->M_check) : "");
    for (const laos::SppMeasure* m : {R ? &R->cage_modulus : nullptr, R ? &R->static_yield : nullptr,
                                      R ? &R->dynamic_yield : nullptr})
      append_measure(row, m);
    row.push_back(R ? "ok" : "refused: " + spp[i].refused);
    w.row(row);
  }
}

/// spp_cycles.csv: a row per used cycle of the amplitudes with several, each cycle's own
/// measures.
void write_spp_cycles(io::AtomicOutputSet& set, const core::Metadata& meta, const std::vector<Item>& items,
                      const std::vector<SppItem>& spp, bool ss, const Names& nm) {
  std::vector<std::string> cols = {"source", "segment", "amplitude", "cycle", "t_start_s", "M_spp"};
  for (auto& c : spp_measure_columns(ss, nm)) cols.push_back(std::move(c));
  auto& f = set.add("spp_cycles.csv");
  io::CsvWriter w(f.stream(), meta, cols);
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (!spp[i].R) continue;
    for (const laos::SppCycle& c : spp[i].R->cycles) {
      double t0 = core::kUnset;
      for (const auto& cr : items[i].A.cycles)
        if (cr.cycle == c.cycle) t0 = cr.t_start_s;
      std::vector<std::string> row = {items[i].source, items[i].segment, std::to_string(i + 1),
                                      std::to_string(c.cycle), format_number_nan_empty(t0),
                                      std::to_string(spp[i].R->M)};
      for (const laos::SppMeasure* m : {&c.cage_modulus, &c.static_yield, &c.dynamic_yield}) append_measure(row, m);
      w.row(row);
    }
  }
}

/// spp_NN.csv: the transient quantities at every sample of amplitude NN.
void write_spp_samples(io::AtomicOutputSet& set, const core::Metadata& meta, const std::vector<Item>& items,
                       const std::vector<SppItem>& spp, bool ss, const Names& nm) {
  const std::string K = nm.K, r = nm.r.substr(0, nm.r.find('_')), ru = nm.r.substr(nm.r.find('_'));
  const std::string x = nm.x.substr(0, nm.x.find('_'));
  const std::string xu = ss ? "" : "_rad";
  const std::string G = ss ? "Gt" : "Kt";
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (!spp[i].R) continue;
    const auto& A = items[i].A;
    const auto& R = *spp[i].R;
    core::Metadata lm = meta;
    lm.emplace_back("source", items[i].source);
    lm.emplace_back("segment", items[i].segment);
    lm.emplace_back("amplitude", std::to_string(i + 1));
    if (!items[i].N.empty()) lm.emplace_back("N", items[i].N);
    lm.emplace_back(nm.x0, format_number_nan_empty(A.x0));
    lm.emplace_back("M_spp", std::to_string(R.M));
    auto& f = set.add(fmt::format("spp_{:02d}.csv", i + 1));
    io::CsvWriter w(f.stream(), lm,
                    {"cycle", "theta_rad", "t_s", x + xu, x + "dot_over_omega" + xu, r + ru, r + "_spp" + ru,
                     G + "_prime_" + K, G + "_prime_se_" + K, G + "_dprime_" + K, G + "_dprime_se_" + K,
                     "delta_t_rad", "d" + G + "_prime_dt_" + K + "_per_s",
                     "d" + G + "_dprime_dt_" + K + "_per_s", r + "_d" + ru, x + "_eq" + xu});
    const double th0 = A.theta_origin;
    for (std::size_t k = 0; k < R.points.size(); ++k) {
      const laos::SppPoint& p = R.points[k];
      w.row(std::vector<std::string>{
          std::to_string(A.sample_cycle[k]), format_number_nan_empty(p.theta - th0),
          A.timed ? format_number_nan_empty(A.time_s[k]) : "", format_number_nan_empty(p.x),
          format_number_nan_empty(p.rate), format_number_nan_empty(A.response[k]), format_number_nan_empty(p.r),
          format_number_nan_empty(p.Gp), format_number_nan_empty(p.Gp_se), format_number_nan_empty(p.Gpp),
          format_number_nan_empty(p.Gpp_se), format_number_nan_empty(p.delta),
          format_number_nan_empty(p.dGp * R.omega), format_number_nan_empty(p.dGpp * R.omega),
          format_number_nan_empty(p.r_d), format_number_nan_empty(p.x_eq)});
    }
  }
}

}  // namespace

LaosJobSummary run_laos_job(const LaosJobOptions& o, const core::Metadata& header) {
  o.validate();
  const bool convert = !std::isnan(o.stress_constant_Pa_per_N_m) || o.log_constants;
  if (convert && o.read.quantity == io::LogQuantity::kStrainStress)
    throw ConfigError("laos: vane constants convert angle/torque logs; this log is already strain/stress");
  if (o.read.quantity == io::LogQuantity::kStrainStress && o.inertia_kg_m2 > 0)
    throw ConfigError("laos: --inertia-kg-m2 needs an angle/torque log (or vane constants)");
  std::string tag_N;
  std::vector<std::pair<std::string, std::string>> extra_tags;
  for (const auto& kv : o.tags) {
    if (kv.first == "N")
      tag_N = kv.second;
    else
      extra_tags.push_back(kv);
  }
  LaosJobSummary sum;
  const Analysed an = analyse_logs(o, convert, tag_N, sum);
  const bool ss = convert || an.native_ss.value_or(false);
  const Names nm = names(ss);
  sum.stress_strain = ss;
  const core::Metadata meta = laos_metadata(o, header, ss, convert, nm);
  io::AtomicOutputSet set(o.output, o.force);
  write_summary(set, meta, summary_columns(extra_tags, ss, nm), an.items, extra_tags, sum);
  write_cycles(set, meta, an.items, ss, nm);
  write_harmonics(set, meta, an.items, ss, nm);
  write_lissajous(set, meta, an.items, nm);
  if (o.spp) {
    const std::vector<SppItem> spp = spp_of(o, an.items);
    for (const auto& s : spp) {
      sum.spp_refused += s.R ? 0 : 1;
      LaosJobSummary::SppRow row;
      if (s.R) row = {s.R->M, s.R->cage_modulus, s.R->static_yield, s.R->dynamic_yield};
      sum.spp_rows.push_back(row);
    }
    write_spp_summary(set, meta, an.items, spp, ss, nm);
    write_spp_cycles(set, meta, an.items, spp, ss, nm);
    write_spp_samples(set, meta, an.items, spp, ss, nm);
  }
  sum.files = set.final_paths();
  set.commit_all();
  return sum;
}

std::string inspect_laos_logs(const LaosJobOptions& o) {
  if (o.inputs.empty()) throw ConfigError("laos: no input log given");
  io::LogReadOptions ro = o.read;
  ro.inspect = true;
  std::string out;
  for (const auto& path : o.inputs) {
    const io::OscillationLog log = io::read_oscillation_log(path, ro);
    const bool ss = log.quantity == io::LogQuantity::kStrainStress;
    std::size_t closed = 0;
    for (const auto& s : log.segments) closed += s.closed_cycle ? 1 : 0;
    out += fmt::format("{}: format {}, {} ({})\n", log.source, io::log_format_name(log.format),
                       ss ? "strain and stress" : "angle and torque",
                       ss ? "moduli G in Pa" : "K in N m/rad");
    out += fmt::format("  {} analysable segment{}{}\n", log.segments.size(),
                       log.segments.size() == 1 ? "" : "s",
                       closed > 0 ? fmt::format(" ({} one stored period each)", closed) : "");
    for (const auto& s : log.segments) {
      std::string what = s.closed_cycle ? "closed cycle" : (s.time_s.empty() ? "no time" : "timed");
      std::string ins;
      auto add = [&](const char* name, double v, const char* unit) {
        if (!std::isnan(v)) ins += fmt::format("{}{} {:.4g} {}", ins.empty() ? "; instrument: " : ", ", name, v, unit);
      };
      add("f", s.instrument_frequency_Hz, "Hz");
      add("G'", s.instrument_G_prime_Pa, "Pa");
      add("G''", s.instrument_G_dprime_Pa, "Pa");
      add("torque", s.instrument_torque_N_m, "N m");
      out += fmt::format("    {}: lines {}-{}, {} samples, {}{}\n", s.label,
                         s.line.empty() ? 0 : s.line.front(), s.line.empty() ? 0 : s.line.back(),
                         s.drive.size(), what, ins);
    }
    if (!log.skipped.empty()) {
      out += fmt::format("  {} skipped block{} (no raw waveform to analyse)\n", log.skipped.size(),
                         log.skipped.size() == 1 ? "" : "s");
      for (const auto& s : log.skipped) out += "    " + s + "\n";
    }
    out += log.segments.empty()
               ? "  nothing to analyse: shearzone laos needs the raw drive and response samples\n"
               : fmt::format("  analyse with: shearzone laos {} -o OUT\n", log.source);
  }
  return out;
}

}  // namespace shearzone::pipeline
