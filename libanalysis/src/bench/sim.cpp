#include "shearzone/bench/sim.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/laos/harmonics.hpp"
#include "shearzone/sim/builder.hpp"
#include "shearzone/sim/scenario.hpp"
#include "shearzone/sim/scene.hpp"
#include "shearzone/sim/world.hpp"

namespace shearzone::bench {
namespace {

constexpr double kDiameter = 2e-3;   // m
constexpr double kDensity = 2500.0;  // kg/m³
constexpr double kFriction = 0.3;    // beads and walls
constexpr double kPitch = 1.2;       // lattice pitch, × d
constexpr double kJitter = 0.1;      // horizontal jitter amplitude, × d
constexpr double kSettleStep = 5e-4;
constexpr double kSettleTolerance = 1e-2;
constexpr int kSettleIterations = 30;
constexpr double kSettleEnergy = 1e-3;  // ½ m v² per bead / (m g d)
constexpr double kRelaxEnergy = 1e-5;   // end of the relaxation, same unit

std::string fixed(double v, int digits) { return fmt::format("{:.{}f}", v, digits); }
std::string sci(double v) { return fmt::format("{:.4e}", v); }

std::string cpu_model() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("model name", 0) == 0) {
      const auto p = line.find(':');
      if (p != std::string::npos) {
        std::string s = line.substr(p + 1);
        s.erase(0, s.find_first_not_of(' '));
        return s;
      }
    }
  return "unknown CPU";
}

/// One engine solver of BenchSimOptions::solvers.
struct SolverChoice {
  std::string name;  // alternate, forward, anderson
  int depth = 0;     // Anderson depth (anderson only)
  void set(sim::Options& o) const {
    o.alternate_sweeps = name == "alternate";
    o.anderson_depth = name == "anderson" ? depth : 0;
  }
  [[nodiscard]] std::string label() const { return name == "anderson" ? fmt::format("anderson{}", depth) : name; }
  [[nodiscard]] std::string words() const {
    return name == "alternate" ? "alternating sweeps"
           : name == "forward" ? "forward sweeps"
                               : fmt::format("forward sweeps + Anderson({})", depth);
  }
};
std::vector<SolverChoice> solver_choices(const BenchSimOptions& o) {
  std::vector<SolverChoice> r;
  for (const std::string& n : o.solvers) r.push_back({n, n == "anderson" ? o.anderson_depth : 0});
  return r;
}

/// A world on the settled state with the given h, tolerance, cap, threads and solver
/// (sim::at_time_step carries the impulses over to h).
sim::World restart(const sim::WorldState& settled, double h, double tolerance, int cap, int threads,
                   int freeze_sweeps, const SolverChoice& solver) {
  sim::WorldState s = sim::at_time_step(settled, h);
  s.options.tolerance = tolerance;
  s.options.max_iterations = cap;
  s.options.threads = threads;
  s.options.freeze_sweeps = freeze_sweeps;
  solver.set(s.options);
  s.step = 0;
  s.iteration_cap_hits = 0;
  return sim::World::from_state(s);
}

struct Run {
  int steps = 0;
  double seconds = 0.0;
  std::int64_t row_updates = 0, active_row_updates = 0, frozen_skips = 0, cap_hits = 0, iterations = 0;
  double residual_sum = 0.0, max_overlap = 0.0, kinetic_energy = 0.0;
};

Run timed(sim::World& w, int steps) {
  Run r;
  r.steps = steps;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) {
    const sim::StepDiagnostics d = w.step();
    r.row_updates += d.row_updates;
    r.active_row_updates += d.active_row_updates;
    r.frozen_skips += d.frozen_skips;
    r.cap_hits += d.hit_iteration_cap ? 1 : 0;
    r.iterations += d.iterations;
    r.residual_sum += d.residual;
    r.max_overlap = std::max(r.max_overlap, d.max_overlap);
    r.kinetic_energy = d.kinetic_energy;
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

/// `steps` timed steps from `state` with the thread count and sweep order given: sweeps
/// per step (mean, median, max), cap hits, the largest overlap, wall seconds.
struct SweepStats {
  double wall = 0.0, mean = 0.0, median = 0.0, overlap = 0.0;
  int max = 0;
  std::int64_t caps = 0;
};
SweepStats time_sheared(const sim::WorldState& state, int threads, const SolverChoice& solver, int steps) {
  sim::WorldState st = state;
  st.options.threads = threads;
  solver.set(st.options);
  sim::World w = sim::World::from_state(st);
  std::vector<int> sweeps;
  SweepStats r;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) {
    const sim::StepDiagnostics d = w.step();
    sweeps.push_back(d.iterations);
    r.caps += d.hit_iteration_cap ? 1 : 0;
    r.overlap = std::max(r.overlap, d.max_overlap);
  }
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::sort(sweeps.begin(), sweeps.end());
  for (const int x : sweeps) r.mean += x;
  r.mean /= static_cast<double>(sweeps.size());
  const std::size_t n = sweeps.size();
  r.median = n % 2 ? sweeps[n / 2] : 0.5 * (sweeps[n / 2 - 1] + sweeps[n / 2]);
  r.max = sweeps.back();
  return r;
}

/// Chains of N beads the built-in cup holds in a wedge of 1/sectors (sectors = 1: whole).
int cup_chains(const BenchSimOptions& o, int N, int sectors) { return std::max(1, o.cup_beads / N / sectors); }

/// The paper's cup as a scene (BenchSimOptions, "cup"), chains of N beads (a sector with
/// chains beyond the validated 9 beads sets sector_chains: the bench measures them).
/// A bench scene's [sim] and [output]: no duration (the bench steps the world itself),
/// the bench's solver options, the paper's steel (mu = 0.2), no snapshots.
sim::SceneSpec bench_scene(const BenchSimOptions& o, std::string source) {
  sim::SceneSpec s;
  s.source = std::move(source);
  s.sim.duration_s = 0.0;
  s.sim.time_step_s = o.time_step_s;
  s.sim.friction = 0.2;
  s.sim.tolerance = o.tolerance;
  s.sim.max_iterations = o.max_iterations;
  s.sim.freeze_sweeps = o.freeze_sweeps;
  s.output.snapshot_every = 0;
  s.beads.density_kg_per_m3 = 7800.0;
  return s;
}

sim::SceneSpec cup_scene(const BenchSimOptions& o, int N, int sectors, std::uint64_t seed) {
  const double d = 2.4e-3, R = 14.5 * d, Rv = 4.5 * d;
  const double fill_height =
      o.cup_beads * std::numbers::pi / 6.0 * d * d * d / (0.6 * std::numbers::pi * (R * R - Rv * Rv));
  const double height = fill_height + 3.0 * d;
  sim::SceneSpec s = bench_scene(o, fmt::format("bench sim --scene cup (N = {})", N));
  s.cylinder.radius_m = R;
  s.cylinder.height_m = height;
  s.cylinder.bead_diameter_m = d;
  if (sectors > 1) s.cylinder.sectors = sectors;
  if (sectors > 1 && N > 9) s.cylinder.sector_chains = true;
  s.beads.diameter_m = d;
  s.chains.beads_per_chain = N;
  s.chains.l_max_m = 0.0004;
  s.chains.max_angle_deg = 40.0;
  s.vane.radius_m = Rv;
  s.vane.height_m = height;
  s.fill.count = cup_chains(o, N, sectors);
  s.fill.seed = static_cast<std::int64_t>(seed);
  s.fill.settle = true;
  return s;
}

/// A vane cup's world, filled (InputError without a [vane]); `file` not empty: the
/// spec written beside the outputs under that name (the built-in cup).
sim::LoadedScene cup_world(io::AtomicOutputSet& out, const std::string& file, const sim::SceneSpec& spec,
                           const std::string& name) {
  if (!file.empty())
    sim::write_scene(spec, out.add(file).stream(),
                     fmt::format("# shearzone bench sim --scene cup: the paper's vane cup, chains of N = {} beads\n",
                                 spec.chains.beads_per_chain.value_or(1)));
  sim::LoadedScene sc = sim::build_scene(spec, false);
  if (!sc.vane || sc.world->rotor_count() == 0)
    throw InputError(fmt::format("bench sim --scene {}: no [vane]: the benchmark shears a vane cup", name));
  return sc;
}
int mobile_count(const sim::World& w) {
  int n = 0;
  for (int b = 0; b < w.body_count(); ++b) n += w.kind(b) == sim::BodyKind::kMobile ? 1 : 0;
  return n;
}

/// Observables of one drive cycle of the sheared cup (run_cup_accuracy).
struct CycleObservables {
  double amplitude = 0.0, K1p = 0.0, K1pp = 0.0, r_c = std::numeric_limits<double>::quiet_NaN();
  /// The whole cup: the mean of r_c measured in each quarter about a blade alone (as many
  /// surface beads as a periodic quarter holds; NaN unless every quarter's mean falls
  /// below v_c: a mean of the inner ones only would read short); a quarter: r_c. The
  /// bed's height at the start of the measured cycles: the surface's top (the 99.5th
  /// percentile of the centres) above the lowest centre, plus one bead, in diameters.
  double r_c_quarters = std::numeric_limits<double>::quiet_NaN(), bed_height_over_d = 0.0;
  double mean_sweeps = 0.0, overlap = 0.0, rope_excess = 0.0, wall = 0.0;
  std::int64_t caps = 0;
};

/// Where the mean of the radial bins (vsum / vcount, bins of `bin` from rv) first falls
/// below v_c, outward; linear between bins, NaN when it never does.
double first_below(const std::vector<double>& vsum, const std::vector<double>& vcount, double rv, double bin,
                   double v_c) {
  double prev_r = 0.0, prev_v = 0.0;
  bool have_prev = false;
  for (std::size_t i = 0; i < vsum.size(); ++i) {
    if (vcount[i] == 0.0) continue;
    const double r = rv + (static_cast<double>(i) + 0.5) * bin, v = vsum[i] / vcount[i];
    if (v < v_c) return have_prev ? prev_r + (r - prev_r) * (prev_v - v_c) / (prev_v - v) : r;
    prev_r = r;
    prev_v = v;
    have_prev = true;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// `cycles` whole drive cycles of the vane from `state` (φ = φ0 sin 2πf t from t = 0):
/// per cycle the fundamental of the motor torque by the laos stage's harmonic fit
/// (fit_harmonics, 5 harmonics and drift, trapezoid weights in θ = 2πf t), its amplitude
/// |K*_1| φ0, and the surface: mobile beads within 1 d of the 99.5th percentile of the
/// heights (at the start), their azimuthal speed |v_θ| about the vane's axis sampled every
/// 10 steps and binned by radius (d/2 bins); r_c is where the cycle mean first falls below
/// 1 % of the vane tip's mean speed 4 φ0 f R_v, outward from the vane (linear between bins;
/// NaN when it never does). The whole cup's r_c_quarters takes the same rule in each of the
/// four quarters [90k − 45°, 90k + 45°) about the axis (blade k in its middle, as in a
/// periodic quarter) and averages them (NaN unless all four have one).
std::vector<CycleObservables> run_cycles(const sim::WorldState& state, double phi0, double f, int cycles) {
  sim::World w = sim::World::from_state(state);
  const double t_drive = w.time();  // the drive's phase counts from here
  w.set_rotor_drive(0, phi0, f, 0.0, t_drive);
  const sim::Rotor& rotor = w.rotor(0);
  const double torque_scale = w.options().sectors != 0 ? w.options().sectors : 1.0;  // the whole cup's
  const sim::Vec3 c = rotor.centre, axis = rotor.axis;
  double d = 0.0, rv = 0.0, rmax = 0.0;
  std::vector<double> heights;
  for (int b = 0; b < w.body_count(); ++b) {
    const sim::Vec3 rel = w.position(b) - c;
    const double r = (rel - rel.dot(axis) * axis).norm();
    if (w.kind(b) == sim::BodyKind::kKinematic) rv = std::max(rv, r + 0.5 * w.diameter(b));
    if (w.kind(b) != sim::BodyKind::kMobile) continue;
    d = std::max(d, w.diameter(b));
    rmax = std::max(rmax, r);
    heights.push_back(rel.dot(axis));
  }
  if (heights.empty()) throw NoResultError("bench sim --accuracy: the cup holds no mobile bead");
  std::sort(heights.begin(), heights.end());
  const double top = heights[static_cast<std::size_t>(0.995 * static_cast<double>(heights.size() - 1))];
  const double bin = 0.5 * d;
  const std::size_t nbins = static_cast<std::size_t>(std::ceil((rmax + d - rv) / bin)) + 1;
  const double h = w.options().time_step;
  const std::int64_t per_cycle = std::llround(1.0 / (f * h));
  const double v_c = 0.01 * 4.0 * phi0 * f * rv;
  const bool whole = w.options().sectors <= 1;
  const double bed_height_over_d = (top - heights.front()) / d + 1.0;
  std::vector<CycleObservables> out;
  for (int k = 0; k < cycles; ++k) {
    CycleObservables o;
    o.bed_height_over_d = bed_height_over_d;
    std::vector<double> theta, torque, vsum(nbins, 0.0), vcount(nbins, 0.0);
    std::array<std::vector<double>, 4> qsum{vsum, vsum, vsum, vsum}, qcount{vsum, vsum, vsum, vsum};
    const auto t0 = std::chrono::steady_clock::now();
    double sweeps = 0.0;
    for (std::int64_t s = 0; s < per_cycle; ++s) {
      const sim::StepDiagnostics dg = w.step();
      theta.push_back(2.0 * std::numbers::pi * f * (w.time() - t_drive - 0.5 * h));  // the step's torque acts over it
      torque.push_back(torque_scale * w.rotor_torque(0));
      sweeps += dg.iterations;
      o.caps += dg.hit_iteration_cap ? 1 : 0;
      o.overlap = std::max(o.overlap, dg.max_overlap);
      o.rope_excess = std::max(o.rope_excess, dg.max_rope_excess);
      if (s % 10 != 0) continue;
      for (int b = 0; b < w.body_count(); ++b) {
        if (w.kind(b) != sim::BodyKind::kMobile) continue;
        const sim::Vec3 rel = w.position(b) - c;
        if (rel.dot(axis) < top - d) continue;
        const sim::Vec3 radial = rel - rel.dot(axis) * axis;
        const double r = radial.norm();
        if (r <= rv || r <= 0.0) continue;
        const double vt = std::abs(axis.cross(radial / r).dot(w.velocity(b)));
        const std::size_t i = std::min(nbins - 1, static_cast<std::size_t>((r - rv) / bin));
        vsum[i] += vt;
        vcount[i] += 1.0;
        if (whole) {  // the quarter about blade q: azimuth in [90q − 45°, 90q + 45°)
          const double az = std::atan2(radial.y(), radial.x()) + 0.25 * std::numbers::pi;
          const auto q = static_cast<std::size_t>((static_cast<int>(std::floor(az / (0.5 * std::numbers::pi))) + 4) % 4);
          qsum[q][i] += vt;
          qcount[q][i] += 1.0;
        }
      }
    }
    o.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    o.mean_sweeps = sweeps / static_cast<double>(per_cycle);
    const double a = 2.0 * std::numbers::pi * k, b = a + 2.0 * std::numbers::pi;
    std::vector<double> wts(theta.size(), 0.0);
    laos::add_trapezoid_weights(theta, std::max(a, theta.front()), std::min(b, theta.back()), wts);
    const laos::HarmonicFit fit = laos::fit_harmonics(theta, torque, wts, phi0, laos::HarmonicFitOptions{5, true});
    o.K1p = fit.Kp[1];
    o.K1pp = fit.Kpp[1];
    o.amplitude = phi0 * std::hypot(o.K1p, o.K1pp);
    o.r_c = first_below(vsum, vcount, rv, bin, v_c);
    o.r_c_quarters = o.r_c;
    if (whole) {
      o.r_c_quarters = 0.0;  // NaN as soon as one quarter has none
      for (std::size_t q = 0; q < 4; ++q) o.r_c_quarters += 0.25 * first_below(qsum[q], qcount[q], rv, bin, v_c);
    }
    out.push_back(o);
  }
  return out;
}

/// The filled cup with the measured solver (--time-step, --tolerance, --accuracy-cap, one
/// thread), driven for `preshear_cycles` cycles of φ0 sin(2πf t) from t = 0.
sim::WorldState preshear(const sim::World& filled, const BenchSimOptions& o, const SolverChoice& solver) {
  sim::World p = restart(filled.state(), o.time_step_s, o.tolerance, o.accuracy_cap, 1, o.freeze_sweeps, solver);
  if (o.preshear_cycles <= 0) return p.state();
  p.set_rotor_drive(0, o.phi0_rad, o.f_Hz, 0.0, 0.0);
  const std::int64_t steps = std::llround(o.preshear_cycles / (o.f_Hz * o.time_step_s));
  for (std::int64_t k = 0; k < steps; ++k) (void)p.step();
  return p.state();
}

/// --scene cup --accuracy: the observables of the sheared cup against the solver's
/// tolerance and time step (sim_cup_accuracy.csv, a row per N, setting and cycle).
BenchSimSummary run_cup_accuracy(const BenchSimOptions& o, const std::vector<sim::SceneSpec>& scenes,
                                 const std::vector<std::string>& scene_files, const std::vector<int>& lengths, io::AtomicOutputSet& out, io::AtomicOutput& csv_file,
                                 core::Metadata m, const core::ProgressCallback& progress) {
  const SolverChoice solver = solver_choices(o).front();
  m.emplace_back("protocol", fmt::format("per N: the settled fill, {} pre-shear cycle(s) at h = {} s and tolerance {} "
                                         "({}), then from that state {} cycle(s) per (time_step_s, tolerance), cap {}",
                                         o.preshear_cycles, io::format_number(o.time_step_s),
                                         io::format_number(o.tolerance), solver.words(), o.cycles, o.accuracy_cap));
  m.emplace_back("K1p_N_m_per_rad", "K'_1 of the motor torque over the cycle (laos harmonic fit, 5 harmonics and "
                                     "drift; tau > 0 towards +phi)");
  m.emplace_back("torque_amplitude_N_m", "phi0 |K*_1|: the amplitude of the torque's fundamental");
  m.emplace_back("r_c_m", "surface beads (within 1 d of the 99.5th height percentile): radius where the cycle mean "
                          "|v_theta| first falls below 1 % of the vane tip's mean speed 4 phi0 f R_v (empty: never)");
  io::CsvWriter csv(csv_file.stream(), m,
                    std::vector<std::string>{"N", "beads", "solver", "time_step_s", "tolerance", "max_iterations",
                                             "phi0_rad", "f_Hz", "cycle", "torque_amplitude_N_m", "K1p_N_m_per_rad",
                                             "K1pp_N_m_per_rad", "r_c_m", "mean_sweeps_per_step", "cap_hits",
                                             "max_overlap_over_d", "max_rope_excess_over_d", "wall_s", "diverged"});
  BenchSimSummary sum;
  const std::size_t total = lengths.size() * o.cup_time_steps_s.size() * o.cup_tolerances.size();
  std::size_t done = 0;
  for (std::size_t i = 0; i < lengths.size(); ++i) {
    sim::LoadedScene sc = cup_world(out, scene_files[i], scenes[i], o.scene);
    sim::World& w = *sc.world;
    const int mobile = mobile_count(w);
    const sim::WorldState pre = preshear(w, o, solver);
    const int N = sc.beads_per_chain;
    struct Mean {
      double amp = 0, k1p = 0, k1pp = 0, rc = 0, cost = 0;
      int rc_n = 0;
      std::vector<double> amps;
    };
    std::vector<std::pair<std::string, Mean>> means;
    for (const double h : o.cup_time_steps_s)
      for (const double tol : o.cup_tolerances) {
        const sim::WorldState st = restart(pre, h, tol, o.accuracy_cap, 1, o.freeze_sweeps, solver).state();
        std::vector<CycleObservables> cyc;
        try {
          cyc = run_cycles(st, o.phi0_rad, o.f_Hz, o.cycles);
        } catch (const NoResultError& e) {
          // A setting the packing does not survive (a time step too large for the chains'
          // angle rows, say) is a point of the chart: one row saying where it failed.
          csv.row(std::vector<std::string>{std::to_string(N), std::to_string(mobile), solver.label(),
                                           io::format_number(h), io::format_number(tol), std::to_string(o.accuracy_cap),
                                           io::format_number(o.phi0_rad), io::format_number(o.f_Hz), "", "", "", "",
                                           "", "", "", "", "", "", e.what()});
          sum.lines.push_back(fmt::format("cup N = {}, h = {} s, tolerance {}: no result ({})", N, io::format_number(h),
                                          io::format_number(tol), e.what()));
          if (progress) progress(++done, total);
          continue;
        }
        Mean mean;
        for (std::size_t k = 0; k < cyc.size(); ++k) {
          const CycleObservables& c = cyc[k];
          csv.row(std::vector<std::string>{
              std::to_string(N), std::to_string(mobile), solver.label(), io::format_number(h), io::format_number(tol),
              std::to_string(o.accuracy_cap), io::format_number(o.phi0_rad), io::format_number(o.f_Hz),
              std::to_string(k), sci(c.amplitude), sci(c.K1p), sci(c.K1pp),
              std::isnan(c.r_c) ? std::string() : sci(c.r_c), fixed(c.mean_sweeps, 1), std::to_string(c.caps),
              sci(c.overlap), sci(c.rope_excess), fixed(c.wall, 2), ""});
          mean.amps.push_back(c.amplitude);
          mean.amp += c.amplitude / cyc.size();
          mean.k1p += c.K1p / cyc.size();
          mean.k1pp += c.K1pp / cyc.size();
          mean.cost += c.wall / cyc.size();
          if (!std::isnan(c.r_c)) {
            mean.rc += c.r_c;
            ++mean.rc_n;
          }
        }
        if (mean.rc_n) mean.rc /= mean.rc_n;
        means.emplace_back(fmt::format("h = {} s, tolerance {}", io::format_number(h), io::format_number(tol)), mean);
        sum.lines.push_back(fmt::format(
            "cup N = {}, h = {} s, tolerance {}: torque amplitude {:.4g} N m, K'1 {:.4g}, K''1 {:.4g} N m/rad, r_c {} "
            "mm; {:.0f} s per cycle",
            N, io::format_number(h), io::format_number(tol), mean.amp, mean.k1p, mean.k1pp,
            mean.rc_n ? fmt::format("{:.1f}", 1e3 * mean.rc) : std::string("-"), mean.cost));
        if (progress) progress(++done, total);
      }
    // The reference: the smallest time step at the tightest tolerance (the last of each list
    // once sorted); the others against it, with its cycle-to-cycle scatter (s.d.).
    const double h_ref = *std::min_element(o.cup_time_steps_s.begin(), o.cup_time_steps_s.end());
    const double tol_ref = *std::min_element(o.cup_tolerances.begin(), o.cup_tolerances.end());
    const std::string ref_name = fmt::format("h = {} s, tolerance {}", io::format_number(h_ref), io::format_number(tol_ref));
    const auto ref = std::find_if(means.begin(), means.end(), [&](const auto& e) { return e.first == ref_name; });
    if (ref != means.end() && ref->second.amps.size() > 1) {
      const Mean& r = ref->second;
      double var = 0.0;
      for (const double a : r.amps) var += (a - r.amp) * (a - r.amp);
      const double sd = std::sqrt(var / static_cast<double>(r.amps.size() - 1));
      for (const auto& [name, mn] : means)
        sum.lines.push_back(fmt::format("cup N = {}, {}: torque amplitude {:+.1f} % of the reference ({}; its "
                                        "cycle-to-cycle s.d. {:.1f} %)",
                                        N, name, 100.0 * (mn.amp / r.amp - 1.0), ref_name, 100.0 * sd / r.amp));
    }
  }
  out.commit_all();
  sum.files = out.final_paths();
  return sum;
}

/// Per geometry of --sector-check: the seed means (NaN r_c: none) and the bead count.
struct SectorSeeds {
  std::vector<double> amp, rc, rcq, bed, cost;
  int beads = 0;
};

/// The mean of the values that are not NaN (NaN when none is).
struct MeanOfFinite {
  double sum = 0.0;
  int n = 0;
  void add(double x) {
    if (std::isnan(x)) return;
    sum += x;
    ++n;
  }
  [[nodiscard]] double value() const { return n ? sum / n : std::numeric_limits<double>::quiet_NaN(); }
};

/// The whole cup's rows for N and seed from a --reference table: each copied into `csv`,
/// the seed's means (torque amplitude, r_c, r_c per quarter; NaN: none), bed height and
/// last cycle's wall time appended to `seeds`, with its bead count. Rows missing, a cycle
/// count or bead count other than this run's: InputError naming the file and line.
void reference_rows(const io::CsvTable& ref, const BenchSimOptions& o, int N, std::uint64_t seed, io::CsvWriter& csv,
                    SectorSeeds& seeds) {
  const std::size_t cN = ref.column_index("N"), cK = ref.column_index("sectors"), cS = ref.column_index("seed");
  const std::size_t cB = ref.column_index("beads"), cA = ref.column_index("torque_amplitude_N_m");
  const std::size_t cR = ref.column_index("r_c_m"), cW = ref.column_index("wall_s");
  const std::size_t cQ = ref.column_index("r_c_quarters_m"), cH = ref.column_index("bed_height_over_d");
  const int beads = cup_chains(o, N, 1) * N;  // the whole cup's mobile beads
  auto cell = [&](std::size_t i, std::size_t c) {
    return ref.cell_empty(i, c) ? std::numeric_limits<double>::quiet_NaN() : ref.number(i, c);
  };
  MeanOfFinite amp, rc, rcq;
  double height = 0.0, wall = 0.0;
  int rows = 0;
  for (std::size_t i = 0; i < ref.num_rows(); ++i) {
    if (ref.number(i, cN) != N || ref.number(i, cK) != 1 || ref.number(i, cS) != static_cast<double>(seed)) continue;
    if (ref.number(i, cB) != beads)
      throw InputError(fmt::format("{}:{}: {} beads in the whole cup (expected {}: --cup-beads {}, N = {})", ref.source,
                                   ref.row_lines[i], ref.rows[i][cB], beads, o.cup_beads, N));
    csv.row(ref.rows[i]);
    amp.add(ref.number(i, cA));
    rc.add(cell(i, cR));
    rcq.add(cell(i, cQ));
    height = ref.number(i, cH);
    wall = ref.number(i, cW);
    ++rows;
  }
  if (rows != o.cycles)
    throw InputError(fmt::format("{}: {} whole-cup rows for N = {}, seed {} (expected {}, one per measured cycle)",
                                 ref.source, rows, N, seed, o.cycles));
  seeds.amp.push_back(amp.value());
  seeds.rc.push_back(rc.value());
  seeds.rcq.push_back(rcq.value());
  seeds.bed.push_back(height);
  seeds.cost.push_back(wall);
  seeds.beads = beads;
}

/// --scene cup --sector-check: the periodic quarter against the whole cup. Per N, seed
/// and geometry: the settled fill, `preshear_cycles` cycles, then `cycles` measured cycles
/// (run_cycles; torques the whole cup's). Terminal lines: per N and geometry the mean over
/// seeds of the seed means with their seed-to-seed s.d., and the quarter's difference
/// from the whole in units of the combined standard error.
BenchSimSummary run_sector_check(const BenchSimOptions& o, const core::Metadata& header,
                                 const core::ProgressCallback& progress) {
  if (o.seeds.empty() || o.seeds.size() > 32) throw ConfigError("bench sim: --seeds needs 1 to 32 seeds");
  const SolverChoice solver = solver_choices(o).front();
  io::AtomicOutputSet out(o.out_dir, o.force);
  io::AtomicOutput& csv_file = out.add("sim_cup_sector.csv");
  core::Metadata m = header;
  m.emplace_back("machine", fmt::format("{} hardware threads; {}", std::thread::hardware_concurrency(), cpu_model()));
  m.emplace_back("scene", "the built-in cup (cup_N<N>_K<K>_seed<S>.toml beside this file): K = 1 the whole cup, K = 4 "
                          "its periodic quarter with one blade");
  const std::string protocol = fmt::format(
      "per N, seed and K: the settled fill, {} pre-shear cycle(s), then {} measured cycle(s) of phi = {} sin(2 pi {} "
      "t), h = {} s, tolerance {} ({}), cap {}",
      o.preshear_cycles, o.cycles, io::format_number(o.phi0_rad), io::format_number(o.f_Hz),
      io::format_number(o.time_step_s), io::format_number(o.tolerance), solver.words(), o.accuracy_cap);
  m.emplace_back("protocol", protocol);
  // The whole cup's rows of an earlier run of the same protocol (--reference).
  std::optional<io::CsvTable> reference;
  if (!o.sector_reference.empty()) {
    reference = io::read_csv(o.sector_reference);
    const std::string theirs = core::metadata_value(reference->metadata, "protocol", "");
    if (theirs != protocol)
      throw InputError(fmt::format("{}: protocol \"{}\" (expected this run's: \"{}\")",
                                   o.sector_reference.string(), theirs, protocol));
    m.emplace_back("reference", fmt::format("the whole cup's rows (sectors = 1) copied from {}",
                                            o.sector_reference.filename().string()));
  }
  m.emplace_back("torque_amplitude_N_m", "phi0 |K*_1| of the whole cup's motor torque (K x the simulated wedge's)");
  m.emplace_back("r_c_m", "surface beads (within 1 d of the 99.5th height percentile): radius where the cycle mean "
                          "|v_theta| first falls below 1 % of the vane tip's mean speed 4 phi0 f R_v (empty: never)");
  m.emplace_back("r_c_quarters_m", "K = 1: the mean of r_c_m's rule applied to each quarter about a blade alone "
                                   "(the quarter's number of surface beads; empty unless all four fall below); K = 4: r_c_m");
  m.emplace_back("bed_height_over_d", "the surface's top (99.5th height percentile of the centres) above the lowest "
                                      "centre, plus one bead, in bead diameters, at the start of the measured cycles");
  const std::vector<std::string> columns{"N",
                                         "sectors",
                                         "seed",
                                         "beads",
                                         "cycle",
                                         "torque_amplitude_N_m",
                                         "K1p_N_m_per_rad",
                                         "K1pp_N_m_per_rad",
                                         "r_c_m",
                                         "r_c_quarters_m",
                                         "bed_height_over_d",
                                         "mean_sweeps_per_step",
                                         "cap_hits",
                                         "max_overlap_over_d",
                                         "wall_s"};
  if (reference && reference->columns != columns)
    throw InputError(fmt::format("{}: columns {} (expected sim_cup_sector.csv's: {})", o.sector_reference.string(),
                                 fmt::join(reference->columns, ","), fmt::join(columns, ",")));
  io::CsvWriter csv(csv_file.stream(), m, columns);
  BenchSimSummary sum;
  const std::vector<int> geometries = {1, 4};
  const std::size_t total = o.chain_lengths.size() * geometries.size() * o.seeds.size();
  std::size_t done = 0;
  for (const int N : o.chain_lengths) {
    std::vector<SectorSeeds> stats(geometries.size());
    for (std::size_t g = 0; g < geometries.size(); ++g)
      for (const std::uint64_t seed : o.seeds) {
        const int K = geometries[g];
        if (K == 1 && reference) {
          reference_rows(*reference, o, N, seed, csv, stats[g]);
          if (progress) progress(++done, total);
          continue;
        }
        sim::LoadedScene sc =
            cup_world(out, fmt::format("cup_N{}_K{}_seed{}.toml", N, K, seed), cup_scene(o, N, K, seed), o.scene);
        const auto t0 = std::chrono::steady_clock::now();
        const sim::WorldState pre = preshear(*sc.world, o, solver);
        const double pre_wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const std::vector<CycleObservables> cyc = run_cycles(pre, o.phi0_rad, o.f_Hz, o.cycles);
        const int mobile = mobile_count(*sc.world);
        MeanOfFinite amp, rc, rcq;
        double cost = o.preshear_cycles == 0 ? 0.0 : pre_wall / o.preshear_cycles;
        for (std::size_t k = 0; k < cyc.size(); ++k) {
          const CycleObservables& c = cyc[k];
          csv.row(std::vector<std::string>{
              std::to_string(N), std::to_string(K), std::to_string(seed), std::to_string(mobile), std::to_string(k),
              sci(c.amplitude), sci(c.K1p), sci(c.K1pp), std::isnan(c.r_c) ? std::string() : sci(c.r_c),
              std::isnan(c.r_c_quarters) ? std::string() : sci(c.r_c_quarters), fixed(c.bed_height_over_d, 3),
              fixed(c.mean_sweeps, 1), std::to_string(c.caps), sci(c.overlap), fixed(c.wall, 2)});
          amp.add(c.amplitude);
          rc.add(c.r_c);
          rcq.add(c.r_c_quarters);
          cost = c.wall;
        }
        SectorSeeds& st = stats[g];
        st.beads = mobile;
        st.amp.push_back(amp.value());
        st.rc.push_back(rc.value());
        st.rcq.push_back(rcq.value());
        st.bed.push_back(cyc.empty() ? 0.0 : cyc.front().bed_height_over_d);
        st.cost.push_back(cost);
        if (progress) progress(++done, total);
      }
    // Mean and seed-to-seed s.d. of the seed means (NaN r_c: a seed without one is left out).
    auto mean_sd = [](const std::vector<double>& v) {
      double mean = 0.0, n = 0.0;
      for (const double x : v)
        if (!std::isnan(x)) {
          mean += x;
          n += 1.0;
        }
      if (n == 0.0) return std::array<double, 3>{std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
      mean /= n;
      double var = 0.0;
      for (const double x : v)
        if (!std::isnan(x)) var += (x - mean) * (x - mean);
      return std::array<double, 3>{mean, n > 1 ? std::sqrt(var / (n - 1)) : std::numeric_limits<double>::quiet_NaN(), n};
    };
    std::array<std::array<double, 3>, 2> a{}, r{}, q{}, b{};
    for (std::size_t g = 0; g < geometries.size(); ++g) {
      a[g] = mean_sd(stats[g].amp);
      r[g] = mean_sd(stats[g].rc);
      q[g] = mean_sd(stats[g].rcq);
      b[g] = mean_sd(stats[g].bed);
      const auto c = mean_sd(stats[g].cost);
      sum.lines.push_back(fmt::format(
          "cup N = {}, {}: {} beads, torque amplitude {:.4g} +- {:.2g} N m, r_c {:.1f} +- {:.1f} mm (per quarter "
          "{:.1f} +- {:.1f} mm), bed {:.2f} +- {:.2f} d (mean +- s.d. over {} seeds), {:.3g} s per cycle",
          N, geometries[g] == 1 ? "whole cup" : "quarter", stats[g].beads, a[g][0], a[g][1], 1e3 * r[g][0],
          1e3 * r[g][1], 1e3 * q[g][0], 1e3 * q[g][1], b[g][0], b[g][1], o.seeds.size(), c[0]));
    }
    // The difference in units of its standard error (sqrt(s1²/n1 + s2²/n2)).
    // (0 for equal values that do not scatter, as a bed of one layer).
    auto z = [](const std::array<double, 3>& x, const std::array<double, 3>& y) {
      const double se = std::sqrt(x[1] * x[1] / x[2] + y[1] * y[1] / y[2]);
      return y[0] == x[0] ? 0.0 : (y[0] - x[0]) / se;
    };
    sum.lines.push_back(fmt::format("cup N = {}: quarter - whole: torque amplitude {:+.1f} % ({:+.1f} standard errors), "
                                    "r_c {:+.1f} mm ({:+.1f} standard errors), r_c per quarter {:+.1f} mm ({:+.1f} "
                                    "standard errors), bed {:+.3f} d ({:+.1f} standard errors)",
                                    N, 100.0 * (a[1][0] / a[0][0] - 1.0), z(a[0], a[1]), 1e3 * (r[1][0] - r[0][0]),
                                    z(r[0], r[1]), 1e3 * (q[1][0] - q[0][0]), z(q[0], q[1]), b[1][0] - b[0][0],
                                    z(b[0], b[1])));
  }
  out.commit_all();
  sum.files = out.final_paths();
  return sum;
}

BenchSimSummary run_cup_bench(const BenchSimOptions& o, const core::Metadata& header,
                              const core::ProgressCallback& progress) {
  const bool builtin = o.scene == "cup";
  if (builtin) {
    if (o.chain_lengths.empty() || o.chain_lengths.size() > 32)
      throw ConfigError("bench sim --scene cup: --N needs 1 to 32 chain lengths");
    for (const int n : o.chain_lengths)
      if (n < 1 || n > 1000) throw ConfigError(fmt::format("bench sim: --N {}: expected 1..1000", n));
    if (o.cup_beads < 10 || o.cup_beads > 1000000)
      throw ConfigError(fmt::format("bench sim: --cup-beads {}: expected 10..1000000", o.cup_beads));
  } else if (!std::filesystem::exists(o.scene)) {
    throw InputError(fmt::format("bench sim --scene {}: no such file (expected cup or a scene .toml with a [vane])",
                                 o.scene));
  } else if (!sim::load_scene(o.scene, true).vane) {  // checked before the fill
    throw InputError(fmt::format("bench sim --scene {}: no [vane]: the benchmark shears a vane cup", o.scene));
  }
  if (!(o.phi0_rad > 0 && o.phi0_rad <= 100) || !(o.f_Hz > 0 && o.f_Hz <= 1000))
    throw ConfigError("bench sim: expected 0 < --phi0 <= 100 rad and 0 < --f-hz <= 1000");
  if (o.steps < 1 || o.steps > 100000 || o.warmup_steps < 0 || o.warmup_steps > 100000)
    throw ConfigError("bench sim: expected --steps 1..100000 and --warmup-steps 0..100000");
  if (o.cup_sectors != 1 && o.cup_sectors != 4)
    throw ConfigError(fmt::format("bench sim: --sectors {}: expected 1 (the whole cup) or 4 (a quarter: the cup's "
                                  "four blades)",
                                  o.cup_sectors));
  if (o.cup_sectors != 1 && !builtin)
    throw ConfigError("bench sim: --sectors applies to --scene cup (a scene file sets cylinder.sectors itself)");
  if (o.sector_check) {
    if (!builtin) throw ConfigError("bench sim: --sector-check compares the built-in cup's quarter and whole: --scene cup");
    return run_sector_check(o, header, progress);
  }
  io::AtomicOutputSet out(o.out_dir, o.force);
  io::AtomicOutput& csv_file = out.add(o.cup_accuracy ? "sim_cup_accuracy.csv" : "sim_cup.csv");
  const std::vector<int> lengths = builtin ? o.chain_lengths : std::vector<int>{0};
  // The built-in cup's scenes as values (each written beside the outputs), or the user's.
  std::vector<sim::SceneSpec> scenes;
  std::vector<std::string> scene_files;
  for (const int n : lengths) {
    scenes.push_back(builtin ? cup_scene(o, n, o.cup_sectors, o.seed) : sim::read_scene(o.scene));
    scene_files.push_back(builtin ? fmt::format("cup_N{}.toml", n) : std::string());
  }

  core::Metadata m = header;
  m.emplace_back("machine", fmt::format("{} hardware threads; {}", std::thread::hardware_concurrency(), cpu_model()));
  m.emplace_back("scene", builtin ? "the paper's cup (cup_N<N>.toml beside this file)" : o.scene);
  m.emplace_back("drive", fmt::format("phi = {} sin(2 pi {} t) from the relaxed packing (t = 0: the vane at its "
                                      "fastest, {} m/s at the tip of a 10.8 mm vane)",
                                      io::format_number(o.phi0_rad), io::format_number(o.f_Hz),
                                      io::format_number(o.phi0_rad * 2 * std::numbers::pi * o.f_Hz * 0.0108)));
  if (o.cup_accuracy) return run_cup_accuracy(o, scenes, scene_files, lengths, out, csv_file, m, progress);
  m.emplace_back("timing", "warmup_steps untimed on one thread after the fill, then per thread count the same "
                           "timed steps from that state; wall_s: the timed steps only");
  m.emplace_back("cycle_wall_s", "wall time of one drive cycle (1/f) at this rate: wall_s / steps x 1 / (f h)");
  io::CsvWriter csv(csv_file.stream(), m,
                    std::vector<std::string>{"N", "beads", "threads", "solver", "time_step_s", "tolerance", "max_iterations",
                                             "phi0_rad", "f_Hz", "fill_wall_s", "fill_drop_steps", "fill_relax_steps",
                                             "warmup_steps", "steps", "wall_s", "steps_per_s",
                                             "mean_sweeps_per_step", "median_sweeps_per_step", "max_sweeps",
                                             "cap_hits", "max_overlap_over_d", "wall_s_per_simulated_s",
                                             "cycle_wall_s"});
  BenchSimSummary sum;
  const std::vector<SolverChoice> solvers = solver_choices(o);
  const std::size_t total = lengths.size() * o.threads.size() * solvers.size();
  std::size_t done = 0;
  for (std::size_t i = 0; i < lengths.size(); ++i) {
    sim::LoadedScene sc = cup_world(out, scene_files[i], scenes[i], o.scene);
    sim::World& w = *sc.world;
    const int mobile = mobile_count(w);
    w.set_rotor_drive(0, o.phi0_rad, o.f_Hz, 0.0, w.time());
    for (int k = 0; k < o.warmup_steps; ++k) (void)w.step();
    const sim::WorldState sheared = w.state();
    const double h = w.options().time_step;
    for (const SolverChoice& solver : solvers)
    for (const int t : o.threads) {
      const SweepStats r = time_sheared(sheared, t, solver, o.steps);
      const double per_step = r.wall / o.steps;
      const int N = sc.beads_per_chain;
      csv.row(std::vector<std::string>{
          std::to_string(N), std::to_string(mobile), std::to_string(t),
          solver.label(), io::format_number(h),
          io::format_number(w.options().tolerance), std::to_string(w.options().max_iterations),
          io::format_number(o.phi0_rad), io::format_number(o.f_Hz), fixed(sc.fill.seconds, 2),
          std::to_string(sc.fill.settle_steps), std::to_string(sc.fill.relax_steps),
          std::to_string(o.warmup_steps), std::to_string(o.steps), fixed(r.wall, 3),
          fixed(o.steps / r.wall, 3), fixed(r.mean, 1), fixed(r.median, 1), std::to_string(r.max),
          std::to_string(r.caps), sci(r.overlap), fixed(per_step / h, 1), fixed(per_step / (o.f_Hz * h), 0)});
      sum.lines.push_back(fmt::format(
          "cup N = {}: {} beads, {} thread{}, {}: {:.3g} s per step, {:.0f} sweeps per step (median {:.0f}, {} of {} "
          "at the cap), {:.3g} s per simulated s, one {} s cycle {:.3g} s; fill {:.0f} s",
          N, mobile, t, t == 1 ? "" : "s", solver.words(), per_step, r.mean, r.median, r.caps, o.steps, per_step / h,
          io::format_number(1.0 / o.f_Hz), per_step / (o.f_Hz * h), sc.fill.seconds));
      if (progress) progress(++done, total);
    }
  }
  out.commit_all();
  sum.files = out.final_paths();
  return sum;
}

/// The peer benchmark's stirred box (research: the same scene LAMMPS, LIGGGHTS and YADE
/// ran): `stir_beads` single beads (d = 2.4 mm steel, mu = 0.2 with beads and walls)
/// settled in a 25 d x 25 d box, then a rod of 25 kinematic beads along y, its centres
/// 1 d below the 99.5th-percentile bead height at x = 3 d, pushed along +x at 5 mm/s;
/// mobile beads overlapping the rod are removed.
/// `plow`: the rod becomes a full-height wall of kinematic beads (columns from the floor
/// up to the rod's height at x = 3 d), the plowed packing of the solver issue.
BenchSimSummary run_stir_bench(const BenchSimOptions& o, const core::Metadata& header,
                               const core::ProgressCallback& progress, bool plow) {
  const std::string name = plow ? "plow" : "stir";
  if (o.stir_beads < 10 || o.stir_beads > 1000000)
    throw ConfigError(fmt::format("bench sim: --stir-beads {}: expected 10..1000000", o.stir_beads));
  const double d = 2.4e-3, side = o.stir_side_d * d, rod_speed = 5e-3;
  const int rod_beads = static_cast<int>(o.stir_side_d);
  // Tall enough for the packing (random loose packing ~0.6) and its drop column.
  const double height = o.stir_beads * std::numbers::pi / 6.0 * d * d * d / (0.55 * side * side) + 3 * d;
  io::AtomicOutputSet out(o.out_dir, o.force);
  io::AtomicOutput& csv_file = out.add("sim_" + name + ".csv");
  sim::SceneSpec box = bench_scene(o, "bench sim --scene " + name);  // the settled box (the bench adds the rod)
  box.box.min_m = sim::SceneSpec::Numbers{0.0, 0.0, 0.0};
  box.box.max_m = sim::SceneSpec::Numbers{side, side, height};
  box.box.friction = 0.2;
  box.beads.diameter_m = d;
  box.fill.count = o.stir_beads;
  box.fill.min_m = box.box.min_m;
  box.fill.max_m = box.box.max_m;
  box.fill.seed = static_cast<std::int64_t>(o.seed);
  box.fill.settle = true;
  sim::write_scene(box, out.add(name + ".toml").stream(),
                   fmt::format("# shearzone bench sim --scene {}: the peer benchmark's box, settled (the rod is "
                               "added by the bench)\n",
                               name));
  sim::LoadedScene sc = sim::build_scene(box, false);
  const sim::WorldState settled = sc.world->state();

  // The rod: 1 d below the 99.5th percentile of the bead heights, at x = 3 d.
  std::vector<double> z;
  for (std::size_t b = 0; b < settled.position.size(); ++b)
    if (settled.kind[b] == sim::BodyKind::kMobile) z.push_back(settled.position[b].z());
  std::sort(z.begin(), z.end());
  const double z_rod = z[static_cast<std::size_t>(0.995 * static_cast<double>(z.size() - 1))] - d;
  if (!(z_rod >= 0.5 * d))
    throw NoResultError(fmt::format("bench sim --scene {}: the settled packing is too shallow for the rod ({} m "
                                    "below the floor's top): give more --stir-beads (at least ~1500)",
                                    name, io::format_number(0.5 * d - z_rod)));
  std::vector<sim::Vec3> rod;
  for (int k = 0; k < rod_beads; ++k) {
    rod.emplace_back(3 * d, (k + 0.5) * d, z_rod);
    if (plow)  // the column below it, down to the floor
      for (double zc = z_rod - d; zc >= 0.5 * d - 1e-12; zc -= d) rod.emplace_back(3 * d, (k + 0.5) * d, zc);
  }
  sim::WorldState st = settled;
  std::vector<int> new_index(settled.position.size(), -1);
  st.position.clear();
  st.velocity.clear();
  st.angular_velocity.clear();
  st.orientation.clear();
  st.diameter.clear();
  st.mass.clear();
  st.inertia.clear();
  st.kind.clear();
  auto keep = [&](std::size_t b) {
    new_index[b] = static_cast<int>(st.position.size());
    st.position.push_back(settled.position[b]);
    st.velocity.push_back(settled.velocity[b]);
    st.angular_velocity.push_back(settled.angular_velocity[b]);
    st.orientation.push_back(settled.orientation[b]);
    st.diameter.push_back(settled.diameter[b]);
    st.mass.push_back(settled.mass[b]);
    st.inertia.push_back(settled.inertia[b]);
    st.kind.push_back(settled.kind[b]);
  };
  int removed = 0;
  for (std::size_t b = 0; b < settled.position.size(); ++b) {
    bool hit = false;
    for (const sim::Vec3& r : rod) hit = hit || (settled.position[b] - r).norm() < d;
    if (hit && settled.kind[b] == sim::BodyKind::kMobile) ++removed;
    else keep(b);
  }
  const std::size_t template_bead = 0;
  for (const sim::Vec3& r : rod) {
    st.position.push_back(r);
    st.velocity.emplace_back(rod_speed, 0.0, 0.0);
    st.angular_velocity.push_back(sim::Vec3::Zero());
    st.orientation.push_back(Eigen::Quaterniond::Identity());
    st.diameter.push_back(d);
    st.mass.push_back(settled.mass[template_bead]);
    st.inertia.push_back(settled.inertia[template_bead]);
    st.kind.push_back(sim::BodyKind::kKinematic);
  }
  // Warm start: the contacts between surviving bodies, renumbered.
  st.contacts.clear();
  for (sim::ContactRecord c : settled.contacts) {
    if ((c.body_i >= 0 && new_index[static_cast<std::size_t>(c.body_i)] < 0) ||
        (c.body_j >= 0 && new_index[static_cast<std::size_t>(c.body_j)] < 0))
      continue;
    if (c.body_i >= 0) c.body_i = new_index[static_cast<std::size_t>(c.body_i)];
    if (c.body_j >= 0) c.body_j = new_index[static_cast<std::size_t>(c.body_j)];
    st.contacts.push_back(c);
  }
  const int mobile = o.stir_beads - removed;
  sim::World w = sim::World::from_state(st);
  for (int k = 0; k < o.warmup_steps; ++k) (void)w.step();
  const sim::WorldState stirred = w.state();

  core::Metadata m = header;
  m.emplace_back("machine", fmt::format("{} hardware threads; {}", std::thread::hardware_concurrency(), cpu_model()));
  m.emplace_back("scene", fmt::format("the peer benchmark's stirred box ({} d wide): {} single beads settled "
                                      "({}.toml), {} of {} kinematic beads at x = 3 d, top at z = {} m (1 d below the "
                                      "99.5th percentile), +x at 5 mm/s; {} mobile beads overlapping it removed",
                                      o.stir_side_d, o.stir_beads, name, plow ? "a full-height wall" : "a rod",
                                      rod.size(), io::format_number(z_rod), removed));
  m.emplace_back("peer", "LAMMPS, Hertz-Mindlin softened to E = 200 MPa, 2 cores: 266 s per simulated second on "
                         "the same scene (full 1.0 s run), 477 s on 1 core (static)");
  io::CsvWriter csv(csv_file.stream(), m,
                    std::vector<std::string>{"mobile_beads", "threads", "solver", "time_step_s", "tolerance",
                                             "max_iterations", "fill_wall_s", "warmup_steps", "steps", "wall_s",
                                             "steps_per_s", "mean_sweeps_per_step", "median_sweeps_per_step",
                                             "cap_hits", "max_overlap_over_d", "wall_s_per_simulated_s"});
  BenchSimSummary sum;
  const std::vector<SolverChoice> solvers = solver_choices(o);
  const std::size_t total = o.threads.size() * solvers.size();
  std::size_t done = 0;
  for (const SolverChoice& solver : solvers)
    for (const int t : o.threads) {
      const SweepStats r = time_sheared(stirred, t, solver, o.steps);
      const double per_step = r.wall / o.steps, h = stirred.options.time_step;
      csv.row(std::vector<std::string>{
          std::to_string(mobile), std::to_string(t), solver.label(), io::format_number(h),
          io::format_number(stirred.options.tolerance), std::to_string(stirred.options.max_iterations),
          fixed(sc.fill.seconds, 2), std::to_string(o.warmup_steps), std::to_string(o.steps), fixed(r.wall, 3),
          fixed(o.steps / r.wall, 3), fixed(r.mean, 1), fixed(r.median, 1), std::to_string(r.caps), sci(r.overlap),
          fixed(per_step / h, 1)});
      sum.lines.push_back(fmt::format(
          "{}: {} beads, {} thread{}, {}: {:.3g} s per step, {:.0f} sweeps per step (median {:.0f}, {} of {} "
          "at the cap), {:.3g} s per simulated s (LAMMPS softened, 2 cores: 266)",
          name, mobile, t, t == 1 ? "" : "s", solver.words(), per_step, r.mean, r.median, r.caps, o.steps,
          per_step / h));
      if (progress) progress(++done, total);
    }
  out.commit_all();
  sum.files = out.final_paths();
  return sum;
}

}  // namespace

namespace {

/// --quick: a smoke run of every table in seconds.
void set_quick(BenchSimOptions& o) {
  o.beads = {150, 300};
  o.steps = 5;
  o.warmup_steps = 3;
  o.accuracy_beads = 150;
  o.accuracy_time_steps_s = {5e-4, 1e-3};
  o.accuracy_max_iterations = {25, 100};
  o.accuracy_duration_s = 0.002;
  o.settle_max_steps = 600;
  o.relax_min_steps = 5;
  o.relax_max_steps = 50;
  o.cup_beads = 400;
  o.stir_beads = 300;
  o.stir_side_d = 10;
  o.chain_lengths = {1};
  o.cup_tolerances = {1e-2, 1e-3};
  o.cup_time_steps_s = {1e-3};
  o.preshear_cycles = 0;
  o.seeds = {1, 2};
  if (o.cup_accuracy || o.sector_check) o.f_Hz = 10.0;  // 100 steps per cycle
}

/// The options every bench takes (threads, solvers, --reference).
void validate_common(const BenchSimOptions& o) {
  if (o.threads.empty()) throw ConfigError("bench sim: --threads needs at least one thread count");
  if (o.solvers.empty() || o.solvers.size() > 3)
    throw ConfigError("bench sim: --solver needs one to three solvers (alternate, forward, anderson)");
  for (const std::string& n : o.solvers)
    if (n != "alternate" && n != "forward" && n != "anderson")
      throw ConfigError(fmt::format("bench sim: --solver {}: expected alternate, forward or anderson", n));
  if (o.anderson_depth < 1 || o.anderson_depth > 10)
    throw ConfigError(fmt::format("bench sim: --anderson-depth {}: out of [1, 10]", o.anderson_depth));
  for (int t : o.threads)
    if (t < 1 || t > 256) throw ConfigError(fmt::format("bench sim: --threads {}: out of [1, 256]", t));
  if (!o.sector_reference.empty() && !o.sector_check)
    throw ConfigError("bench sim: --reference is the whole cup's rows of --sector-check: give --sector-check");
  if (o.sector_check && o.cup_accuracy)
    throw ConfigError("bench sim: --sector-check and --accuracy are separate runs: give one");
}

/// --accuracy and --sector-check on the sheared cup.
void validate_cup_charts(const BenchSimOptions& o) {
  if (o.scene.empty() || o.scene == "stir" || o.scene == "plow")
    throw ConfigError("bench sim: --accuracy charts the sheared cup: give --scene cup or a scene .toml with a [vane]");
  auto bad_list = [](const std::vector<double>& v, double hi) {
    if (v.empty() || v.size() > 16) return true;
    for (const double x : v)
      if (!(x > 0.0 && x <= hi)) return true;
    return false;
  };
  if (bad_list(o.cup_tolerances, 1.0))
    throw ConfigError("bench sim: --tolerances needs 1 to 16 tolerances, each in (0, 1]");
  if (bad_list(o.cup_time_steps_s, 0.1))
    throw ConfigError("bench sim: --time-steps needs 1 to 16 time steps, each in (0, 0.1] s");
  if (o.cycles < 1 || o.cycles > 1000 || o.preshear_cycles < 0 || o.preshear_cycles > 1000)
    throw ConfigError(fmt::format("bench sim: --cycles {} / --preshear-cycles {}: expected 1..1000 and 0..1000",
                                  o.cycles, o.preshear_cycles));
  if (o.accuracy_cap < 1 || o.accuracy_cap > 100000)
    throw ConfigError(fmt::format("bench sim: --accuracy-cap {}: expected 1..100000", o.accuracy_cap));
  // The torque's harmonic fit (5 harmonics and a drift: 12 parameters) needs 13 steps a cycle.
  constexpr long long kMinStepsPerCycle = 13;
  if (o.f_Hz > 0)
    for (const double h : o.cup_accuracy ? o.cup_time_steps_s : std::vector<double>{o.time_step_s})
      if (h > 0 && std::llround(1.0 / (o.f_Hz * h)) < kMinStepsPerCycle)
        throw ConfigError(fmt::format("bench sim: h = {} s at --f-hz {}: {} steps per drive cycle (expected at least "
                                      "{} for the torque's harmonic fit)",
                                      io::format_number(h), io::format_number(o.f_Hz),
                                      std::llround(1.0 / (o.f_Hz * h)), kMinStepsPerCycle));
}

/// The packing bench's own options.
void validate_box_bench(const BenchSimOptions& o) {
  if (!(o.time_step_s > 0.0 && o.time_step_s <= 0.1) || !(o.tolerance > 0.0) || o.max_iterations < 1 ||
      o.max_iterations > 100000 || o.freeze_sweeps < 0 || o.relax_max_steps < 0 || o.relax_max_steps > 1000000 ||
      o.relax_min_steps < 0)
    throw ConfigError("bench sim: expected 0 < --time-step <= 0.1 s, --tolerance > 0, --max-iterations 1..100000, "
                      "--freeze-sweeps >= 0, --relax-steps 0..1000000");
  if (o.beads.empty()) throw ConfigError("bench sim: --beads needs at least one bead count");
  for (int b : o.beads)
    if (b < 1 || b > 1000000) throw ConfigError(fmt::format("bench sim: --beads {}: out of [1, 1e6]", b));
  if (o.beads.size() > 32) throw ConfigError(fmt::format("bench sim: --beads lists {} counts: expected at most 32", o.beads.size()));
  if (o.threads.size() > 32) throw ConfigError(fmt::format("bench sim: --threads lists {} counts: expected at most 32", o.threads.size()));
  if (o.steps < 1 || o.steps > 100000 || o.warmup_steps < 0 || o.warmup_steps > 100000)
    throw ConfigError(fmt::format("bench sim: --steps {}: expected 1..100000", o.steps));
  if (o.accuracy_beads < 1 || o.accuracy_beads > 1000000)
    throw ConfigError(fmt::format("bench sim: --accuracy-beads {}: expected 1..1000000", o.accuracy_beads));
  if (!(o.accuracy_duration_s > 0.0)) throw ConfigError("bench sim: accuracy duration must be > 0");
}

/// The packing bench: speed against bead count and threads, accuracy against time step
/// and iteration cap.
BenchSimSummary run_box_bench(const BenchSimOptions& o, const core::Metadata& header,
                              const core::ProgressCallback& progress) {
  io::AtomicOutputSet out(o.out_dir, o.force);
  out.check("sim_speed.csv");
  out.check("sim_accuracy.csv");

  const std::size_t total =
      o.beads.size() * o.threads.size() + o.accuracy_time_steps_s.size() * o.accuracy_max_iterations.size();
  std::size_t done = 0;
  std::map<int, sim::SettledPour> packings;
  auto packing = [&](int count) -> const sim::SettledPour& {
    auto it = packings.find(count);
    if (it == packings.end()) {
      const sim::LatticePour lp{.count = count, .diameter = kDiameter, .density = kDensity, .pitch = kPitch,
                                .jitter = kJitter, .wall_friction = kFriction, .seed = o.seed};
      const sim::PourSettling st{.drop_time_step = kSettleStep, .drop_tolerance = kSettleTolerance,
                                 .drop_max_iterations = kSettleIterations, .drop_kinetic_energy = kSettleEnergy,
                                 .drop_max_steps = o.settle_max_steps, .relax_min_steps = o.relax_min_steps,
                                 .relax_max_steps = o.relax_max_steps, .relax_kinetic_energy = kRelaxEnergy};
      // Relaxed with the measured solver (one thread).
      const SolverChoice solver = solver_choices(o).front();
      it = packings
               .emplace(count, sim::settle_lattice_pour(lp, st,
                                                        [&](sim::Options& so) {
                                                          so.time_step = o.time_step_s;
                                                          so.tolerance = o.tolerance;
                                                          so.max_iterations = o.max_iterations;
                                                          so.threads = 1;
                                                          so.freeze_sweeps = o.freeze_sweeps;
                                                          solver.set(so);
                                                        }))
               .first;
    }
    return it->second;
  };
  auto describe = [&](int count) {
    const sim::SettledPour& p = packing(count);
    return fmt::format("{} beads: {}x{} floor lattice, {} layers, dropped in {} steps to ½mv²/(mgd) = "
                       "{:.2e}, relaxed in {} steps to {:.2e}, top at {:.1f} mm",
                       count, p.layout.floor_side, p.layout.floor_side, p.layout.layers, p.drop_steps,
                       p.drop_kinetic_energy, p.relax_steps, p.relax_kinetic_energy, 1e3 * p.height);
  };

  core::Metadata base = header;
  base.emplace_back("machine", fmt::format("{} hardware threads; {}", std::thread::hardware_concurrency(),
                                           cpu_model()));
  base.emplace_back("threads", fmt::format("{}", fmt::join(o.threads, ",")));
  base.emplace_back(
      "packing",
      fmt::format("single beads d = {} mm, density {} kg/m3, friction {} (beads and walls), gravity "
                  "9.81 m/s2; jittered lattice (pitch {} d, jitter +-{} d, alternate layers shifted) "
                  "in a square box (floor + 4 side walls) sized for the count; dropped with h = {} s, "
                  "tolerance {}, cap {} until ½mv² per bead < {} m g d (at most {} steps); then relaxed "
                  "with the measured h, tolerance and cap (one thread) for at least {} steps until a "
                  "step converges with ½mv² per bead < {} m g d (at most {} steps); seed {}",
                  1e3 * kDiameter, kDensity, kFriction, kPitch, kJitter, kSettleStep,
                  kSettleTolerance, kSettleIterations, kSettleEnergy, o.settle_max_steps,
                  o.relax_min_steps, kRelaxEnergy, o.relax_max_steps, o.seed));
  base.emplace_back("solver", fmt::format("{} (the packing's relaxation and every table)",
                                          solver_choices(o).front().words()));
  base.emplace_back("row_updates", "local solves of the NLGS sweeps (frozen rows skipped do not count); "
                                   "active: those on rows with a non-zero impulse after the solve or "
                                   "closed (contact gap <= 0, taut rope, angle at its limit)");

  // 1. Speed against bead count.
  std::vector<std::vector<std::string>> speed_rows;
  BenchSimSummary sum;
  std::vector<std::string> packing_lines;
  for (int count : o.beads) {
    const sim::SettledPour& p = packing(count);
    for (int threads : o.threads) {
      sim::World w = restart(p.state, o.time_step_s, o.tolerance, o.max_iterations, threads, o.freeze_sweeps, solver_choices(o).front());
      if (o.warmup_steps > 0) (void)timed(w, o.warmup_steps);
      const Run r = timed(w, o.steps);
      const double sps = r.steps / r.seconds;
      speed_rows.push_back({std::to_string(count), std::to_string(threads), std::to_string(r.steps),
                            fixed(r.seconds, 4), fixed(sps, 4), std::to_string(r.row_updates),
                            sci(r.row_updates / r.seconds), sci(r.active_row_updates / r.seconds),
                            sci(r.row_updates / r.seconds / threads),
                            fixed(static_cast<double>(r.frozen_skips) / r.steps, 1),
                            fixed(static_cast<double>(r.iterations) / r.steps, 2),
                            sci(r.residual_sum / r.steps), std::to_string(r.cap_hits), sci(r.max_overlap)});
      sum.lines.push_back(fmt::format(
          "{} beads, {} thread{}: {:.3f} steps/s, {:.3e} row updates/s ({:.3e} active), {:.1f} sweeps/step, "
          "residual {:.2e}, {} cap hits, max overlap {:.2e} d",
          count, threads, threads == 1 ? "" : "s", sps, r.row_updates / r.seconds,
          r.active_row_updates / r.seconds, static_cast<double>(r.iterations) / r.steps,
          r.residual_sum / r.steps, r.cap_hits, r.max_overlap));
      if (progress) progress(++done, total);
    }
    packing_lines.push_back(describe(count));
  }
  {
    core::Metadata meta = base;
    meta.emplace_back("bench", fmt::format("speed against bead count: {} untimed warm-up steps, then {} "
                                           "timed steps (wall clock) with h = {} s, tolerance {}, cap {}, "
                                           "freeze_sweeps {}, warm-started, per thread count",
                                           o.warmup_steps, o.steps, o.time_step_s, o.tolerance,
                                           o.max_iterations, o.freeze_sweeps));
    meta.emplace_back("packings", fmt::format("{}", fmt::join(packing_lines, "; ")));
    io::CsvWriter w(out.add("sim_speed.csv").stream(), meta,
                    {"beads", "threads", "steps", "seconds", "steps_per_s", "row_updates", "row_updates_per_s",
                     "active_row_updates_per_s", "row_updates_per_s_per_thread", "frozen_skips_per_step",
                     "mean_iterations", "mean_residual", "cap_hits", "max_overlap_over_d"});
    for (const auto& r : speed_rows) w.row(r);
  }

  // 2. Accuracy against iterations and time step.
  std::vector<std::vector<std::string>> acc_rows;
  const sim::SettledPour& ap = packing(o.accuracy_beads);
  for (double h : o.accuracy_time_steps_s)
    for (int cap : o.accuracy_max_iterations) {
      if (!(h > 0.0) || cap < 1) throw ConfigError("bench sim: accuracy grid needs h > 0 and cap >= 1");
      sim::World w = restart(ap.state, h, o.tolerance, cap, 1, o.freeze_sweeps, solver_choices(o).front());
      const int steps = std::max(1, static_cast<int>(std::lround(o.accuracy_duration_s / h)));
      const Run r = timed(w, steps);
      acc_rows.push_back({sci(h), std::to_string(cap), sci(o.tolerance),
                          fixed(static_cast<double>(r.iterations) / r.steps, 2), sci(r.residual_sum / r.steps),
                          sci(r.max_overlap), sci(r.kinetic_energy), sci(r.seconds / r.steps)});
      if (progress) progress(++done, total);
    }
  {
    core::Metadata meta = base;
    meta.emplace_back("bench", fmt::format("accuracy against time step and iteration cap on the {}-bead "
                                           "packing: every setting runs {} s of simulated time from the "
                                           "same settled state (impulses rescaled to h), tolerance {}; "
                                           "max_overlap_over_d: largest over the run; kinetic_energy_J: at "
                                           "its end (translation and rotation)",
                                           o.accuracy_beads, o.accuracy_duration_s, o.tolerance));
    meta.emplace_back("packings", describe(o.accuracy_beads));
    io::CsvWriter w(out.add("sim_accuracy.csv").stream(), meta,
                    {"time_step_s", "max_iterations", "tolerance", "mean_iterations", "mean_residual",
                     "max_overlap_over_d", "kinetic_energy_J", "seconds_per_step"});
    for (const auto& r : acc_rows) w.row(r);
  }
  out.commit_all();
  sum.files = out.final_paths();
  return sum;
}

}  // namespace

BenchSimSummary run_sim_bench(const BenchSimOptions& options, const core::Metadata& header,
                              const core::ProgressCallback& progress) {
  BenchSimOptions o = options;
  if (o.quick) set_quick(o);
  validate_common(o);
  if (o.cup_accuracy || o.sector_check) validate_cup_charts(o);
  if (o.scene == "stir" || o.scene == "plow") return run_stir_bench(o, header, progress, o.scene == "plow");
  if (!o.scene.empty()) return run_cup_bench(o, header, progress);
  validate_box_bench(o);
  return run_box_bench(o, header, progress);
}

}  // namespace shearzone::bench
