// python/src/module.cpp: `shearzone._native`, the C++ side of the Python module.
//
// Two ways in, both through the command's own option parsing (apps/shearzone), so a
// keyword means what the flag of the same name means and is checked the same way:
//  - run(words): a subcommand run in this process exactly as `shearzone WORDS` runs
//    it (files in, files out), quiet;
//  - piv_frames, fit_arrays, laos_arrays: the subcommand's options converted as the
//    command converts them (Context::capture), then the library on arrays.
// Errors become the exception classes of shearzone/_errors.py carrying the command's
// one-line message. Long work runs without the GIL; every progress update takes it
// back to call the user's callback and to check for Ctrl-C (KeyboardInterrupt), which
// stops the work through the library's normal unwinding (no output left behind).
#include <any>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "common/run_app.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"
#include "shearzone/core/version.hpp"
#include "shearzone/fit/models.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/field_file.hpp"
#include "shearzone/io/frames.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/io/oscillation_log.hpp"
#include "shearzone/laos/analysis.hpp"
#include "shearzone/pipeline/fit_job.hpp"
#include "shearzone/pipeline/laos_job.hpp"
#include "shearzone/pipeline/piv_job.hpp"
#include "shearzone/piv/texture.hpp"
#include "bindings.hpp"
#include "subcommands.hpp"

namespace py = pybind11;
using namespace shearzone;

namespace {

/// Thrown through the library when Python must take over: Ctrl-C (the
/// KeyboardInterrupt is pending) or an exception from the user's callback (restored
/// as the pending error). The binding re-raises the pending error once it holds the GIL.
struct PythonPending {};

/// Sets this thread's progress observer for a call: the user's callback (label, done,
/// total) and the Ctrl-C check, each with the GIL taken back. Construct and destroy
/// with the GIL held.
class Observer {
 public:
  explicit Observer(py::object callback) : callback_(std::move(callback)) {
    previous_ = core::set_progress_observer([this](const std::string& label, std::size_t done, std::size_t total) {
      py::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) throw PythonPending{};
      if (callback_.is_none()) return;
      try {
        callback_(label, done, total);
      } catch (py::error_already_set& e) {
        e.restore();
        throw PythonPending{};
      }
    });
  }
  ~Observer() { core::set_progress_observer(std::move(previous_)); }
  Observer(const Observer&) = delete;
  Observer& operator=(const Observer&) = delete;

 private:
  py::object callback_;
  core::ProgressObserver previous_;
};

/// Runs `work` without the GIL, with the observer set; re-raises what Python left pending.
template <class F>
void without_gil(const py::object& progress, F&& work) {
  Observer observer(progress);
  try {
    py::gil_scoped_release release;
    work();
  } catch (const PythonPending&) {
    throw py::error_already_set();
  }
}

/// The header every output carries: the command line that gives the same numbers.
core::Metadata python_header(const std::vector<std::string>& words) {
  std::vector<const char*> argv{"shearzone"};  // the command that gives the same output
  for (const auto& w : words) argv.push_back(w.c_str());
  return core::standard_metadata(core::command_line_from_argv(static_cast<int>(argv.size()), argv.data()));
}

/// The typed options a subcommand makes of `words` (Context::capture), nothing run.
template <class Options>
Options capture(const std::vector<std::string>& words) {
  apps::Context ctx;
  std::optional<Options> out;
  ctx.capture = [&out](std::any a) { out = std::any_cast<Options>(std::move(a)); };
  apps::run_in_process(words, ctx);
  if (!out) throw ConfigError("these options do not apply to arrays");
  return *out;
}

int run(const std::vector<std::string>& words, const py::object& progress) {
  apps::Context ctx;
  std::vector<const char*> argv{"shearzone"};  // the command that gives the same output
  for (const auto& w : words) argv.push_back(w.c_str());
  ctx.command_line = core::command_line_from_argv(static_cast<int>(argv.size()), argv.data());
  std::vector<std::string> quiet{"-q"};
  quiet.insert(quiet.end(), words.begin(), words.end());
  int code = 0;
  without_gil(progress, [&] { code = apps::run_in_process(quiet, ctx); });
  return code;
}

/// A 2-D array as a Mat over the same memory (no copy): C-contiguous uint8, uint16 or
/// float32; anything else is refused with what was expected.
cv::Mat as_mat(const py::array& a, const std::string& name) {
  if (a.ndim() != 2)
    throw InputError(fmt::format("{}: a {}-D array; expected a 2-D grey image (rows, columns)", name, a.ndim()));
  if (!(a.flags() & py::array::c_style))
    throw InputError(fmt::format("{}: not C-contiguous; expected numpy.ascontiguousarray(frame)", name));
  int type = -1;
  if (a.dtype().is(py::dtype::of<std::uint8_t>())) type = CV_8UC1;
  else if (a.dtype().is(py::dtype::of<std::uint16_t>())) type = CV_16UC1;
  else if (a.dtype().is(py::dtype::of<float>())) type = CV_32FC1;
  else
    throw InputError(fmt::format("{}: dtype {}; expected uint8, uint16 or float32 (grey levels 0..1)", name,
                                 py::str(a.dtype()).cast<std::string>()));
  return cv::Mat(static_cast<int>(a.shape(0)), static_cast<int>(a.shape(1)), type, const_cast<void*>(a.data()));
}

template <class T>
py::array_t<T> to_array(const std::vector<T>& v, std::size_t ny, std::size_t nx) {
  py::array_t<T> out({ny, nx});
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(T));
  return out;
}

py::list metadata_list(const core::Metadata& m) {
  py::list out;
  for (const auto& [k, v] : m) out.append(py::make_tuple(k, v));
  return out;
}

/// One pair's field as arrays (rows, columns) plus its frames and times.
py::dict field_dict(const core::VectorField& f) {
  const std::size_t ny = f.ny(), nx = f.nx();
  py::array_t<double> x({ny, nx}), y({ny, nx});
  auto xm = x.mutable_unchecked<2>();
  auto ym = y.mutable_unchecked<2>();
  for (std::size_t i = 0; i < ny; ++i)
    for (std::size_t j = 0; j < nx; ++j) {
      xm(i, j) = f.x_px[j];
      ym(i, j) = f.y_px[i];
    }
  std::vector<std::uint8_t> flag(f.flag.size());
  for (std::size_t k = 0; k < flag.size(); ++k) flag[k] = static_cast<std::uint8_t>(f.flag[k]);
  py::dict d;
  d["x_px"] = x;
  d["y_px"] = y;
  d["u_px"] = to_array(f.u_px, ny, nx);
  d["v_px"] = to_array(f.v_px, ny, nx);
  d["flag"] = to_array(flag, ny, nx);
  d["peak"] = to_array(f.peak, ny, nx);
  d["peak_ratio"] = to_array(f.peak_ratio, ny, nx);
  return d;
}

py::dict piv_frames(const std::vector<py::array>& frames, const std::vector<std::string>& words,
                    const py::object& progress) {
  std::vector<std::string> all{"piv", "<arrays>", "-o", "<arrays>.h5"};
  all.insert(all.end(), words.begin(), words.end());
  pipeline::PivJobOptions job = capture<pipeline::PivJobOptions>(all);
  std::vector<cv::Mat> mats;
  for (std::size_t k = 0; k < frames.size(); ++k) mats.push_back(as_mat(frames[k], fmt::format("frame {}", k)));
  job.inputs.clear();
  job.output.clear();
  const double fps = job.fps;
  io::frames_from_memory(mats, fps, "arrays");  // checks the frames before any work
  job.frames = [mats, fps] { return io::frames_from_memory(mats, fps, "arrays"); };
  struct Pair {
    core::VectorField field;
    std::int64_t a = 0, b = 0;
    double t_a = 0, dt = 0;
  };
  std::vector<Pair> pairs;
  core::Metadata header;
  job.on_pair = [&](const core::VectorField& f, const io::Frame& a, const io::Frame& b, const core::Metadata& m) {
    pairs.push_back({f, a.index, b.index, a.t_s, b.t_s - a.t_s});
    if (header.empty()) header = m;
  };
  pipeline::PivJobSummary sum;
  const core::Metadata call = python_header(all);
  without_gil(progress, [&] { sum = pipeline::run_piv_job(job, call, {}); });
  py::list out;
  for (const auto& p : pairs) {
    py::dict d = field_dict(p.field);
    d["frame_a"] = p.a;
    d["frame_b"] = p.b;
    d["t_a_s"] = p.t_a;
    d["dt_s"] = p.dt;
    out.append(d);
  }
  py::dict result;
  result["pairs"] = out;
  result["header"] = metadata_list(header);
  result["windows_px"] = sum.windows_px;
  result["texture_size_px"] = sum.texture_half_width_px * piv::kBeadDiameterPerHalfWidth;
  result["track_bead_diameter_px"] = sum.track_bead_diameter_px;
  return result;
}

py::dict fit_dict(const fit::CurveFit& f) {
  const fit::FitResult& r = f.result;
  py::dict d;
  d["status"] = std::string(fit::status_name(f.status));
  d["message"] = f.message;
  d["has_result"] = f.has_result;
  d["names"] = r.names;
  d["values"] = r.values;
  d["std_errors"] = r.std_errors;
  d["ci_low"] = r.ci_low;
  d["ci_high"] = r.ci_high;
  d["boot_low"] = r.boot_low;
  d["boot_high"] = r.boot_high;
  d["start"] = r.start;
  const std::size_t p = r.names.size();
  d["covariance"] = p && r.covariance.size() == p * p ? py::object(to_array(r.covariance, p, p)) : py::none();
  d["correlation"] = p && r.correlation.size() == p * p ? py::object(to_array(r.correlation, p, p)) : py::none();
  d["n"] = r.n;
  d["dof"] = r.dof;
  d["chi2"] = r.chi2;
  d["reduced_chi2"] = r.reduced_chi2;
  d["aic"] = r.aic;
  d["aicc"] = r.aicc;
  d["bic"] = r.bic;
  d["cond"] = r.cond;
  d["iterations"] = r.iterations;
  d["termination"] = r.termination;
  d["confidence"] = r.confidence;
  d["fitted"] = r.fitted;
  d["residuals"] = r.residuals;
  return d;
}

/// Refuses a value that is not a finite number (as the command refuses such a cell),
/// naming the array and the index; `positive`: also <= 0 (an uncertainty).
void check_values(const char* name, const std::vector<double>& v, bool positive = false) {
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i]))
      throw InputError(fmt::format("{}[{}] = {}: not a finite number", name, i, v[i]));
    if (positive && !(v[i] > 0))
      throw InputError(fmt::format("{}[{}] = {}: not a positive uncertainty", name, i, v[i]));
  }
}

py::dict fit_arrays(const std::string& model, std::vector<double> x, std::vector<double> y,
                    std::vector<double> sigma, const std::vector<std::string>& words) {
  std::vector<std::string> all{"fit", model, "<arrays>.csv", "-o", "<arrays>.csv", "--x", "x", "--y", "y"};
  all.insert(all.end(), words.begin(), words.end());
  const auto job = capture<pipeline::FitJobOptions>(all);
  job.fit.validate();
  if (x.size() != y.size() || (!sigma.empty() && sigma.size() != x.size()))
    throw InputError(sigma.empty() ? fmt::format("x and y: {} and {} values; expected as many of each", x.size(), y.size())
                                   : fmt::format("x, y and sigma: {}, {} and {} values; expected as many of each",
                                                 x.size(), y.size(), sigma.size()));
  check_values("x", x);
  check_values("y", y);
  check_values("sigma", sigma, true);
  py::dict d;
  fit::CurveFit f;
  {
    py::gil_scoped_release release;
    if (job.model == pipeline::FitModel::kErf) {
      f = fit::fit_erf(x, y, sigma, job.fit);
    } else if (!std::isnan(job.subtract_at)) {
      // As the fit job does: y − y(x0), the points at x0 removed.
      double y0 = 0;
      if (!fit::subtract_at(x, y, sigma, job.subtract_at, job.subtract_rtol, &y0)) {
        f.status = fit::FitStatus::kTooFewPoints;
        f.message = fmt::format("no point at x = {} to subtract", job.subtract_at);
      } else {
        f = fit::fit_power(x, y, sigma, job.space, job.fit);
      }
      py::gil_scoped_acquire gil;
      d["y0"] = y0;
    } else {
      f = fit::fit_power(x, y, sigma, job.space, job.fit);
    }
  }
  for (auto item : fit_dict(f)) d[item.first] = item.second;
  return d;
}

py::dict amplitude_dict(const laos::AmplitudeResult& a) {
  py::dict d;
  d["status"] = std::string(laos::amplitude_status_name(a.status));
  d["first_sample"] = a.first_sample;
  d["last_sample"] = a.last_sample;
  d["phase_method"] = a.phase_method;
  d["omega_rad_per_s"] = a.omega;
  d["x0"] = a.x0;
  d["x_offset"] = a.x_offset;
  d["M"] = a.M;
  d["partial_cycles"] = a.partial_cycles;
  d["first_steady_cycle"] = a.first_steady_cycle;
  const laos::Measures& m = a.measures;
  d["K1p"] = m.K1p;
  d["K1pp"] = m.K1pp;
  d["K1p_se"] = m.K1p_se;
  d["K1pp_se"] = m.K1pp_se;
  d["tan_delta"] = m.tan_delta;
  d["I_over_I1"] = m.I_over_I1;
  d["Phi"] = m.Phi;
  d["e"] = m.e;
  d["v"] = m.v;
  d["K_M"] = m.K_M;
  d["K_L"] = m.K_L;
  d["eta_M"] = m.eta_M;
  d["eta_L"] = m.eta_L;
  d["S"] = m.S;
  d["T"] = m.T;
  d["e3_over_e1"] = m.e3_over_e1;
  d["v3_over_v1"] = m.v3_over_v1;
  d["I3_over_I1"] = m.I3_over_I1;
  d["I2_over_I1"] = m.I2_over_I1;
  d["Kp"] = a.fit.Kp;
  d["Kpp"] = a.fit.Kpp;
  d["Kp_se"] = a.fit.Kp_se;
  d["Kpp_se"] = a.fit.Kpp_se;
  d["r_max"] = a.r_max;
  d["r_max_raw"] = a.r_max_raw;
  d["E_d"] = a.E_d;
  d["E_d_ratio"] = a.E_d_ratio;
  d["phi_d"] = a.phi_d;
  py::list cycles;
  for (const auto& c : a.cycles) {
    py::dict cd;
    cd["cycle"] = c.cycle;
    cd["t_start_s"] = c.t_start_s;
    cd["x0"] = c.x0;
    cd["r_max"] = c.r_max;
    cd["K1p"] = c.K1p;
    cd["K1pp"] = c.K1pp;
    cd["E_d"] = c.E_d;
    cd["steady"] = c.steady;
    cd["used"] = c.used;
    cycles.append(cd);
  }
  d["cycles"] = cycles;
  py::dict lj;
  lj["cycle"] = a.sample_cycle;
  lj["theta_rad"] = a.theta;
  lj["time_s"] = a.time_s;
  lj["drive"] = a.drive;
  lj["response"] = a.response;
  d["lissajous"] = lj;
  return d;
}

py::dict spp_measure_dict(const laos::SppMeasure& m) {
  py::dict d;
  d["value"] = m.value;
  d["unchecked"] = m.estimate;
  d["noise_sd"] = m.noise_sd;
  d["truncation_change"] = m.truncation_change;
  d["status"] = laos::spp_status_name(m.status);
  return d;
}

/// What `laos --spp` writes for one amplitude (spp_summary.csv, spp_cycles.csv, spp_NN.csv).
py::dict spp_dict(const laos::SppResult& r) {
  py::dict d;
  d["M"] = r.M;
  d["M_check"] = r.M_check;
  d["cage_modulus"] = spp_measure_dict(r.cage_modulus);
  d["static_yield"] = spp_measure_dict(r.static_yield);
  d["dynamic_yield"] = spp_measure_dict(r.dynamic_yield);
  py::list cycles;
  for (const auto& c : r.cycles) {
    py::dict cd;
    cd["cycle"] = c.cycle;
    cd["cage_modulus"] = spp_measure_dict(c.cage_modulus);
    cd["static_yield"] = spp_measure_dict(c.static_yield);
    cd["dynamic_yield"] = spp_measure_dict(c.dynamic_yield);
    cycles.append(cd);
  }
  d["cycles"] = cycles;
  const auto column = [&](double laos::SppPoint::*f) {
    std::vector<double> v;
    v.reserve(r.points.size());
    for (const auto& p : r.points) v.push_back(p.*f);
    return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
  };
  using P = laos::SppPoint;
  const std::pair<const char*, double P::*> columns[] = {
      {"theta", &P::theta}, {"x", &P::x},           {"rate", &P::rate},         {"r", &P::r},
      {"Gp", &P::Gp},       {"Gp_se", &P::Gp_se},   {"Gpp", &P::Gpp},           {"Gpp_se", &P::Gpp_se},
      {"delta", &P::delta}, {"dGp_dtheta", &P::dGp}, {"dGpp_dtheta", &P::dGpp}, {"r_d", &P::r_d},
      {"x_eq", &P::x_eq}};
  py::dict pts;
  for (const auto& [name, member] : columns) pts[name] = column(member);
  d["points"] = pts;
  return d;
}

py::dict laos_arrays(std::vector<double> t, std::vector<double> drive, std::vector<double> response,
                     const std::vector<std::string>& words) {
  std::vector<std::string> all{"laos", "<arrays>"};
  all.insert(all.end(), words.begin(), words.end());
  const auto job = capture<pipeline::LaosJobOptions>(all);
  job.analysis.validate();
  if (drive.size() != response.size() || (!t.empty() && t.size() != drive.size()))
    throw InputError(t.empty() ? fmt::format("angle and torque: {} and {} values; expected as many of each",
                                             drive.size(), response.size())
                               : fmt::format("t, angle and torque: {}, {} and {} values; expected as many of each",
                                             t.size(), drive.size(), response.size()));
  check_values("t", t);
  check_values("angle", drive);
  check_values("torque", response);
  const bool convert = !std::isnan(job.stress_constant_Pa_per_N_m);
  if (job.log_constants) throw ConfigError("log_constants: arrays carry no log; give stress_constant and strain_constant");
  const double Cs = convert ? job.stress_constant_Pa_per_N_m : 1.0, Cg = convert ? job.strain_constant_per_rad : 1.0;
  if (!(Cs > 0 && Cg > 0 && std::isfinite(Cs) && std::isfinite(Cg)))
    throw ConfigError(fmt::format("vane constants {} Pa/(N m), {} 1/rad; expected both > 0", Cs, Cg));
  if (!(std::isfinite(job.inertia_kg_m2) && job.inertia_kg_m2 >= 0))
    throw ConfigError(fmt::format("inertia_kg_m2 {}; expected >= 0", job.inertia_kg_m2));
  laos::AnalysisOptions ao = job.analysis;
  ao.omega_rad_per_s = !std::isnan(job.f_Hz) ? 2 * std::numbers::pi * job.f_Hz : core::kUnset;
  ao.inertia = job.inertia_kg_m2 * Cs / Cg;
  core::Waveform w{std::move(t), std::move(drive), std::move(response), {}};
  for (auto& v : w.drive) v *= Cg;
  for (auto& v : w.response) v *= Cs;
  laos::RecordResult rec;
  {
    py::gil_scoped_release release;
    rec = laos::analyse_record(w, ao, "arrays");
  }
  py::list amps;
  laos::SppOptions so = job.spp_options;
  so.drift = job.analysis.drift;
  for (std::size_t i = 0; i < rec.amplitudes.size(); ++i) {
    const auto& a = rec.amplitudes[i];
    py::dict ad = amplitude_dict(a);
    if (job.spp) ad["spp"] = spp_dict(laos::analyse_spp(a, so, fmt::format("arrays: amplitude {}", i + 1)));
    amps.append(ad);
  }
  py::dict d;
  d["amplitudes"] = amps;
  d["skipped_blocks"] = rec.skipped_blocks;
  d["stress_strain"] = convert;
  return d;
}

/// A vendor log read as data: what `laos --inspect` shows.
py::dict read_log(const std::string& path, const std::vector<std::string>& words) {
  std::vector<std::string> all{"laos", path};
  all.insert(all.end(), words.begin(), words.end());
  auto job = capture<pipeline::LaosJobOptions>(all);
  job.read.inspect = true;  // a file without a waveform comes back with its skipped blocks
  io::OscillationLog log;
  {
    py::gil_scoped_release release;
    log = io::read_oscillation_log(path, job.read);
  }
  py::dict d;
  d["source"] = log.source;
  d["format"] = std::string(io::log_format_name(log.format));
  d["quantity"] = log.quantity == io::LogQuantity::kStrainStress ? "strain_stress" : "angle_torque";
  d["omega_rad_per_s"] = log.omega_rad_per_s;
  d["parameters"] = metadata_list(log.parameters);
  py::list segs;
  for (const auto& s : log.segments) {
    py::dict sd;
    sd["label"] = s.label;
    sd["time_s"] = py::array_t<double>(static_cast<py::ssize_t>(s.time_s.size()), s.time_s.data());
    sd["drive"] = py::array_t<double>(static_cast<py::ssize_t>(s.drive.size()), s.drive.data());
    sd["response"] = py::array_t<double>(static_cast<py::ssize_t>(s.response.size()), s.response.data());
    sd["line"] = s.line;
    sd["closed_cycle"] = s.closed_cycle;
    sd["instrument_frequency_Hz"] = s.instrument_frequency_Hz;
    sd["instrument_G_prime_Pa"] = s.instrument_G_prime_Pa;
    sd["instrument_G_dprime_Pa"] = s.instrument_G_dprime_Pa;
    sd["instrument_torque_N_m"] = s.instrument_torque_N_m;
    segs.append(sd);
  }
  d["segments"] = segs;
  py::list skipped;
  for (const auto& b : log.skipped) skipped.append(b);
  d["skipped"] = skipped;
  return d;
}

/// fields.h5 (or a one-pair CSV) read pair by pair through io's reader.
class Fields {
 public:
  Fields(const std::string& path, double csv_dt_s) : reader_(io::open_field_file(path, csv_dt_s)) {}
  std::size_t size() const { return reader_->size(); }
  py::dict pair(std::size_t k) {
    if (k >= reader_->size())
      throw py::index_error(fmt::format("pair {}: the file holds {} pairs", k, reader_->size()));
    core::VectorField f;
    double t_a = 0, dt = 0;
    reader_->read(k, f, t_a, dt);
    py::dict d = field_dict(f);
    d["t_a_s"] = t_a;
    d["dt_s"] = dt;
    return d;
  }
  py::object attribute(const std::string& name) const {
    const std::string text = reader_->text_attribute(name);
    if (text.empty()) return py::none();
    const double v = reader_->attribute(name);
    if (!std::isnan(v)) return py::float_(v);
    return py::str(text);
  }

 private:
  std::unique_ptr<io::FieldReader> reader_;
};

/// An image file as a numpy array (grey, as the command reads it).
py::array read_image(const std::string& path, const std::string& grey) {
  cv::Mat m = io::read_image_gray(path, nullptr, io::grey_mode_from_name(grey));
  if (m.depth() == CV_16U) {
    py::array_t<std::uint16_t> out({m.rows, m.cols});
    for (int r = 0; r < m.rows; ++r) std::memcpy(out.mutable_data(r, 0), m.ptr(r), m.cols * sizeof(std::uint16_t));
    return out;
  }
  py::array_t<std::uint8_t> out({m.rows, m.cols});
  for (int r = 0; r < m.rows; ++r) std::memcpy(out.mutable_data(r, 0), m.ptr(r), m.cols);
  return out;
}

/// The exception classes of shearzone/_errors.py, raised with the command's message.
void raise_as(const char* name, const char* message) {
  py::object cls = py::module_::import("shearzone._errors").attr(name);
  PyErr_SetString(cls.ptr(), message);
}

}  // namespace

PYBIND11_MODULE(_native, m) {
  m.doc() = "shearzone's library, for the Python module (shearzone/__init__.py wraps it)";
  io::configure_decoders();
  io::leave_signals_to_the_host();  // Ctrl-C: Python's KeyboardInterrupt, the work unwound (no output left)
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      const std::string what = e.what();
      const bool missing = what.size() > 14 && what.compare(what.size() - 14, 14, ": no such file") == 0;
      raise_as(missing ? "MissingFileError" : "InputError", e.what());
    } catch (const ConfigError& e) {
      raise_as("ConfigError", e.what());
    } catch (const NoResultError& e) {
      raise_as("NoResultError", e.what());
    } catch (const InternalError& e) {
      raise_as("InternalError", e.what());
    }
  });
  m.attr("version") = std::string(kVersion);
  m.def("run", &run, py::arg("words"), py::arg("progress") = py::none());
  m.def("piv_frames", &piv_frames, py::arg("frames"), py::arg("words"), py::arg("progress") = py::none());
  m.def("fit_arrays", &fit_arrays, py::arg("model"), py::arg("x"), py::arg("y"), py::arg("sigma"), py::arg("words"));
  m.def("laos_arrays", &laos_arrays, py::arg("t"), py::arg("drive"), py::arg("response"), py::arg("words"));
  m.def("read_log", &read_log, py::arg("path"), py::arg("words"));
  m.def("read_image", &read_image, py::arg("path"), py::arg("grey") = "luma");
  py::class_<Fields>(m, "Fields")
      .def(py::init<const std::string&, double>(), py::arg("path"), py::arg("csv_dt_s"))
      .def("__len__", &Fields::size)
      .def("pair", &Fields::pair, py::arg("k"))
      .def("attribute", &Fields::attribute, py::arg("name"));
  bind_sim(m);
}
