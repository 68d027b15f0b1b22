// The scene TOML of `shearzone sim`: see shearzone/sim/scene.hpp.
#include "shearzone/sim/scene.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <ostream>
#include <numbers>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/json.hpp"
#include "shearzone/io/toml_config.hpp"
#include "shearzone/sim/builder.hpp"

namespace shearzone::sim {
namespace {


// Lengths that may also be given in bead diameters (beads.diameter_m): key_d for key_m.
const std::vector<std::string> kLengthKeys = {"cylinder.radius_m", "cylinder.height_m", "vane.radius_m",
                                              "vane.height_m", "fill.height_m"};

// The settle/relax keys of [fill]; they only mean something with fill.settle = true.
const std::vector<std::string> kSettleKeys = {
    "fill.insert_fraction",  "fill.settle_tolerance",      "fill.settle_max_iterations",
    "fill.settle_max_steps", "fill.settle_kinetic_energy", "fill.relax_kinetic_energy",
    "fill.relax_max_steps",  "fill.plateau_ratio"};

constexpr long long kMaxSweeps = 100000;      // NLGS sweeps per step (sim.max_iterations)
constexpr long long kMaxFillSteps = 10000000;  // fill.settle_max_steps, fill.relax_max_steps
constexpr double kMaxWallBeads = 1e6;          // cylinder wall and floor beads, as for mobile beads

double deg(double a) { return a * std::numbers::pi / 180.0; }

/// Everything a scene puts in the world, read and checked before anything is built (the
/// spec's sections in SI units, the cylinder's and the vane's beads laid out).
struct SceneBodies {
  // Container: a box of half-space walls, or a cylinder of fixed beads on a floor plane.
  std::optional<BoxRegion> box;
  double box_friction = 0.5;
  bool lid = false;
  bool cylinder = false;
  double cyl_radius = 0.0, cyl_height = 0.0, cyl_bead = 0.0, cyl_floor_friction = 0.5;
  double cyl_cx = 0.0, cyl_cy = 0.0;
  bool rough_floor = false;  ///< a layer of fixed beads on the floor, centres at z = 0
  int sectors = 0;           ///< cylinder.sectors: a periodic wedge of 1/sectors of the cup (0: the whole cup)
  double floor_top = 0.0;    ///< where the mobile space starts: cylinder.bead_diameter_m / 2 on a rough floor
  // Beads.
  double diameter = 0.0, density = 2500.0;
  std::vector<Vec3> fixed, kinematic, mobile;
  Vec3 kinematic_velocity = Vec3::Zero(), kinematic_omega = Vec3::Zero();
  ChainOptions chains;
  // [vane]: kinematic beads of a rigid rotor about the vertical axis through its centre.
  std::vector<Vec3> vane;
  Vec3 vane_centre = Vec3::Zero();
  double vane_phi0 = 0.0, vane_f = 0.0, vane_phase = 0.0, vane_torque_every = 1e-3, vane_stop_change = 0.0;
  // [fill].
  bool fill = false;
  Region fill_region;
  bool settle = false;
  FillOptions settle_options;
};

/// A spec's keys resolved: the world's options, bodies, cadence, protocol and camera.
struct ResolvedScene {
  std::optional<SceneProtocol> protocol;
  std::optional<SceneCamera> camera;
  SceneCadence cadence;
  Options options;     ///< the world's (a periodic sector's fields set from the cylinder)
  SceneBodies bodies;  ///< the container, beads, chains, vane and fill
};

/// The checked getters of a spec's keys by name: defaults, ranges, lengths in bead
/// diameters, and refusals naming the spec's source, line and key.
class Scene {
 public:
  /// A given key's member of the spec (not a copy: a scene's positions may be millions).
  using Value = std::variant<const double*, const std::int64_t*, const bool*, const std::string*,
                             const std::vector<double>*>;
  explicit Scene(const SceneSpec& spec) : spec_(spec) {
    SceneSpec::for_each_key(spec, [this](const char* name, const auto& key) {
      if (key) values_.emplace(name, Value(&*key));
    });
  }
  bool has(const std::string& k) const { return given(k) || (is_length(k) && given(in_d(k))); }
  /// A number; a length key (kLengthKeys) given as key_d instead comes back in metres.
  double num(const std::string& k, double fallback) const {
    if (is_length(k) && given(in_d(k))) {
      if (given(k)) fail(in_d(k), fmt::format("give either {} (m) or {} (bead diameters), not both", k, in_d(k)));
      if (!given("beads.diameter_m"))
        fail(in_d(k), "a length in bead diameters needs beads.diameter_m");
      return get<double>(in_d(k)) * get<double>("beads.diameter_m");
    }
    return given(k) ? get<double>(k) : fallback;
  }
  long long integer(const std::string& k, long long fallback, long long min,
                    long long max = std::numeric_limits<long long>::max()) const {
    if (!given(k)) return fallback;
    const long long v = get<std::int64_t>(k);
    if (v < min || v > max) {
      if (max == std::numeric_limits<long long>::max()) fail(k, fmt::format("{} (expected >= {})", v, min));
      fail(k, fmt::format("{} (expected in [{}, {}])", v, min, max));
    }
    return v;
  }
  double positive(const std::string& k, double fallback) const {
    const double v = num(k, fallback);
    if (!(v > 0.0) || !std::isfinite(v)) fail(k, fmt::format("{} (expected > 0)", v));
    return v;
  }
  /// lo <= v <= hi (lo < v when open_lo), finite.
  double within(const std::string& k, double fallback, double lo, double hi, bool open_lo = false) const {
    const double v = num(k, fallback);
    if (!(open_lo ? v > lo : v >= lo) || !(v <= hi))
      fail(k, fmt::format("{} (expected in {}{}, {}])", v, open_lo ? "(" : "[", lo, hi));
    return v;
  }
  double non_negative(const std::string& k, double fallback) const {
    const double v = num(k, fallback);
    if (!(v >= 0.0) || !std::isfinite(v)) fail(k, fmt::format("{} (expected >= 0)", v));
    return v;
  }
  bool flag(const std::string& k, bool fallback) const { return given(k) ? get<bool>(k) : fallback; }
  std::string text(const std::string& k) const { return get<std::string>(k); }
  std::vector<double> numbers(const std::string& k) const {
    if (!given(k)) return {};
    std::vector<double> v = get<std::vector<double>>(k);
    for (const double x : v)  // a spec built in code may hold what a file cannot
      if (!std::isfinite(x)) fail(k, fmt::format("{} is not a finite number (expected a number or a list of numbers)", x));
    return v;
  }
  std::vector<double> fixed_size(const std::string& k, std::size_t n) const {
    std::vector<double> v = numbers(k);
    if (v.size() != n) fail(k, fmt::format("{} values (expected {})", v.size(), n));
    return v;
  }
  Vec3 vec3(const std::string& k) const {
    const auto v = fixed_size(k, 3);
    return {v[0], v[1], v[2]};
  }
  /// Positions x0, y0, z0, x1, ... as points.
  std::vector<Vec3> points(const std::string& k) const {
    const auto v = numbers(k);
    if (v.size() % 3 != 0) fail(k, "the count must be a multiple of 3");
    if (v.size() > 3000000) fail(k, fmt::format("{} beads (expected at most 1e6)", v.size() / 3));
    std::vector<Vec3> out;
    for (std::size_t i = 0; i < v.size(); i += 3) out.emplace_back(v[i], v[i + 1], v[i + 2]);
    return out;
  }
  /// ConfigError "<source>:<line>: key "<key>": <what>" (no line for a spec built in code).
  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    // A length given in bead diameters is named as written.
    const std::string named = is_length(key) && !given(key) && given(in_d(key)) ? in_d(key) : key;
    if (spec_.lines.empty()) throw ConfigError(fmt::format("{}: key \"{}\": {}", spec_.source, named, what));
    const auto line = spec_.lines.find(named);
    throw ConfigError(fmt::format("{}:{}: key \"{}\": {}", spec_.source, line == spec_.lines.end() ? 0 : line->second,
                                  named, what));
  }
  [[noreturn]] void fail_file(const std::string& what) const {
    throw ConfigError(fmt::format("{}: {}", spec_.source, what));
  }

 private:
  bool given(const std::string& k) const { return values_.count(k) != 0; }
  template <class T>
  const T& get(const std::string& k) const {
    return *std::get<const T*>(values_.at(k));  // each key's type is its SceneSpec member's
  }
  static bool is_length(const std::string& k) {
    return std::find(kLengthKeys.begin(), kLengthKeys.end(), k) != kLengthKeys.end();
  }
  static std::string in_d(const std::string& k) { return k.substr(0, k.size() - 2) + "_d"; }
  const SceneSpec& spec_;
  std::map<std::string, Value> values_;
};

/// [protocol]: the paper's fill -> pre-shear -> amplitude branches (one scene, one command).
std::optional<SceneProtocol> read_protocol(const Scene& s) {
  const bool any = s.has("protocol.preshear_phi0_rad") || s.has("protocol.preshear_f_Hz") ||
                   s.has("protocol.preshear_s") || s.has("protocol.stop_change") || s.has("protocol.phi0_rad") ||
                   s.has("protocol.f_Hz") || s.has("protocol.cycles");
  if (!any) return std::nullopt;
  if (!s.has("protocol.phi0_rad")) s.fail_file("[protocol] needs phi0_rad (the branches' amplitudes, rad)");
  if (!s.has("vane.radius_m")) s.fail_file("[protocol] drives a vane: give [vane] radius_m and height_m");
  // One source for each number: the protocol sets the vane's drive and the durations.
  for (const char* k : {"sim.duration_s", "vane.phi0_rad", "vane.f_Hz", "vane.phase_rad", "vane.stop_change"})
    if (s.has(k))
      s.fail(k, "set by [protocol] in a protocol scene (preshear_s, preshear_phi0_rad, preshear_f_Hz, "
                "stop_change): remove it");
  SceneProtocol p;
  p.preshear_phi0_rad = s.within("protocol.preshear_phi0_rad", p.preshear_phi0_rad, 0.0, 100.0, true);
  p.preshear_f_Hz = s.within("protocol.preshear_f_Hz", p.preshear_f_Hz, 0.0, 1000.0, true);
  p.preshear_s = s.within("protocol.preshear_s", p.preshear_s, 0.0, 1e7);
  p.stop_change = s.within("protocol.stop_change", p.stop_change, 0.0, 1.0);
  p.f_Hz = s.within("protocol.f_Hz", p.f_Hz, 0.0, 1000.0, true);
  p.cycles = s.within("protocol.cycles", p.cycles, 0.0, 1e6, true);
  p.phi0_rad = s.numbers("protocol.phi0_rad");
  if (p.phi0_rad.empty()) s.fail("protocol.phi0_rad", "no amplitude (expected a list such as [0.02, 0.3])");
  std::vector<std::string> names;
  for (const double a : p.phi0_rad) {
    if (!(a > 0.0 && a <= 100.0)) s.fail("protocol.phi0_rad", fmt::format("{} (expected 0 < phi0 <= 100 rad)", a));
    const std::string name = SceneProtocol::branch_folder(a);
    if (std::find(names.begin(), names.end(), name) != names.end())
      s.fail("protocol.phi0_rad", fmt::format("{} appears twice (branch folder {})", a, name));
    names.push_back(name);
  }
  return p;
}

/// The friction of a vane cup when the scene does not say: the paper's chains, oiled.
constexpr double kCupFriction = 0.2;
constexpr int kSceneAndersonDepth = 3;  // a scene's default sim.anderson_depth
bool vane_scene(const Scene& s) { return s.has("vane.radius_m") || s.has("vane.height_m"); }

SceneCadence read_cadence(const Scene& s, const std::optional<SceneProtocol>& protocol) {
  SceneCadence c;
  c.snapshot_every = s.integer("output.snapshot_every", c.snapshot_every, 0);
  c.checkpoint_every = s.integer("output.checkpoint_every", c.checkpoint_every, 0);
  c.diagnostics_every = s.integer("output.diagnostics_every", c.diagnostics_every, 1);
  if (protocol) {
    c.duration_s = protocol->preshear_s;
    return c;
  }
  if (!s.has("sim.duration_s")) s.fail_file("key \"sim.duration_s\" is required");
  c.duration_s = s.num("sim.duration_s", 0.0);
  if (!(c.duration_s >= 0.0) || !std::isfinite(c.duration_s))
    s.fail("sim.duration_s", fmt::format("{} (expected >= 0)", c.duration_s));
  return c;
}

Options read_options(const Scene& s) {
  Options o;
  // The ranges of World's constructor, checked here so that the message names the line.
  // Upper bounds keep a run's cost bounded (World::step also refuses a step whose
  // contact search would reach beyond 8 diameters: every pair would become a contact).
  o.time_step = s.within("sim.time_step_s", o.time_step, 0.0, 1.0, true);
  if (s.has("sim.gravity_m_per_s2")) {
    o.gravity = s.vec3("sim.gravity_m_per_s2");
    if (!(o.gravity.norm() <= 1000.0))
      s.fail("sim.gravity_m_per_s2", fmt::format("|g| = {} m/s^2 (expected at most 1000)", o.gravity.norm()));
  }
  // A vane cup's beads are the paper's oiled steel (mu ~ 0.2); other scenes the engine's 0.5.
  o.friction = s.non_negative("sim.friction", vane_scene(s) ? kCupFriction : o.friction);
  o.tolerance = s.positive("sim.tolerance", o.tolerance);
  o.max_iterations = static_cast<int>(s.integer("sim.max_iterations", o.max_iterations, 1, kMaxSweeps));
  o.alert_margin = s.within("sim.alert_margin", o.alert_margin, 0.0, 1.0);
  o.max_overlap = s.positive("sim.max_overlap", o.max_overlap);
  o.max_rope_excess = s.positive("sim.max_rope_excess", o.max_rope_excess);
  if (s.has("sim.max_angle_excess_deg")) o.max_angle_excess = deg(s.positive("sim.max_angle_excess_deg", 2.0));
  o.freeze_sweeps = static_cast<int>(s.integer("sim.freeze_sweeps", o.freeze_sweeps, 0, 1000000));
  o.threads = static_cast<int>(s.integer("sim.threads", o.threads, 1, 256));
  // Every scene's solver: forward sweeps with Anderson acceleration, the fastest measured
  // on each kind of scene (sheared cups 2.0-2.2x, plowed and stirred boxes 1.9x and 1.35x,
  // the demo's pour 1.2x less time than the engine's alternating NLGS; docs/sim.md,
  // "Solver"). The engine's own default (World::Options) stays alternating NLGS.
  o.alternate_sweeps = false;
  o.anderson_depth = kSceneAndersonDepth;
  if (s.has("sim.sweep_order")) {
    const std::string order = s.text("sim.sweep_order");
    if (order != "alternate" && order != "forward")
      s.fail("sim.sweep_order", fmt::format("\"{}\" (expected \"alternate\" or \"forward\")", order));
    o.alternate_sweeps = order == "alternate";
  }
  o.anderson_depth = static_cast<int>(s.integer("sim.anderson_depth", o.anderson_depth, 0, 10));
  return o;
}

/// Axis-aligned box from two keys, max > min in every coordinate.
BoxRegion read_box(const Scene& s, const std::string& lo_key, const std::string& hi_key) {
  const Vec3 lo = s.vec3(lo_key), hi = s.vec3(hi_key);
  for (int k = 0; k < 3; ++k)
    if (!(hi[k] > lo[k])) s.fail(hi_key, fmt::format("must exceed {} in every coordinate", lo_key));
  return {lo, hi};
}


/// The first side of a periodic wedge of 1/k of the cup: blade 0 (azimuth 0) in its middle.
double sector_start(int k) { return k != 0 ? -std::numbers::pi / k : 0.0; }

SceneBodies read_bodies(const Scene& s) {
  SceneBodies b;
  if (s.has("box.min_m") || s.has("box.max_m")) {
    b.box = read_box(s, "box.min_m", "box.max_m");
    b.box_friction = s.non_negative("box.friction", 0.5);
    b.lid = s.flag("box.lid", false);
  } else if (s.has("box.friction") || s.has("box.lid")) {
    s.fail_file("[box] needs min_m and max_m");
  }
  b.cylinder = s.has("cylinder.radius_m");
  if (b.cylinder && b.box) s.fail_file("give either [box] or [cylinder], not both");
  b.density = s.positive("beads.density_kg_per_m3", 2500.0);
  if (b.cylinder) {
    b.cyl_radius = s.positive("cylinder.radius_m", 1.0);
    if (!s.has("cylinder.height_m")) s.fail_file("[cylinder] needs height_m (or height_d)");
    b.cyl_height = s.positive("cylinder.height_m", 1.0);
    // The wall beads: cylinder.bead_diameter_m, by default the beads' own diameter.
    if (!s.has("cylinder.bead_diameter_m") && !s.has("beads.diameter_m"))
      s.fail_file("[cylinder] needs bead_diameter_m (or beads.diameter_m)");
    b.cyl_bead = s.positive("cylinder.bead_diameter_m", s.num("beads.diameter_m", 1.0));
    {  // the wall beads add_container() places: rings of ceil(2 pi (R + d/2) / d) beads
      const double per_ring = std::ceil(2.0 * std::numbers::pi * (b.cyl_radius + 0.5 * b.cyl_bead) / b.cyl_bead);
      const double layers = std::max(0.0, std::floor(b.cyl_height / b.cyl_bead - 0.5) + 1.0);
      if (!(per_ring * layers <= kMaxWallBeads))
        s.fail("cylinder.bead_diameter_m",
               fmt::format("{} m makes {:.3g} wall beads for radius_m = {} and height_m = {} (expected at most 1e6)",
                           b.cyl_bead, per_ring * layers, b.cyl_radius, b.cyl_height));
    }
    if (s.has("cylinder.centre_m")) {
      const auto c = s.fixed_size("cylinder.centre_m", 2);
      b.cyl_cx = c[0];
      b.cyl_cy = c[1];
    }
    b.cyl_floor_friction = s.non_negative("cylinder.floor_friction", vane_scene(s) ? kCupFriction : 0.5);
    b.sectors = static_cast<int>(s.integer("cylinder.sectors", 1, 1, 64));
    if (b.sectors == 2) s.fail("cylinder.sectors", "2 (expected 1, the whole cup, or 3 to 64)");
    if (b.sectors == 1) b.sectors = 0;
    b.rough_floor = s.flag("cylinder.rough_floor", false);
    if (b.rough_floor) {
      b.floor_top = 0.5 * b.cyl_bead;
      // The floor beads: a triangular lattice of touching beads, about 1.155 R^2 / d^2.
      if (!(1.2 * b.cyl_radius * b.cyl_radius / (b.cyl_bead * b.cyl_bead) <= kMaxWallBeads))
        s.fail("cylinder.rough_floor", "the floor would hold more than 1e6 beads (a larger bead_diameter_m)");
    }
  } else if (s.has("cylinder.height_m") || s.has("cylinder.bead_diameter_m") || s.has("cylinder.centre_m") ||
             s.has("cylinder.floor_friction") || s.has("cylinder.rough_floor") || s.has("cylinder.sectors")) {
    s.fail_file("[cylinder] needs radius_m (or radius_d)");
  }

  for (const char* k : {"beads.kinematic_velocity_m_per_s", "beads.kinematic_angular_velocity_rad_per_s"})
    if (s.has(k) && !s.has("beads.kinematic_positions_m")) s.fail(k, "needs beads.kinematic_positions_m");
  const bool any_beads = s.has("beads.positions_m") || s.has("beads.fixed_positions_m") ||
                         s.has("beads.kinematic_positions_m") || s.has("fill.count") || s.has("vane.radius_m");
  // Without fill.count, no other [fill] key may be set.
  auto no_fill_keys = [&s] {
    for (const char* k : {"fill.min_m", "fill.max_m", "fill.seed", "fill.clearance", "fill.settle"})
      if (s.has(k)) s.fail_file("[fill] needs count");
    for (const std::string& k : kSettleKeys)
      if (s.has(k)) s.fail_file("[fill] needs count");
  };
  if (!any_beads) {
    no_fill_keys();
    return b;
  }
  if (!s.has("beads.diameter_m")) s.fail_file("key \"beads.diameter_m\" is required with beads");
  b.diameter = s.positive("beads.diameter_m", 1.0);
  ChainOptions& co = b.chains;
  co.diameter = b.diameter;
  co.density = b.density;
  // Scene sizes are bounded so that time and memory stay bounded (the paper's cup holds
  // about 15 000 beads; 1e6 is the most a scene may hold).
  constexpr std::int64_t kMaxBeads = 1000000;
  co.beads_per_chain = static_cast<int>(s.integer("chains.beads_per_chain", 1, 1, kMaxBeads));
  co.l_max = s.non_negative("chains.l_max_m", 0.0);
  co.theta_max = deg(s.num("chains.max_angle_deg", 180.0));
  if (!(co.theta_max > 0.0) || co.theta_max > std::numbers::pi)
    s.fail("chains.max_angle_deg", "expected in (0, 180]");
  // The periodic quarter was validated against the whole cup for single beads and the
  // paper's 9-bead chains (docs/sim.md, "Periodic sector"); longer chains reach further
  // round the cup than any validated case and can touch their own images.
  constexpr int kSectorValidatedChain = 9;
  const bool sector_chains = s.flag("cylinder.sector_chains", false);
  if (b.sectors != 0 && co.beads_per_chain > kSectorValidatedChain && !sector_chains)
    s.fail("cylinder.sectors", fmt::format("a periodic sector with chains of {} beads is not validated (validated up to "
                                           "{} beads against the whole cup): simulate the whole cup, or set "
                                           "cylinder.sector_chains = true to run it anyway",
                                           co.beads_per_chain, kSectorValidatedChain));
  if (sector_chains && b.sectors == 0) s.fail("cylinder.sector_chains", "only applies with cylinder.sectors");

  b.fixed = s.points("beads.fixed_positions_m");
  b.kinematic = s.points("beads.kinematic_positions_m");
  if (s.has("beads.kinematic_velocity_m_per_s")) b.kinematic_velocity = s.vec3("beads.kinematic_velocity_m_per_s");
  if (s.has("beads.kinematic_angular_velocity_rad_per_s"))
    b.kinematic_omega = s.vec3("beads.kinematic_angular_velocity_rad_per_s");
  if (s.has("vane.radius_m") || s.has("vane.height_m")) {
    if (!s.has("vane.radius_m") || !s.has("vane.height_m"))
      s.fail_file("[vane] needs radius_m and height_m (or radius_d, height_d)");
    const double d = b.diameter;
    const double radius = s.positive("vane.radius_m", 1.0), height = s.positive("vane.height_m", 1.0);
    const auto blades = static_cast<int>(s.integer("vane.blades", 4, 1, 64));
    if (radius < 1.5 * d) s.fail("vane.radius_m", fmt::format("{} m: expected at least 1.5 bead diameters", radius));
    if (height < d) s.fail("vane.height_m", fmt::format("{} m: expected at least one bead diameter", height));
    const double layers = std::floor(height / d - 0.5) + 1.0, per_blade = std::floor(radius / d - 0.5);
    if (!(layers * (1.0 + blades * per_blade) <= static_cast<double>(kMaxBeads)))
      s.fail("vane.height_m", "the vane would hold more than 1e6 beads");
    if (s.has("vane.centre_m")) {
      const auto c = s.fixed_size("vane.centre_m", 2);
      b.vane_centre = Vec3(c[0], c[1], 0.0);
    } else if (b.cylinder) {
      b.vane_centre = Vec3(b.cyl_cx, b.cyl_cy, 0.0);
    }
    if (b.cylinder && std::hypot(b.vane_centre.x() - b.cyl_cx, b.vane_centre.y() - b.cyl_cy) + radius > b.cyl_radius)
      s.fail("vane.radius_m", fmt::format("{} m: the vane reaches through the cylinder wall at {} m", radius,
                                          b.cyl_radius));
    b.vane_phi0 = s.num("vane.phi0_rad", 0.0);
    if (!(std::abs(b.vane_phi0) <= 100.0)) s.fail("vane.phi0_rad", "expected |phi0| <= 100 rad");
    b.vane_f = s.non_negative("vane.f_Hz", 0.0);
    if (!(b.vane_f <= 1000.0)) s.fail("vane.f_Hz", "expected 0 <= f <= 1000 Hz");
    b.vane_phase = s.num("vane.phase_rad", 0.0);
    if (!std::isfinite(b.vane_phase)) s.fail("vane.phase_rad", "expected a finite number");
    b.vane_torque_every = s.non_negative("vane.torque_every_rad", 1e-3);
    b.vane_stop_change = s.non_negative("vane.stop_change", 0.0);
    if (b.sectors != 0) {  // one blade per wedge, in its middle, never reaching a side
      if (blades != b.sectors)
        s.fail("cylinder.sectors", fmt::format("{}: a periodic sector holds one blade, the vane has {} (expected "
                                               "vane.blades = {})",
                                               b.sectors, blades, b.sectors));
      if (std::hypot(b.vane_centre.x() - b.cyl_cx, b.vane_centre.y() - b.cyl_cy) != 0.0)
        s.fail("vane.centre_m", "a periodic sector needs the vane on the cylinder's axis");
      if (!(std::abs(b.vane_phi0) < std::numbers::pi / b.sectors))
        s.fail("vane.phi0_rad", fmt::format("{} rad: the blade would leave its sector (expected |phi0| < pi/{})",
                                            b.vane_phi0, b.sectors));
    }
    if (b.vane_stop_change > 0 && !(b.vane_f > 0)) s.fail("vane.stop_change", "needs vane.f_Hz > 0 (whole cycles)");
    // A hub bead on the axis and, per blade, touching beads at r = d, 2d, ... while the
    // tip bead's outer edge stays within radius_m; layers from the floor up to height_m.
    // Layers from the floor up (on a rough floor, from the floor beads' tops).
    for (int layer = 0; b.floor_top + (0.5 + layer) * d <= height; ++layer) {
      const double z = b.floor_top + (0.5 + layer) * d;
      b.vane.push_back(b.vane_centre + Vec3(0, 0, z));
      for (int j = 0; j < blades; ++j) {
        const double a = 2.0 * std::numbers::pi * j / blades;
        for (int k = 1; (k + 0.5) * d <= radius * (1 + 1e-12); ++k)
          b.vane.push_back(b.vane_centre + Vec3(k * d * std::cos(a), k * d * std::sin(a), z));
      }
    }
  } else {
    for (const char* k : {"vane.blades", "vane.centre_m", "vane.phi0_rad", "vane.f_Hz", "vane.phase_rad",
                          "vane.torque_every_rad", "vane.stop_change"})
      if (s.has(k)) s.fail_file("[vane] needs radius_m and height_m");
  }
  b.mobile = s.points("beads.positions_m");
  if (!b.mobile.empty() && s.has("fill.count") && s.flag("fill.settle", false))
    s.fail("beads.positions_m",
           "explicit mobile beads cannot be combined with fill.settle = true (the fill builds the packing "
           "in worlds of its own; give them as fixed_positions_m, or drop fill.settle)");
  const std::size_t n = static_cast<std::size_t>(co.beads_per_chain);
  if (b.mobile.size() % n != 0)
    s.fail("beads.positions_m", fmt::format("{} beads are not whole chains of {}", b.mobile.size(), n));

  b.fill = s.has("fill.count");
  if (!b.fill) {
    no_fill_keys();
    return b;
  }
  co.chains = static_cast<int>(s.integer("fill.count", 1, 1, kMaxBeads));
  if (static_cast<std::int64_t>(co.chains) * co.beads_per_chain > kMaxBeads)
    s.fail("fill.count", fmt::format("{} chains of {} beads: expected at most {} beads in all", co.chains,
                                     co.beads_per_chain, kMaxBeads));
  co.seed = static_cast<std::uint64_t>(s.integer("fill.seed", 1, 0));
  co.clearance = s.non_negative("fill.clearance", co.clearance);
  // The fill region: a box (fill.min_m, fill.max_m), or in a [cylinder] without them the
  // cylinder itself from the floor to fill.height_m (default: the cylinder's height),
  // around the vane when there is one (an annulus outside vane.radius_m).
  const bool cylinder_fill = b.cylinder && !s.has("fill.min_m") && !s.has("fill.max_m");
  if (s.has("fill.height_m") && !cylinder_fill)
    s.fail("fill.height_m", "only applies to a [cylinder] fill without fill.min_m and fill.max_m");
  if (cylinder_fill) {
    CylinderRegion c;
    c.cx = b.cyl_cx;
    c.cy = b.cyl_cy;
    c.radius = b.cyl_radius;
    c.z0 = b.floor_top;
    c.z1 = s.positive("fill.height_m", b.cyl_height);
    if (!(c.z1 > c.z0)) s.fail("fill.height_m", fmt::format("{} m: expected above the rough floor's top {} m", c.z1, c.z0));
    c.sectors = b.sectors;
    c.sector_start = sector_start(b.sectors);
    if (!b.vane.empty()) {
      if (std::hypot(b.vane_centre.x() - b.cyl_cx, b.vane_centre.y() - b.cyl_cy) > 1e-12 * b.cyl_radius)
        s.fail("vane.centre_m", "a cylinder fill around a vane needs the vane on the cylinder's axis");
      c.inner_radius = s.num("vane.radius_m", 0.0);
      if (!(c.radius - c.inner_radius >= b.diameter))
        s.fail("vane.radius_m", fmt::format("{} m leaves less than a bead diameter to the cylinder wall at {} m",
                                            c.inner_radius, c.radius));
    }
    b.fill_region = c;
  } else {
    if (b.sectors != 0) s.fail("fill.min_m", "a periodic sector (cylinder.sectors) is filled by the cylinder fill");
    b.fill_region = read_box(s, "fill.min_m", "fill.max_m");
    const BoxRegion& fb = std::get<BoxRegion>(b.fill_region);
    const Vec3 &flo = fb.lo, &fhi = fb.hi;
    // The chains must start inside the container: a bead placed through a half-space wall
    // would start deep in overlap and stop the run at its first step.
    if (b.box) {
      const bool inside = flo.x() >= b.box->lo.x() && flo.y() >= b.box->lo.y() && flo.z() >= b.box->lo.z() &&
                          fhi.x() <= b.box->hi.x() && fhi.y() <= b.box->hi.y() &&
                          (!b.lid || fhi.z() <= b.box->hi.z());
      if (!inside) s.fail("fill.max_m", "the fill region must lie inside the box (below its lid, if any)");
    } else if (b.cylinder) {
      const double rx = std::max(std::abs(flo.x() - b.cyl_cx), std::abs(fhi.x() - b.cyl_cx));
      const double ry = std::max(std::abs(flo.y() - b.cyl_cy), std::abs(fhi.y() - b.cyl_cy));
      if (std::hypot(rx, ry) > b.cyl_radius || flo.z() < 0.0)
        s.fail("fill.max_m", fmt::format("the fill region must lie inside the cylinder (radius {} m, floor z = 0)",
                                         b.cyl_radius));
    }
  }

  b.settle = s.flag("fill.settle", false);
  if (!b.settle) {
    for (const std::string& k : kSettleKeys)
      if (s.has(k)) s.fail(k, "only applies with fill.settle = true");
  }
  FillOptions& fo = b.settle_options;
  fo.insert_fraction = s.num("fill.insert_fraction", fo.insert_fraction);
  if (!(fo.insert_fraction > 0.0) || fo.insert_fraction > 0.35)
    s.fail("fill.insert_fraction", fmt::format("{} (expected in (0, 0.35])", fo.insert_fraction));
  // fill places the chains in the fill box raised until they fill insert_fraction of
  // it (builder.hpp, "Fill"); without settle they go into the box itself.
  Region placed = b.fill_region;
  if (b.settle) {
    const double d = b.diameter;
    const double beads = static_cast<double>(co.chains) * co.beads_per_chain;
    const double column = beads * std::numbers::pi * d * d * d / 6.0;
    if (auto* pb = std::get_if<BoxRegion>(&placed)) {
      const double area = (pb->hi.x() - pb->lo.x()) * (pb->hi.y() - pb->lo.y());
      pb->hi.z() = std::max(pb->hi.z(), pb->lo.z() + column / (fo.insert_fraction * area) + d);
    } else {
      auto& pc = std::get<CylinderRegion>(placed);
      const double area = std::numbers::pi * (pc.radius * pc.radius - pc.inner_radius * pc.inner_radius) /
                          (pc.sectors != 0 ? pc.sectors : 1);
      pc.z1 = std::max(pc.z1, pc.z0 + column / (fo.insert_fraction * area) + d);
    }
  }
  const double placed_top = std::holds_alternative<BoxRegion>(placed) ? std::get<BoxRegion>(placed).hi.z()
                                                                      : std::get<CylinderRegion>(placed).z1;
  // Placement sees none of the scene's other beads: one in the way would start in deep
  // overlap with a chain bead.
  auto reaches_in = [&](const Vec3& x) {
    if (const auto* pb = std::get_if<BoxRegion>(&placed)) {
      const Vec3 nearest = x.cwiseMax(pb->lo).cwiseMin(pb->hi);
      return (x - nearest).norm() < 0.5 * b.diameter;
    }
    const auto& pc = std::get<CylinderRegion>(placed);
    const double rho = std::hypot(x.x() - pc.cx, x.y() - pc.cy), r = 0.5 * b.diameter;
    return x.z() > pc.z0 - r && x.z() < pc.z1 + r && rho < pc.radius + r && rho > pc.inner_radius - r;
  };
  auto check_clear = [&](const std::vector<Vec3>& beads, const char* key) {
    for (std::size_t k = 0; k < beads.size(); ++k)
      if (reaches_in(beads[k]))
        s.fail(key, fmt::format("bead {} at ({}, {}, {}) reaches into the {} region (z up to {:.6g} m), where "
                                "the chains are placed without seeing it",
                                k, beads[k].x(), beads[k].y(), beads[k].z(), b.settle ? "drop" : "fill",
                                placed_top));
  };
  check_clear(b.fixed, "beads.fixed_positions_m");
  check_clear(b.kinematic, "beads.kinematic_positions_m");
  if (!b.settle) {
    check_clear(b.mobile, "beads.positions_m");
    return b;
  }
  if (!b.box && !b.cylinder && b.fixed.empty() && b.kinematic.empty())
    s.fail("fill.settle", "needs a container ([box], [cylinder] or fixed beads) to settle into");
  fo.chains = co;
  fo.region = b.fill_region;
  fo.wall_friction = b.box_friction;  // unused: the container callback adds the walls
  fo.settle_tolerance = s.positive("fill.settle_tolerance", fo.settle_tolerance);
  fo.settle_max_iterations =
      static_cast<int>(s.integer("fill.settle_max_iterations", fo.settle_max_iterations, 1, kMaxSweeps));
  fo.settle_max_steps = s.integer("fill.settle_max_steps", fo.settle_max_steps, 1, kMaxFillSteps);
  fo.settle_kinetic_energy = s.positive("fill.settle_kinetic_energy", fo.settle_kinetic_energy);
  fo.relax_kinetic_energy = s.positive("fill.relax_kinetic_energy", fo.relax_kinetic_energy);
  fo.relax_max_steps = s.integer("fill.relax_max_steps", fo.relax_max_steps, 0, kMaxFillSteps);
  fo.plateau_ratio = s.within("fill.plateau_ratio", fo.plateau_ratio, 0.0, 1.0);
  // Under a lid the drop column must fit, or beads would start above the lid.
  if (b.lid && placed_top > b.box->hi.z())
    s.fail("fill.settle", fmt::format("the drop column reaches z = {:.6g} m, above the lid at {:.6g} m (raise "
                                      "box.max_m, raise fill.insert_fraction or set box.lid = false)",
                                      placed_top, b.box->hi.z()));
  return b;
}

/// Adds the container (walls, cylinder beads, fixed beads, kinematic beads) to `w`; the
/// kinematic beads get their prescribed velocities only if `moving` (fill's drop and
/// relaxation worlds keep them still).
void add_container(World& w, const SceneBodies& b, bool moving) {
  if (b.box) {
    add_box_walls(w, *b.box, b.box_friction);
    if (b.lid) w.add_wall(Wall{Vec3(b.box->lo.x(), b.box->lo.y(), b.box->hi.z()), -Vec3::UnitZ(), b.box_friction});
  }
  if (b.cylinder) {
    const double dw = b.cyl_bead;
    w.add_wall(Wall{Vec3(b.cyl_cx, b.cyl_cy, 0.0), Vec3::UnitZ(), b.cyl_floor_friction});
    if (b.rough_floor) {
      // Touching fixed beads on a triangular lattice, centres on the floor plane up to
      // the wall beads' inner surface (so no hole a bead could reach the plane through
      // is left at the rim; fixed beads may overlap): a rough floor.
      const double row = dw * std::sqrt(3.0) / 2.0, rmax = b.cyl_radius;
      const int rows = static_cast<int>(std::floor(rmax / row));
      for (int j = -rows; j <= rows; ++j) {
        const double y = j * row, off = (j % 2 != 0) ? 0.5 * dw : 0.0;
        const int cols = static_cast<int>(std::floor(rmax / dw)) + 1;
        for (int i = -cols; i <= cols; ++i) {
          const double x = i * dw + off;
          const Vec3 p(b.cyl_cx + x, b.cyl_cy + y, 0.0);
          if (std::hypot(x, y) <= rmax && sector_contains(w.options(), p)) w.add_sphere(p, dw, b.density, BodyKind::kFixed);
        }
      }
    }
    const double rc = b.cyl_radius + 0.5 * dw;  // bead centres: the beads' inner surface at r
    auto per_ring = static_cast<int>(std::ceil(2.0 * std::numbers::pi * rc / dw));
    // A periodic sector: a whole number of wall beads per wedge, a quarter step off its
    // sides (so each ring bead has exactly one image in the wedge).
    const int k = b.sectors;
    if (k != 0) per_ring = (per_ring + k - 1) / k * k;
    const double offset = k != 0 ? 0.25 : 0.0;
    for (int layer = 0; (0.5 + layer) * dw <= b.cyl_height; ++layer)
      for (int m = 0; m < per_ring; ++m) {
        const double a = 2.0 * std::numbers::pi * (m + offset + 0.5 * (layer % 2)) / per_ring;
        const Vec3 p(b.cyl_cx + rc * std::cos(a), b.cyl_cy + rc * std::sin(a), (0.5 + layer) * dw);
        if (sector_contains(w.options(), p)) w.add_sphere(p, dw, b.density, BodyKind::kFixed);
      }
  }
  for (const Vec3& x : b.fixed) w.add_sphere(x, b.diameter, b.density, BodyKind::kFixed);
  for (const Vec3& x : b.kinematic) {
    const int id = w.add_sphere(x, b.diameter, b.density, BodyKind::kKinematic);
    if (moving) {
      w.set_velocity(id, b.kinematic_velocity);
      w.set_angular_velocity(id, b.kinematic_omega);
    }
  }
  // The vane's beads: kinematic, at rest until the rotor is added to the run's world (in
  // a periodic sector, the hub and the wedge's blade).
  for (const Vec3& x : b.vane)
    if (sector_contains(w.options(), x)) w.add_sphere(x, b.diameter, b.density, BodyKind::kKinematic);
}

/// The vane of a built world: its beads are the container's last kinematic bodies.
void add_vane_rotor(World& w, const SceneBodies& b, int container_bodies) {
  if (b.vane.empty()) return;
  std::vector<int> ids;
  int beads = 0;
  for (const Vec3& x : b.vane) beads += sector_contains(w.options(), x) ? 1 : 0;
  const int first = container_bodies - beads;
  for (int k = 0; k < beads; ++k) ids.push_back(first + k);
  w.add_rotor(ids, b.vane_centre, Vec3::UnitZ(), b.vane_phi0, b.vane_f, b.vane_phase, 0.0);
}

/// The world's options, bodies and camera of a scene, every cross-section rule checked
/// (the drive resolved by the time step, the sector's limits, the camera's frame).
void read_world(const Scene& s, ResolvedScene& spec) {
  const std::optional<SceneProtocol>& protocol = spec.protocol;
  Options& opt = spec.options;
  opt = read_options(s);
  SceneBodies& b = spec.bodies;
  b = read_bodies(s);
  if (b.sectors != 0) {  // the periodic wedge of the cup (World: "Periodic sector")
    opt.sectors = b.sectors;
    opt.sector_centre = Vec3(b.cyl_cx, b.cyl_cy, 0.0);
    opt.sector_start = sector_start(b.sectors);
    auto outside = [&](const std::vector<Vec3>& beads, const char* key) {
      for (std::size_t k = 0; k < beads.size(); ++k)
        if (!sector_contains(opt, beads[k]))
          s.fail(key, fmt::format("bead {} at ({}, {}, {}) lies outside the periodic sector (azimuth in [{:.6g}, "
                                  "{:.6g}) rad about the cylinder's axis)",
                                  k, beads[k].x(), beads[k].y(), beads[k].z(), opt.sector_start,
                                  opt.sector_start + 2.0 * std::numbers::pi / b.sectors));
    };
    outside(b.fixed, "beads.fixed_positions_m");
    outside(b.kinematic, "beads.kinematic_positions_m");
    outside(b.mobile, "beads.positions_m");
  }
  if (protocol) {  // the pre-shear drives the vane; the branches restart from its checkpoint
    b.vane_phi0 = protocol->preshear_phi0_rad;
    b.vane_f = protocol->preshear_f_Hz;
    b.vane_phase = 0.0;
    b.vane_stop_change = protocol->stop_change;
  }
  // Every drive resolved by the time step (kMinStepsPerDrivePeriod).
  auto resolved = [&](double f, const char* key) {
    if (f > 0 && f * opt.time_step > 1.0 / kMinStepsPerDrivePeriod)
      s.fail(key, fmt::format("{} Hz with sim.time_step_s = {} s: {:.3g} steps per period; expected at least {} "
                              "(f <= {:.4g} Hz), or the vane is sampled at an alias",
                              f, opt.time_step, 1.0 / (f * opt.time_step), kMinStepsPerDrivePeriod,
                              1.0 / (kMinStepsPerDrivePeriod * opt.time_step)));
  };
  resolved(b.vane_f, protocol ? "protocol.preshear_f_Hz" : "vane.f_Hz");
  if (protocol) {
    resolved(protocol->f_Hz, "protocol.f_Hz");
    // A branch's length is known here: refused before the pre-shear runs, not after.
    const double branch_steps = protocol->cycles / protocol->f_Hz / opt.time_step;
    if (!(branch_steps <= kMaxRunSteps))
      s.fail("protocol.cycles", fmt::format("{} cycles at {} Hz over sim.time_step_s = {} s is {:.3g} steps per "
                                            "branch; expected at most {:.0e}",
                                            protocol->cycles, protocol->f_Hz, opt.time_step, branch_steps,
                                            kMaxRunSteps));
  }
  if (protocol && b.sectors != 0) {  // every drive keeps the blade inside its wedge
    const double limit = std::numbers::pi / b.sectors;
    if (!(protocol->preshear_phi0_rad < limit))
      s.fail("protocol.preshear_phi0_rad", fmt::format("{} rad: the blade would leave its sector (expected < pi/{})",
                                                       protocol->preshear_phi0_rad, b.sectors));
    for (const double a : protocol->phi0_rad)
      if (!(a < limit))
        s.fail("protocol.phi0_rad", fmt::format("{} rad: the blade would leave its sector (expected < pi/{})", a,
                                                b.sectors));
  }
  // fill raises the drop column along +z: the beads must fall down it.
  if (b.settle && !(opt.gravity.z() < 0.0))
    s.fail("fill.settle", "needs gravity with a downward (negative z) component (sim.gravity_m_per_s2)");
  if (s.has("camera.fps") || s.has("camera.m_per_px") || s.has("camera.spacing_px") || s.has("camera.frames")) {
    if (!b.cylinder) s.fail_file("[camera] looks down into a [cylinder] (give the cup as [cylinder])");
    SceneCamera& c = spec.camera.emplace();
    c.fps = s.positive("camera.fps", 25.0);
    if (!(c.fps <= 1e4)) s.fail("camera.fps", "expected 0 < fps <= 1e4");
    if (!(1.0 / c.fps >= opt.time_step * (1 - 1e-9)))
      s.fail("camera.fps", fmt::format("{} frames per second: a frame is shorter than the time step {} s", c.fps,
                                       opt.time_step));
    SurfaceCameraOptions& co = c.options;
    co.m_per_px = s.positive("camera.m_per_px", b.diameter > 0 ? b.diameter / 10.0 : 1e-4);
    co.spacing_px = s.positive("camera.spacing_px", 8.0);
    if (!(co.spacing_px >= 1 && co.spacing_px <= 1024)) s.fail("camera.spacing_px", "expected 1..1024 px");
    const double half_px = std::ceil((b.cyl_radius + b.cyl_bead) / co.m_per_px);
    if (!(2 * half_px <= 65536)) s.fail("camera.m_per_px", "the image of the cup would exceed 65536 px");
    co.width_px = co.height_px = static_cast<int>(2 * half_px);
    co.centre_x_px = co.centre_y_px = half_px - 0.5;
    co.cx_m = b.cyl_cx;
    co.cy_m = b.cyl_cy;
    co.cup_radius_m = b.cyl_radius;
    co.vane_radius_m = b.vane.empty() ? 0.0 : s.num("vane.radius_m", 0.0);
    c.frames = s.flag("camera.frames", true);
    c.bead_diameter_m = b.diameter;
    c.cup_height_m = b.cyl_height;
    c.vane_blades = b.vane.empty() ? 0 : static_cast<int>(s.integer("vane.blades", 4, 1, 64));
    c.vane_height_m = b.vane.empty() ? 0.0 : s.num("vane.height_m", 0.0);
  }
}


LoadedScene build_resolved(const ResolvedScene& spec, bool check_only, const FillProgress& progress) {
  const Options& opt = spec.options;
  const SceneBodies& b = spec.bodies;
  LoadedScene out;
  out.protocol = spec.protocol;
  out.camera = spec.camera;
  out.cadence = spec.cadence;
  out.torque_every_rad = b.vane_torque_every;
  out.stop_change = b.vane_stop_change;
  out.vane = !b.vane.empty();
  out.vane_f_Hz = b.vane_f;
  out.beads_per_chain = b.chains.beads_per_chain;
  out.bead_diameter_m = b.diameter;
  out.mobile_beads = static_cast<std::int64_t>(b.mobile.size()) +
                     (b.fill ? std::int64_t{b.chains.chains} * b.chains.beads_per_chain : 0);
  World container(opt);
  add_container(container, b, true);
  // Every container body is a chain of its own; then the explicit chains, then the fill.
  std::int64_t next_chain = 0;
  for (int k = 0; k < container.body_count(); ++k) out.chain_ids.push_back(next_chain++);
  if (b.fill) {
    validate(b.fill_region);
    validate(b.chains);
    if (b.settle) validate(b.settle_options);
  }
  if (check_only) {
    out.world.emplace(std::move(container));
    return out;
  }

  if (b.settle) {
    const auto t0 = std::chrono::steady_clock::now();
    FillOptions fo = b.settle_options;
    fo.drop_progress = progress.drop;
    fo.relax_progress = progress.relax;
    FillResult r = fill(opt, fo, [&b](World& w) { add_container(w, b, false); });
    out.fill.settled = true;
    out.fill.settle_plateau = r.settle_plateau;
    out.fill.settle_steps = r.settle_steps;
    out.fill.relax_steps = r.relax_steps;
    out.fill.settle_cap_hits = r.settle_cap_hits;
    out.fill.kinetic_energy = r.kinetic_energy;
    out.fill.relaxed = r.relaxed;
    out.fill.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The run starts from the relaxed packing at step 0 and t = 0, with the relaxation's
    // last impulses as its warm start; the kinematic beads start moving now.
    WorldState st = r.world.state();
    st.step = 0;
    st.iteration_cap_hits = 0;
    out.world.emplace(World::from_state(st));
    for (int k = 0; k < out.world->body_count(); ++k)
      if (out.world->kind(k) == BodyKind::kKinematic) {
        out.world->set_velocity(k, b.kinematic_velocity);
        out.world->set_angular_velocity(k, b.kinematic_omega);
      }
    add_vane_rotor(*out.world, b, container.body_count());
    for (const int c : r.chain_of_bead) out.chain_ids.push_back(next_chain + c);
    return out;
  }

  const int container_bodies = container.body_count();
  out.world.emplace(std::move(container));
  World& w = *out.world;
  add_vane_rotor(w, b, container_bodies);
  const auto n = static_cast<std::size_t>(b.chains.beads_per_chain);
  for (std::size_t c = 0; c < b.mobile.size() / n; ++c) {
    std::vector<int> ids;
    for (std::size_t k = 0; k < n; ++k) {
      ids.push_back(w.add_sphere(b.mobile[c * n + k], b.diameter, b.density));
      out.chain_ids.push_back(next_chain);
    }
    ++next_chain;
    if (n > 1) w.add_chain(ids, b.diameter + b.chains.l_max, b.chains.theta_max);
  }
  if (b.fill) {
    const ChainPlacement p = place_chains(b.fill_region, b.chains);
    add_chains(w, p, b.chains);
    for (const int c : p.chain_of_bead) out.chain_ids.push_back(next_chain + c);
  }
  return out;
}


/// A fresh scene must not start with overlapping beads: the solver would push them
/// apart in one step (a bead leaving at metres per second) and report nothing.
/// Pairs of fixed beads (walls) may touch. Throws InputError naming the first bead
/// (in body order) that overlaps another by more than sim.max_overlap x d.
void refuse_initial_overlaps(const World& w, const std::string& scene) {
  const int n = w.body_count();
  if (n < 2) return;
  double dmax = 0;
  for (int k = 0; k < n; ++k) dmax = std::max(dmax, w.diameter(k));
  const double cell = dmax;
  auto key = [&](const Vec3& x, int dx, int dy, int dz) {
    const auto c = [&](double v, int d) { return static_cast<std::int64_t>(std::floor(v / cell)) + d; };
    return std::array<std::int64_t, 3>{c(x.x(), dx), c(x.y(), dy), c(x.z(), dz)};
  };
  std::map<std::array<std::int64_t, 3>, std::vector<int>> grid;
  for (int k = 0; k < n; ++k) grid[key(w.position(k), 0, 0, 0)].push_back(k);
  const double limit = w.options().max_overlap;
  for (int k = 0; k < n; ++k) {
    int worst = -1;
    double worst_rel = limit;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find(key(w.position(k), dx, dy, dz));
          if (it == grid.end()) continue;
          for (int j : it->second) {
            if (j <= k || (w.kind(k) == BodyKind::kFixed && w.kind(j) == BodyKind::kFixed)) continue;
            const double overlap = 0.5 * (w.diameter(k) + w.diameter(j)) - (w.position(k) - w.position(j)).norm();
            const double rel = overlap / std::min(w.diameter(k), w.diameter(j));
            if (rel > worst_rel) {
              worst_rel = rel;
              worst = j;
            }
          }
        }
    if (worst >= 0)
      throw InputError(fmt::format(
          "{}: beads {} and {} overlap by {:.4g} d at the start (centres {:.6g} m apart, diameters {} "
          "and {} m); expected at most sim.max_overlap = {} d: move them apart",
          scene, k, worst, worst_rel, (w.position(k) - w.position(worst)).norm(),
          io::format_number(w.diameter(k)), io::format_number(w.diameter(worst)),
          io::format_number(limit)));
  }
}

}  // namespace

std::string SceneProtocol::branch_folder(double phi0_rad) {
  const std::string three = fmt::format("{:.3f}", phi0_rad);
  // Three decimals when they hold the value (0.300), else its shortest exact form.
  return "phi0_" + (std::stod(three) == phi0_rad ? three : fmt::format("{}", phi0_rad));
}

void validate_branch(int sectors, double time_step, double start_time_s, double phi0_rad, double f_Hz,
                     double cycles) {
  if (sectors != 0 && !(std::abs(phi0_rad) < std::numbers::pi / sectors))
    throw ConfigError(fmt::format("--phi0 {} rad: the blade would leave the checkpoint's periodic sector of 1/{} "
                                  "(expected |phi0| < pi/{})",
                                  phi0_rad, sectors, sectors));
  if (!(std::abs(phi0_rad) <= 100.0)) throw ConfigError(fmt::format("--phi0 {}: expected |phi0| <= 100 rad", phi0_rad));
  if (!(f_Hz > 0 && f_Hz <= 1000.0)) throw ConfigError(fmt::format("--f-hz {}: expected 0 < f <= 1000 Hz", f_Hz));
  if (f_Hz * time_step > 1.0 / kMinStepsPerDrivePeriod)
    throw ConfigError(fmt::format("--f-hz {}: {:.3g} time steps of {} s per period; expected at least {} (f <= {:.4g} "
                                  "Hz), or the vane is sampled at an alias",
                                  f_Hz, 1.0 / (f_Hz * time_step), io::format_number(time_step),
                                  kMinStepsPerDrivePeriod, 1.0 / (kMinStepsPerDrivePeriod * time_step)));
  if (!(cycles > 0 && cycles <= 1e6)) throw ConfigError(fmt::format("--cycles {}: expected 0 < cycles <= 1e6", cycles));
  const double steps = (start_time_s + cycles / f_Hz) / time_step;
  if (!(steps <= kMaxRunSteps))
    throw ConfigError(fmt::format("--cycles {} at --f-hz {} over the time step {} s is {:.3g} steps; expected at "
                                  "most {:.0e} (fewer cycles or a higher frequency)",
                                  io::format_number(cycles), io::format_number(f_Hz), io::format_number(time_step),
                                  steps, kMaxRunSteps));
}

void check_checkpoint_matches(const LoadedScene& scene, const WorldState& ck, const std::filesystem::path& scene_path,
                              const std::filesystem::path& checkpoint_path) {
  const World& c = *scene.world;  // the container alone (check_only)
  auto refuse = [&](const std::string& what) {
    throw InputError(fmt::format("{}: not a checkpoint of {}: {}; restart from a checkpoint of this scene",
                                 checkpoint_path.string(), scene_path.string(), what));
  };
  auto num = [](double v) { return io::format_number(v); };
  // Lengths compared to 1e-9 of the bead diameter (a checkpoint stores doubles exactly).
  const double tol = 1e-9 * std::max(scene.bead_diameter_m, 1e-9);
  auto same = [&](const Vec3& a, const Vec3& b) { return (a - b).norm() <= tol; };
  auto xyz = [](const Vec3& v) { return fmt::format("({:.6g}, {:.6g}, {:.6g}) m", v.x(), v.y(), v.z()); };
  if (ck.options.sectors != c.options().sectors)
    refuse(fmt::format("the scene's cylinder.sectors is {}, the checkpoint's {}", c.options().sectors,
                       ck.options.sectors));
  if (ck.walls.size() != c.walls().size())
    refuse(fmt::format("the scene has {} walls, the checkpoint {}", c.walls().size(), ck.walls.size()));
  for (std::size_t k = 0; k < ck.walls.size(); ++k) {
    const Wall &a = c.walls()[k], &b = ck.walls[k];
    if (!same(a.normal * a.normal.dot(a.point), b.normal * b.normal.dot(b.point)) || !same(a.normal, b.normal))
      refuse(fmt::format("wall {} differs (the scene's through {} with normal {}, the checkpoint's through {} with "
                         "normal {})",
                         k, xyz(a.point), xyz(a.normal), xyz(b.point), xyz(b.normal)));
  }
  const int nc = c.body_count();
  const auto n = static_cast<std::int64_t>(ck.position.size());
  if (n < nc) refuse(fmt::format("the scene's cup and vane are {} beads, the checkpoint holds {} bodies", nc, n));
  int fixed = 0, kinematic = 0;
  for (int k = 0; k < nc; ++k) {
    fixed += c.kind(k) == BodyKind::kFixed ? 1 : 0;
    kinematic += c.kind(k) == BodyKind::kKinematic ? 1 : 0;
  }
  for (int k = 0; k < nc; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    if (ck.kind[kk] != c.kind(k))
      refuse(fmt::format("the scene's cup and vane are {} fixed and {} moving beads; body {} of the checkpoint is "
                         "not one of them",
                         fixed, kinematic, k));
    if (std::abs(ck.diameter[kk] - c.diameter(k)) > tol)
      refuse(fmt::format("body {} (the cup or vane) has diameter {} m in the scene, {} m in the checkpoint", k,
                         num(c.diameter(k)), num(ck.diameter[kk])));
    if (c.kind(k) == BodyKind::kFixed && !same(ck.position[kk], c.position(k)))
      refuse(fmt::format("fixed bead {} (the cup) lies at {} in the scene, {} in the checkpoint", k,
                         xyz(c.position(k)), xyz(ck.position[kk])));
  }
  if (ck.rotors.size() != (scene.vane ? 1U : 0U))
    refuse(fmt::format("the scene has {} vane, the checkpoint {}", scene.vane ? "a" : "no",
                       ck.rotors.empty() ? "none" : "one"));
  if (scene.vane) {  // the vane's beads at phi = 0 where the scene puts them
    const Rotor& r = ck.rotors[0];
    for (std::size_t j = 0; j < r.bodies.size(); ++j) {
      const int k = r.bodies[j];
      if (k < 0 || k >= nc || c.kind(k) != BodyKind::kKinematic || !same(r.reference[j], c.position(k)))
        refuse(fmt::format("the vane's bead {} lies at {} at phi = 0 in the checkpoint, not where the scene's vane "
                           "puts it",
                           j, xyz(r.reference[j])));
    }
  }
  std::int64_t mobile = 0;
  for (std::int64_t k = nc; k < n; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    if (ck.kind[kk] != BodyKind::kMobile)
      refuse(fmt::format("body {} of the checkpoint is a {} bead beyond the scene's cup and vane", k,
                         ck.kind[kk] == BodyKind::kFixed ? "fixed" : "moving"));
    if (std::abs(ck.diameter[kk] - scene.bead_diameter_m) > tol)
      refuse(fmt::format("the scene's beads are {} m across (beads.diameter_m), the checkpoint's bead {} {} m",
                         num(scene.bead_diameter_m), k, num(ck.diameter[kk])));
    ++mobile;
  }
  if (mobile != scene.mobile_beads)
    refuse(fmt::format("the scene has {} beads (beads.positions_m, fill.count x chains.beads_per_chain), the "
                       "checkpoint {}",
                       scene.mobile_beads, mobile));
}

namespace {

/// The spec's keys: one list (SceneSpec::for_each_key) for the reader, the writer and the
/// file's known keys.
std::vector<std::string> scene_keys() {
  std::vector<std::string> keys;
  SceneSpec spec;
  SceneSpec::for_each_key(spec, [&keys](const char* name, const auto&) { keys.emplace_back(name); });
  return keys;
}

}  // namespace

SceneSpec read_scene(const std::filesystem::path& path) {
  const io::TomlConfig t = io::TomlConfig::load(path);
  t.require_known(scene_keys());
  SceneSpec spec;
  spec.source = t.source();
  SceneSpec::for_each_key(spec, [&](const char* name, auto& key) {
    if (!t.has(name)) return;
    using T = typename std::decay_t<decltype(key)>::value_type;
    if constexpr (std::is_same_v<T, double>) key = t.get_double(name);
    else if constexpr (std::is_same_v<T, std::int64_t>) key = t.get_int(name);
    else if constexpr (std::is_same_v<T, bool>) key = t.get_bool(name);
    else if constexpr (std::is_same_v<T, std::string>) key = t.get_string(name);
    else key = t.get_doubles(name);
    spec.lines[name] = t.line(name);
  });
  return spec;
}

void write_scene(const SceneSpec& spec, std::ostream& out, const std::string& comment) {
  out << comment;
  std::string section;
  SceneSpec::for_each_key(spec, [&](const char* name, const auto& key) {
    if (!key) return;
    const std::string_view n(name);
    const std::string_view sec = n.substr(0, n.find('.'));
    if (sec != section) {
      out << (section.empty() ? "[" : "\n[") << sec << "]\n";
      section = sec;
    }
    out << n.substr(sec.size() + 1) << " = ";
    using T = typename std::decay_t<decltype(key)>::value_type;
    if constexpr (std::is_same_v<T, double>) out << io::format_number(*key);
    else if constexpr (std::is_same_v<T, std::int64_t>) out << *key;
    else if constexpr (std::is_same_v<T, bool>) out << (*key ? "true" : "false");
    else if constexpr (std::is_same_v<T, std::string>) out << io::json_string(*key);  // TOML's basic-string escapes
    else {
      // Long lists (bead positions) three numbers to a line: a file's lines stay short.
      const std::vector<double>& v = *key;
      const bool lines = v.size() > 3;
      out << '[';
      for (std::size_t k = 0; k < v.size(); ++k) {
        if (lines && k % 3 == 0) out << "\n  ";
        out << io::format_number(v[k]);
        if (k + 1 < v.size()) out << (lines && (k + 1) % 3 == 0 ? "," : ", ");
      }
      out << (lines ? ",\n]" : "]");
    }
    out << '\n';
  });
}

LoadedScene build_scene(const SceneSpec& spec, bool check_only, const FillProgress& progress) {
  const Scene s(spec);
  ResolvedScene r;
  r.protocol = read_protocol(s);
  r.cadence = read_cadence(s, r.protocol);
  read_world(s, r);
  LoadedScene out = build_resolved(r, check_only, progress);
  if (!check_only) refuse_initial_overlaps(*out.world, spec.source);
  return out;
}

LoadedScene load_scene(const std::filesystem::path& path, bool check_only, const FillProgress& progress) {
  return build_scene(read_scene(path), check_only, progress);
}

}  // namespace shearzone::sim
