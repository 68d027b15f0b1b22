// `shearzone sim`: see shearzone/pipeline/sim_job.hpp.
#include "shearzone/pipeline/sim_job.hpp"

#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/toml_config.hpp"
#include "shearzone/sim/builder.hpp"
#include "shearzone/sim/sim_io.hpp"
#include "shearzone/sim/world.hpp"

namespace shearzone::pipeline {
namespace {

using sim::Vec3;

const std::vector<std::string> kKeys = {
    "sim.duration_s",         "sim.time_step_s",        "sim.gravity_m_per_s2",
    "sim.friction",           "sim.tolerance",          "sim.max_iterations",
    "sim.alert_margin",       "sim.max_overlap",        "sim.max_rope_excess",
    "sim.max_angle_excess_deg",
    "output.snapshot_every",  "output.checkpoint_every", "output.diagnostics_every",
    "box.min_m",              "box.max_m",              "box.friction",
    "box.lid",
    "cylinder.radius_m",      "cylinder.height_m",      "cylinder.bead_diameter_m",
    "cylinder.centre_m",      "cylinder.floor_friction",
    "beads.diameter_m",       "beads.density_kg_per_m3", "beads.positions_m",
    "beads.fixed_positions_m",
    "chains.beads_per_chain", "chains.l_max_m",         "chains.max_angle_deg",
    "fill.count",             "fill.min_m",             "fill.max_m",
    "fill.seed",              "fill.clearance"};

double deg(double a) { return a * std::numbers::pi / 180.0; }

class Scene {
 public:
  explicit Scene(const std::filesystem::path& path) : t_(io::TomlConfig::load(path)) {
    t_.require_known(kKeys);
  }
  bool has(const std::string& k) const { return t_.has(k); }
  double num(const std::string& k, double fallback) const { return t_.has(k) ? t_.get_double(k) : fallback; }
  long long integer(const std::string& k, long long fallback, long long min) const {
    if (!t_.has(k)) return fallback;
    const long long v = t_.get_int(k);
    if (v < min) fail(k, fmt::format("{} (expected >= {})", v, min));
    return v;
  }
  double positive(const std::string& k, double fallback) const {
    const double v = num(k, fallback);
    if (!(v > 0.0) || !std::isfinite(v)) fail(k, fmt::format("{} (expected > 0)", v));
    return v;
  }
  bool flag(const std::string& k, bool fallback) const { return t_.has(k) ? t_.get_bool(k) : fallback; }
  std::vector<double> numbers(const std::string& k) const {
    std::vector<double> out;
    if (!t_.has(k)) return out;
    for (const std::string& s : t_.texts(k)) {
      double v = 0.0;
      if (!io::parse_number(s, false, v) || !std::isfinite(v))
        fail(k, fmt::format("\"{}\" is not a finite number", s));
      out.push_back(v);
    }
    return out;
  }
  std::vector<double> fixed_size(const std::string& k, std::size_t n) const {
    std::vector<double> v = numbers(k);
    if (v.size() != n) fail(k, fmt::format("{} values (expected {})", v.size(), n));
    return v;
  }
  [[noreturn]] void fail(const std::string& k, const std::string& what) const {
    throw ConfigError(fmt::format("{}:{}: key \"{}\": {}", t_.source(), t_.line(k), k, what));
  }
  [[noreturn]] void fail_file(const std::string& what) const {
    throw ConfigError(fmt::format("{}: {}", t_.source(), what));
  }

 private:
  io::TomlConfig t_;
};

struct Cadence {
  double duration_s = 0.0;
  std::int64_t snapshot_every = 100, checkpoint_every = 0, diagnostics_every = 1;
};

Cadence read_cadence(const Scene& s) {
  Cadence c;
  if (!s.has("sim.duration_s")) s.fail_file("key \"sim.duration_s\" is required");
  c.duration_s = s.num("sim.duration_s", 0.0);
  if (!(c.duration_s >= 0.0) || !std::isfinite(c.duration_s))
    s.fail("sim.duration_s", fmt::format("{} (expected >= 0)", c.duration_s));
  c.snapshot_every = s.integer("output.snapshot_every", c.snapshot_every, 0);
  c.checkpoint_every = s.integer("output.checkpoint_every", c.checkpoint_every, 0);
  c.diagnostics_every = s.integer("output.diagnostics_every", c.diagnostics_every, 1);
  return c;
}

sim::Options read_options(const Scene& s) {
  sim::Options o;
  o.time_step = s.num("sim.time_step_s", o.time_step);
  if (s.has("sim.gravity_m_per_s2")) {
    const auto g = s.fixed_size("sim.gravity_m_per_s2", 3);
    o.gravity = Vec3(g[0], g[1], g[2]);
  }
  o.friction = s.num("sim.friction", o.friction);
  o.tolerance = s.num("sim.tolerance", o.tolerance);
  o.max_iterations = static_cast<int>(s.integer("sim.max_iterations", o.max_iterations, 1));
  o.alert_margin = s.num("sim.alert_margin", o.alert_margin);
  o.max_overlap = s.num("sim.max_overlap", o.max_overlap);
  o.max_rope_excess = s.num("sim.max_rope_excess", o.max_rope_excess);
  if (s.has("sim.max_angle_excess_deg")) o.max_angle_excess = deg(s.num("sim.max_angle_excess_deg", 2.0));
  return o;
}

/// Builds the world of a scene; chain ids per body (for the snapshots).
sim::World build_world(const Scene& s, std::vector<std::int64_t>& chain_ids) {
  sim::World w(read_options(s));
  std::int64_t next_chain = 0;
  auto own_chain = [&] { chain_ids.push_back(next_chain++); };
  if (s.has("box.min_m") || s.has("box.max_m")) {
    const auto lo = s.fixed_size("box.min_m", 3), hi = s.fixed_size("box.max_m", 3);
    for (int k = 0; k < 3; ++k)
      if (!(hi[static_cast<std::size_t>(k)] > lo[static_cast<std::size_t>(k)]))
        s.fail("box.max_m", "must exceed box.min_m in every coordinate");
    const double mu = s.num("box.friction", 0.5);
    sim::add_box_walls(w, sim::BoxRegion{Vec3(lo[0], lo[1], lo[2]), Vec3(hi[0], hi[1], hi[2])}, mu);
    if (s.flag("box.lid", false)) w.add_wall(sim::Wall{Vec3(lo[0], lo[1], hi[2]), -Vec3::UnitZ(), mu});
  } else if (s.has("box.friction") || s.has("box.lid")) {
    s.fail_file("[box] needs min_m and max_m");
  }
  const bool cylinder = s.has("cylinder.radius_m");
  if (cylinder && s.has("box.min_m")) s.fail_file("give either [box] or [cylinder], not both");
  if (cylinder) {
    const double r = s.positive("cylinder.radius_m", 1.0);
    const double height = s.positive("cylinder.height_m", 1.0);
    const double dw = s.positive("cylinder.bead_diameter_m", 1.0);
    std::vector<double> c{0.0, 0.0};
    if (s.has("cylinder.centre_m")) c = s.fixed_size("cylinder.centre_m", 2);
    w.add_wall(sim::Wall{Vec3(c[0], c[1], 0.0), Vec3::UnitZ(), s.num("cylinder.floor_friction", 0.5)});
    const double rc = r + 0.5 * dw;  // bead centres: the beads' inner surface at r
    const auto per_ring = static_cast<int>(std::ceil(2.0 * std::numbers::pi * rc / dw));
    const double rho = s.positive("beads.density_kg_per_m3", 2500.0);
    for (int layer = 0; (0.5 + layer) * dw <= height; ++layer)
      for (int k = 0; k < per_ring; ++k) {
        const double a = 2.0 * std::numbers::pi * (k + 0.5 * (layer % 2)) / per_ring;
        w.add_sphere(Vec3(c[0] + rc * std::cos(a), c[1] + rc * std::sin(a), (0.5 + layer) * dw), dw, rho,
                     sim::BodyKind::fixed);
        own_chain();
      }
  } else if (s.has("cylinder.height_m") || s.has("cylinder.bead_diameter_m") || s.has("cylinder.centre_m") ||
             s.has("cylinder.floor_friction")) {
    s.fail_file("[cylinder] needs radius_m");
  }

  const bool any_beads = s.has("beads.positions_m") || s.has("beads.fixed_positions_m") || s.has("fill.count");
  if (!any_beads) return w;
  if (!s.has("beads.diameter_m")) s.fail_file("key \"beads.diameter_m\" is required with beads");
  const double d = s.positive("beads.diameter_m", 1.0);
  const double rho = s.positive("beads.density_kg_per_m3", 2500.0);
  sim::ChainOptions co;
  co.diameter = d;
  co.density = rho;
  co.beads_per_chain = static_cast<int>(s.integer("chains.beads_per_chain", 1, 1));
  co.l_max = s.num("chains.l_max_m", 0.0);
  co.theta_max = deg(s.num("chains.max_angle_deg", 180.0));
  if (!(co.l_max >= 0.0)) s.fail("chains.l_max_m", fmt::format("{} (expected >= 0)", co.l_max));
  if (!(co.theta_max > 0.0) || co.theta_max > std::numbers::pi)
    s.fail("chains.max_angle_deg", "expected in (0, 180]");

  const auto fixed = s.numbers("beads.fixed_positions_m");
  if (fixed.size() % 3 != 0) s.fail("beads.fixed_positions_m", "the count must be a multiple of 3");
  for (std::size_t k = 0; k < fixed.size(); k += 3) {
    w.add_sphere(Vec3(fixed[k], fixed[k + 1], fixed[k + 2]), d, rho, sim::BodyKind::fixed);
    own_chain();
  }
  const auto pos = s.numbers("beads.positions_m");
  if (pos.size() % 3 != 0) s.fail("beads.positions_m", "the count must be a multiple of 3");
  const std::size_t nb = pos.size() / 3, n = static_cast<std::size_t>(co.beads_per_chain);
  if (nb % n != 0)
    s.fail("beads.positions_m", fmt::format("{} beads are not whole chains of {}", nb, n));
  for (std::size_t c = 0; c < nb / n; ++c) {
    std::vector<int> ids;
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t b = 3 * (c * n + k);
      ids.push_back(w.add_sphere(Vec3(pos[b], pos[b + 1], pos[b + 2]), d, rho));
      chain_ids.push_back(next_chain);
    }
    ++next_chain;
    if (n > 1) w.add_chain(ids, d + co.l_max, co.theta_max);
  }
  if (s.has("fill.count")) {
    co.chains = static_cast<int>(s.integer("fill.count", 1, 1));
    co.seed = static_cast<std::uint64_t>(s.integer("fill.seed", 1, 0));
    co.clearance = s.num("fill.clearance", co.clearance);
    const auto lo = s.fixed_size("fill.min_m", 3), hi = s.fixed_size("fill.max_m", 3);
    const sim::Region region = sim::BoxRegion{Vec3(lo[0], lo[1], lo[2]), Vec3(hi[0], hi[1], hi[2])};
    sim::validate(region);
    sim::validate(co);
    const sim::ChainPlacement p = sim::place_chains(region, co);
    sim::add_chains(w, p, co);
    for (int c : p.chain_of_bead) chain_ids.push_back(next_chain + c);
    next_chain += co.chains;
  } else if (s.has("fill.min_m") || s.has("fill.max_m") || s.has("fill.seed") || s.has("fill.clearance")) {
    s.fail_file("[fill] needs count");
  }
  return w;
}

}  // namespace

SimJobSummary run_sim_job(const SimJobOptions& o, const core::Metadata& header,
                          const core::ProgressCallback& progress) {
  const Scene scene(o.scene);
  const Cadence cad = read_cadence(scene);
  std::vector<std::int64_t> chain_ids;
  std::optional<sim::World> built;
  if (o.restart.empty()) {
    built.emplace(build_world(scene, chain_ids));
  } else {
    (void)build_world(scene, chain_ids);  // checks the scene's sections
    built.emplace(sim::World::from_state(sim::read_checkpoint(o.restart)));
    chain_ids = sim::chain_ids_from_ropes(built->state());
  }
  sim::World& w = *built;

  SimJobSummary sum;
  sum.first_step = w.steps_done();
  sum.bodies = w.body_count();
  sum.walls = static_cast<int>(w.walls().size());
  sum.ropes = w.rope_count();
  sum.angles = w.angle_count();
  const double h = w.options().time_step;
  const auto end_step = static_cast<std::int64_t>(std::llround(cad.duration_s / h));
  const std::int64_t todo = std::max<std::int64_t>(0, end_step - w.steps_done());

  core::Metadata meta = header;
  meta.emplace_back("scene", o.scene.string());
  if (!o.restart.empty()) meta.emplace_back("restart", o.restart.string());
  meta.emplace_back("time_step_s", io::CsvWriter::format_number(h));
  meta.emplace_back("bodies", std::to_string(w.body_count()));

  io::AtomicOutputSet out(o.output_dir, o.force);
  io::AtomicOutput& snap_file = out.add("snapshots.h5");
  io::AtomicOutput& xdmf_file = out.add("snapshots.xdmf");
  io::AtomicOutput& diag_file = out.add("diagnostics.csv");
  out.check("checkpoint.h5");
  io::AtomicOutput* ckpt_file = nullptr;

  sim::SnapshotWriter snaps(snap_file.temp_path(), w, meta, chain_ids);
  sim::DiagnosticsCsv diag(diag_file.stream(), meta);
  auto checkpoint = [&] {
    if (ckpt_file == nullptr) ckpt_file = &out.add("checkpoint.h5");
    sim::write_checkpoint(ckpt_file->temp_path(), w, meta);
    ++sum.checkpoints;
  };
  auto finish_files = [&] {
    snaps.close();
    sim::write_snapshot_xdmf(xdmf_file.stream(), "snapshots.h5", snaps.body_count(), snaps.times());
    sum.snapshots = snaps.snapshot_count();
  };

  const auto t0 = std::chrono::steady_clock::now();
  const std::int64_t cap0 = w.iteration_cap_hits();
  if (cad.snapshot_every > 0 || todo == 0) snaps.append(w);
  std::int64_t last_snapshot = w.steps_done();
  try {
    for (std::int64_t k = 1; k <= todo; ++k) {
      const sim::StepDiagnostics d = w.step();
      sum.max_overlap_over_d = std::max(sum.max_overlap_over_d, d.max_overlap);
      if (d.step % cad.diagnostics_every == 0 || k == todo) diag.row(d, w.time());
      if (cad.snapshot_every > 0 && d.step % cad.snapshot_every == 0) {
        snaps.append(w);
        last_snapshot = d.step;
      }
      if (cad.checkpoint_every > 0 && d.step % cad.checkpoint_every == 0 && k != todo) checkpoint();
      if (progress) progress(static_cast<std::size_t>(k), static_cast<std::size_t>(todo));
    }
  } catch (const NoResultError&) {
    // The failing step's state is not written; what was written up to it is whole.
    sum.steps = w.steps_done() - sum.first_step;
    finish_files();
    out.commit_all();
    throw;
  }
  if (last_snapshot != w.steps_done()) snaps.append(w);
  checkpoint();
  finish_files();
  out.commit_all();
  sum.steps = w.steps_done() - sum.first_step;
  sum.time_s = w.time();
  sum.state_hash = w.state_hash();
  sum.iteration_cap_hits = w.iteration_cap_hits() - cap0;
  sum.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace shearzone::pipeline
