// Chain builder, fill and packing measurement (see shearzone/sim/builder.hpp).
#include "shearzone/sim/builder.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <string>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "sector.hpp"

namespace shearzone::sim {

namespace {

constexpr double kPi = std::numbers::pi;
/// Dead-end backtracks allowed per bead of a chain before the chain restarts.
constexpr int kBacktracksPerBead = 4;

[[noreturn]] void bad_option(const std::string& name, double value, const char* expected) {
  throw ConfigError(fmt::format("sim builder option {}: {} (expected {})", name, value, expected));
}

bool finite(const Vec3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

/// Uniform double in [0, 1) from the top 53 bits (portable, unlike std::uniform_real_distribution).
double u01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11U) * 0x1.0p-53; }

/// Bead centre wholly inside the region (bead radius r). A wedge's sides do not bound it:
/// place_chains grows chains across a periodic wedge's sides and wraps each bead inside.
bool inside(const Region& region, const Vec3& x, double r) {
  if (const auto* b = std::get_if<BoxRegion>(&region)) {
    for (int k = 0; k < 3; ++k)
      if (x[k] < b->lo[k] + r || x[k] > b->hi[k] - r) return false;
    return true;
  }
  const auto& c = std::get<CylinderRegion>(region);
  const double dx = x.x() - c.cx, dy = x.y() - c.cy;
  const double rho = std::sqrt(dx * dx + dy * dy);
  return x.z() >= c.z0 + r && x.z() <= c.z1 - r && rho <= c.radius - r &&
         (c.inner_radius <= 0.0 || rho >= c.inner_radius + r);
}

Vec3 random_centre(const Region& region, double r, std::mt19937_64& rng) {
  if (const auto* b = std::get_if<BoxRegion>(&region)) {
    Vec3 x;
    for (int k = 0; k < 3; ++k) x[k] = b->lo[k] + r + u01(rng) * (b->hi[k] - b->lo[k] - 2.0 * r);
    return x;
  }
  const auto& c = std::get<CylinderRegion>(region);
  // Uniform in area between the inner and outer radii the centre may take.
  const double ro = c.radius - r, ri = c.inner_radius > 0.0 ? std::min(ro, c.inner_radius + r) : 0.0;
  const double wedge = c.sectors != 0 ? 2.0 * kPi / c.sectors : 2.0 * kPi;
  const double rho = std::sqrt(ri * ri + (ro * ro - ri * ri) * u01(rng));
  const double phi = c.sectors != 0 ? c.sector_start + wedge * u01(rng) : 2.0 * kPi * u01(rng);
  const double z = c.z0 + r + u01(rng) * (c.z1 - c.z0 - 2.0 * r);
  return {c.cx + rho * std::cos(phi), c.cy + rho * std::sin(phi), z};
}

/// Unit vector uniform on the cap of half-angle theta_max around the unit vector u.
Vec3 random_direction(const Vec3& u, double theta_max, std::mt19937_64& rng) {
  const double cos_min = theta_max >= kPi ? -1.0 : std::cos(theta_max);
  const double ct = 1.0 - u01(rng) * (1.0 - cos_min);
  const double st = std::sqrt(std::max(0.0, 1.0 - ct * ct));
  const double phi = 2.0 * kPi * u01(rng);
  const Vec3 a = std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 e1 = u.cross(a).normalized();
  const Vec3 e2 = u.cross(e1);
  return (ct * u + st * (std::cos(phi) * e1 + std::sin(phi) * e2)).normalized();
}

/// Uniform hash grid of bead centres for the placement overlap test.
class HashGrid {
 public:
  explicit HashGrid(double cell) : cell_(cell) {}
  void insert(int id, const Vec3& x) { cells_[key(x, 0, 0, 0)].push_back(id); }
  /// Removes the most recently inserted bead of its cell (chain restarts undo in reverse order).
  void remove_last(const Vec3& x) { cells_[key(x, 0, 0, 0)].pop_back(); }
  /// True if some bead other than `skip` lies closer than `dist` (≤ cell) to x.
  [[nodiscard]] bool near(const Vec3& x, double dist, const std::vector<Vec3>& pos, int skip) const {
    const double d2 = dist * dist;
    for (int i = -1; i <= 1; ++i)
      for (int j = -1; j <= 1; ++j)
        for (int k = -1; k <= 1; ++k) {
          const auto it = cells_.find(key(x, i, j, k));
          if (it == cells_.end()) continue;
          for (const int b : it->second)
            if (b != skip && (pos[static_cast<std::size_t>(b)] - x).squaredNorm() < d2) return true;
        }
    return false;
  }

 private:
  [[nodiscard]] std::uint64_t key(const Vec3& x, int di, int dj, int dk) const {
    auto c = [&](double v, int o) {
      return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v / cell_)) + o + (1 << 20)) &
             0x1fffffULL;
    };
    return c(x.x(), di) | (c(x.y(), dj) << 21U) | (c(x.z(), dk) << 42U);
  }
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<int>> cells_;
};

// ---- slice areas for the packing measurement ----

/// ∫ √(ρ² − x²) dx.
double chord_primitive(double x, double rho) {
  const double t = std::clamp(x / rho, -1.0, 1.0);
  return 0.5 * (x * std::sqrt(std::max(0.0, rho * rho - x * x)) + rho * rho * std::asin(t));
}

/// Area of the disc of radius rho at the origin with x ≥ a.
double disc_beyond(double a, double rho) {
  if (a <= -rho) return kPi * rho * rho;
  if (a >= rho) return 0.0;
  return 2.0 * (chord_primitive(rho, rho) - chord_primitive(a, rho));
}

/// Area of the disc of radius rho at the origin with x ≥ a and y ≥ b.
double disc_quadrant(double a, double b, double rho) {
  if (b < 0.0) return disc_beyond(a, rho) - disc_quadrant(a, -b, rho);
  if (b >= rho) return 0.0;
  const double c = std::sqrt(rho * rho - b * b);
  const double lo = std::max(a, -c);
  if (lo >= c) return 0.0;
  return chord_primitive(c, rho) - chord_primitive(lo, rho) - b * (c - lo);
}

/// Area of the disc (centre (px, py), radius rho) inside the rectangle [x0,x1]×[y0,y1].
double disc_rect(double px, double py, double rho, double x0, double x1, double y0, double y1) {
  if (rho <= 0.0) return 0.0;
  x0 -= px, x1 -= px, y0 -= py, y1 -= py;
  return disc_quadrant(x0, y0, rho) - disc_quadrant(x1, y0, rho) - disc_quadrant(x0, y1, rho) +
         disc_quadrant(x1, y1, rho);
}

/// Area of the intersection of discs of radii a and b whose centres are e apart.
double disc_disc(double a, double b, double e) {
  if (a <= 0.0 || b <= 0.0 || e >= a + b) return 0.0;
  if (e <= std::abs(a - b)) return kPi * std::min(a, b) * std::min(a, b);
  const double ca = std::clamp((e * e + a * a - b * b) / (2.0 * e * a), -1.0, 1.0);
  const double cb = std::clamp((e * e + b * b - a * a) / (2.0 * e * b), -1.0, 1.0);
  const double k = (-e + a + b) * (e + a - b) * (e - a + b) * (e + a + b);
  return a * a * std::acos(ca) + b * b * std::acos(cb) - 0.5 * std::sqrt(std::max(0.0, k));
}

// 8-point Gauss–Legendre on [−1, 1].
constexpr std::array<double, 4> kGlX{0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                     0.9602898564975363};
constexpr std::array<double, 4> kGlW{0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                     0.1012285362903763};
/// Panels per interval between kinks. With the cosine map below the slice area's
/// (z − z*)^{3/2} kink behaviour becomes smooth in s, and 16 × 8 nodes give < 1e-10.
constexpr int kPanels = 16;

/// ∫_a^b f(z) dz with z = a + (b − a)(1 − cos πs)/2, s ∈ [0, 1] (clusters nodes at both ends).
template <class F>
double integrate(F&& f, double a, double b) {
  if (!(b > a)) return 0.0;
  double sum = 0.0;
  const double hs = 1.0 / kPanels;
  for (int p = 0; p < kPanels; ++p) {
    const double mid = (p + 0.5) * hs;
    for (std::size_t q = 0; q < kGlX.size(); ++q)
      for (const double sgn : {-1.0, 1.0}) {
        const double s = mid + sgn * 0.5 * hs * kGlX[q];
        const double z = a + 0.5 * (b - a) * (1.0 - std::cos(kPi * s));
        const double dz = 0.5 * (b - a) * kPi * std::sin(kPi * s);
        sum += 0.5 * hs * kGlW[q] * f(z) * dz;
      }
  }
  return sum;
}

/// ∫ slice(z) dz over the sphere's z-range clipped to [z0, z1], split at the z where
/// the slice radius equals one of the `kinks` (horizontal distances).
template <class F>
double integrate_slices(const Vec3& c, double r, double z0, double z1, const std::vector<double>& kinks,
                        F&& slice) {
  const double lo = std::max(c.z() - r, z0), hi = std::min(c.z() + r, z1);
  if (!(hi > lo)) return 0.0;
  std::vector<double> cuts{lo, hi};
  for (const double k : kinks)
    if (k > 0.0 && k < r) {
      const double dz = std::sqrt(r * r - k * k);
      for (const double z : {c.z() - dz, c.z() + dz})
        if (z > lo && z < hi) cuts.push_back(z);
    }
  std::sort(cuts.begin(), cuts.end());
  auto f = [&](double z) {
    const double rho = std::sqrt(std::max(0.0, r * r - (z - c.z()) * (z - c.z())));
    return slice(rho);
  };
  double v = 0.0;
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i) v += integrate(f, cuts[i], cuts[i + 1]);
  return v;
}

double region_volume(const Region& region) {
  if (const auto* b = std::get_if<BoxRegion>(&region)) return (b->hi - b->lo).prod();
  const auto& c = std::get<CylinderRegion>(region);
  return kPi * (c.radius * c.radius - c.inner_radius * c.inner_radius) * (c.z1 - c.z0) /
         (c.sectors != 0 ? c.sectors : 1);
}

double gravity_magnitude(const Options& o) { return o.gravity.norm(); }

/// Σ ½ m v² over the given beads (J). Rotation is left out: this engine has no rolling or
/// torsional resistance, so a bead spinning about its contact normals never stops.
double translational_energy(const World& w, const std::vector<int>& beads) {
  double e = 0.0;
  for (const int b : beads) e += 0.5 * w.mass(b) * w.velocity(b).squaredNorm();
  return e;
}

}  // namespace

void validate(const ChainOptions& o) {
  if (o.chains < 1) bad_option("chains.chains", o.chains, ">= 1");
  if (o.beads_per_chain < 1) bad_option("chains.beads_per_chain", o.beads_per_chain, ">= 1");
  if (!(o.diameter > 0.0) || !std::isfinite(o.diameter)) bad_option("chains.diameter", o.diameter, "> 0");
  if (!(o.density > 0.0) || !std::isfinite(o.density)) bad_option("chains.density", o.density, "> 0");
  if (!(o.l_max >= 0.0) || !std::isfinite(o.l_max)) bad_option("chains.l_max", o.l_max, ">= 0");
  if (!(o.theta_max > 0.0) || o.theta_max > kPi) bad_option("chains.theta_max", o.theta_max, "in (0, pi]");
  if (!(o.clearance >= 0.0) || !std::isfinite(o.clearance)) bad_option("chains.clearance", o.clearance, ">= 0");
  if (o.max_attempts < 1) bad_option("chains.max_attempts", o.max_attempts, ">= 1");
  if (o.direction_tries < 1) bad_option("chains.direction_tries", o.direction_tries, ">= 1");
}

void validate(const Region& region) {
  if (const auto* b = std::get_if<BoxRegion>(&region)) {
    if (!finite(b->lo) || !finite(b->hi) || !((b->hi - b->lo).minCoeff() > 0.0))
      throw ConfigError("sim builder region: box with hi <= lo or a non-finite corner (expected lo < hi)");
    return;
  }
  const auto& c = std::get<CylinderRegion>(region);
  if (!std::isfinite(c.cx) || !std::isfinite(c.cy)) bad_option("region.cx/cy", c.cx, "finite");
  if (!(c.radius > 0.0) || !std::isfinite(c.radius)) bad_option("region.radius", c.radius, "> 0");
  if (!(c.z1 > c.z0) || !std::isfinite(c.z0) || !std::isfinite(c.z1)) bad_option("region.z1", c.z1, "> z0");
  if (!(c.inner_radius >= 0.0 && c.inner_radius < c.radius))
    bad_option("region.inner_radius", c.inner_radius, "in [0, radius)");
  if (c.sectors != 0 && (c.sectors < 3 || c.sectors > 64)) bad_option("region.sectors", c.sectors, "0 or in [3, 64]");
  if (!std::isfinite(c.sector_start)) bad_option("region.sector_start", c.sector_start, "finite");
}

ChainPlacement place_chains(const Region& region, const ChainOptions& o) {
  validate(o);
  validate(region);
  const double d = o.diameter, r = 0.5 * d;
  const bool room = std::holds_alternative<BoxRegion>(region)
                        ? (std::get<BoxRegion>(region).hi - std::get<BoxRegion>(region).lo).minCoeff() >= d
                        : std::get<CylinderRegion>(region).radius - std::get<CylinderRegion>(region).inner_radius >=
                                  (std::get<CylinderRegion>(region).inner_radius > 0.0 ? 2.0 * r : r) &&
                              std::get<CylinderRegion>(region).z1 - std::get<CylinderRegion>(region).z0 >= d;
  if (!room)
    throw ConfigError(fmt::format("sim builder region: smaller than one bead of diameter {}", d));
  const int n = o.beads_per_chain;
  const double min_dist = d * (1.0 + o.clearance);
  ChainPlacement out;
  out.beads_per_chain = n;
  const auto total = static_cast<std::size_t>(o.chains) * static_cast<std::size_t>(n);
  out.positions.reserve(total);
  out.chain_of_bead.reserve(total);
  std::mt19937_64 rng(o.seed);
  HashGrid grid(min_dist);
  // A periodic wedge (CylinderRegion::sectors): a chain grows across the sides as in the
  // whole cup, each bead kept as its image inside the wedge and tested against every image
  // of the beads placed, so no chain is folded to fit the wedge.
  const auto* cyl = std::get_if<CylinderRegion>(&region);
  const int images = cyl != nullptr && cyl->sectors != 0 ? cyl->sectors : 1;
  Options wedge_options;
  if (images > 1) {
    wedge_options.sectors = images;
    wedge_options.sector_centre = Vec3(cyl->cx, cyl->cy, 0.0);
    wedge_options.sector_start = cyl->sector_start;
  }
  const detail::Sector sector(wedge_options);
  const double self_gap = 2.0 * std::sin(kPi / images);  // |x - R x| / rho
  auto clash = [&](const Vec3& w, int skip) {
    for (int m = 0; m < images; ++m)
      if (grid.near(m == 0 ? w : sector.place(w, m), min_dist, out.positions, skip)) return true;
    return false;
  };
  for (int c = 0; c < o.chains; ++c) {
    bool done = false;
    for (int attempt = 0; attempt < o.max_attempts && !done; ++attempt) {
      if (attempt > 0) ++out.restarts;
      const std::size_t start = out.positions.size();
      std::vector<Vec3> dirs;  // bond direction arriving at each placed bead of this chain
      std::vector<Vec3> walk;  // the chain's beads as grown (a periodic wedge: not wrapped)
      int backtracks = 0;
      int k = 0;
      while (k < n) {
        bool ok = false;
        for (int t = 0; t < o.direction_tries && !ok; ++t) {
          Vec3 x;
          Vec3 nd = Vec3::UnitZ();
          if (k == 0) {
            x = random_centre(region, r, rng);
          } else {
            nd = random_direction(dirs.back(), k == 1 ? kPi : o.theta_max, rng);
            const double len = d + o.l_max * u01(rng);
            x = walk.back() + len * nd;
          }
          if (!inside(region, x, r)) continue;
          Vec3 w = x;  // the bead as placed: its image inside the wedge
          if (images > 1) {
            w = sector.place(x, -sector.wedges(x));
            // Not on its own image (near the axis) and inside after round-off.
            if (std::hypot(w.x() - cyl->cx, w.y() - cyl->cy) * self_gap < min_dist || sector.wedges(w) != 0)
              continue;
          }
          const int skip = k == 0 ? -1 : static_cast<int>(out.positions.size()) - 1;
          if (clash(w, skip)) continue;
          grid.insert(static_cast<int>(out.positions.size()), w);
          out.positions.push_back(w);
          out.chain_of_bead.push_back(c);
          dirs.push_back(nd);
          walk.push_back(x);
          ok = true;
        }
        if (ok) {
          ++k;
        } else if (k >= 2 && backtracks < kBacktracksPerBead * n) {
          // Dead end: take back the last bead and grow again from the one before.
          ++backtracks;
          grid.remove_last(out.positions.back());
          out.positions.pop_back();
          out.chain_of_bead.pop_back();
          dirs.pop_back();
          walk.pop_back();
          --k;
        } else {
          break;
        }
      }
      if (k == n) {
        done = true;
      } else {
        while (out.positions.size() > start) {
          grid.remove_last(out.positions.back());
          out.positions.pop_back();
          out.chain_of_bead.pop_back();
        }
      }
    }
    if (!done)
      throw NoResultError(fmt::format(
          "sim builder: no room for chain {} of {} ({} beads) after {} attempts (region too dense?)", c,
          o.chains, n, o.max_attempts));
  }
  return out;
}

std::vector<int> add_chains(World& world, const ChainPlacement& p, const ChainOptions& o) {
  validate(o);
  std::vector<int> ids;
  ids.reserve(p.positions.size());
  for (const Vec3& x : p.positions) ids.push_back(world.add_sphere(x, o.diameter, o.density));
  const auto n = static_cast<std::size_t>(p.beads_per_chain);
  if (n > 1)
    for (std::size_t s = 0; s + n <= ids.size(); s += n)
      world.add_chain(std::span<const int>(ids.data() + s, n), o.diameter + o.l_max, o.theta_max);
  return ids;
}

void add_box_walls(World& world, const BoxRegion& b, double friction) {
  world.add_wall(Wall{b.lo, Vec3::UnitZ(), friction});
  world.add_wall(Wall{b.lo, Vec3::UnitX(), friction});
  world.add_wall(Wall{b.hi, -Vec3::UnitX(), friction});
  world.add_wall(Wall{b.lo, Vec3::UnitY(), friction});
  world.add_wall(Wall{b.hi, -Vec3::UnitY(), friction});
}

void validate(const FillOptions& o) {
  if (!(o.max_fall_speed >= 0.0) || !std::isfinite(o.max_fall_speed))
    bad_option("fill.max_fall_speed", o.max_fall_speed, ">= 0 (x d per step)");
  validate(o.chains);
  validate(o.region);
  if (!(o.wall_friction >= 0.0) || !std::isfinite(o.wall_friction)) bad_option("wall_friction", o.wall_friction, ">= 0");
  if (!(o.insert_fraction > 0.0) || o.insert_fraction > 0.35)
    bad_option("insert_fraction", o.insert_fraction, "in (0, 0.35]");
  if (!(o.settle_tolerance > 0.0)) bad_option("settle_tolerance", o.settle_tolerance, "> 0");
  if (o.settle_max_iterations < 1) bad_option("settle_max_iterations", o.settle_max_iterations, ">= 1");
  if (o.settle_max_steps < 1) bad_option("settle_max_steps", static_cast<double>(o.settle_max_steps), ">= 1");
  if (!(o.settle_kinetic_energy > 0.0)) bad_option("settle_kinetic_energy", o.settle_kinetic_energy, "> 0");
  if (!(o.plateau_ratio >= 0.0 && o.plateau_ratio <= 1.0)) bad_option("plateau_ratio", o.plateau_ratio, "in [0, 1]");
  if (!(o.relax_kinetic_energy > 0.0)) bad_option("relax_kinetic_energy", o.relax_kinetic_energy, "> 0");
  if (o.relax_max_steps < 0) bad_option("relax_max_steps", static_cast<double>(o.relax_max_steps), ">= 0");
}

FillResult fill(const Options& world_options, const FillOptions& o, const std::function<void(World&)>& container) {
  validate(o);
  const double g = gravity_magnitude(world_options);
  if (!(g > 0.0)) bad_option("gravity (world option)", g, "> 0 for a fill");
  if (!container && !std::holds_alternative<BoxRegion>(o.region))
    throw ConfigError("sim builder fill: a cylinder region needs a container callback (expected walls or fixed beads)");
  const ChainOptions& c = o.chains;
  const double d = c.diameter;
  const double bead_volume = kPi * d * d * d / 6.0;
  const double n_beads = static_cast<double>(c.chains) * c.beads_per_chain;
  // Insertion region: the container raised until the beads fill insert_fraction of it.
  Region insert = o.region;
  double floor_area = 0.0, z0 = 0.0;
  if (auto* b = std::get_if<BoxRegion>(&insert)) {
    floor_area = (b->hi.x() - b->lo.x()) * (b->hi.y() - b->lo.y());
    z0 = b->lo.z();
  } else {
    auto& cyl = std::get<CylinderRegion>(insert);
    floor_area = kPi * (cyl.radius * cyl.radius - cyl.inner_radius * cyl.inner_radius) / (cyl.sectors != 0 ? cyl.sectors : 1);
    z0 = cyl.z0;
  }
  const double height = n_beads * bead_volume / (o.insert_fraction * floor_area) + d;
  if (auto* b = std::get_if<BoxRegion>(&insert)) b->hi.z() = std::max(b->hi.z(), z0 + height);
  else std::get<CylinderRegion>(insert).z1 = std::max(std::get<CylinderRegion>(insert).z1, z0 + height);
  const ChainPlacement placement = place_chains(insert, c);

  auto build = [&](const Options& opt) {
    World w(opt);
    if (container) container(w);
    else add_box_walls(w, std::get<BoxRegion>(o.region), o.wall_friction);
    return w;
  };
  // Drop with the cheap solver.
  Options cheap = world_options;
  cheap.tolerance = o.settle_tolerance;
  cheap.max_iterations = o.settle_max_iterations;
  // The drop only places the beads: a cheap solve lets chains bend past their limits on
  // impact (measured: 2.1 deg over theta_max at step 196 of a 15 000-bead fill of 9-bead
  // chains at h = 1e-3 s), which the relaxation's full solver takes back. Its divergence
  // limits are therefore 5x the run's (default: overlap and rope excess 0.25 d, 10 deg).
  cheap.max_overlap = 5.0 * world_options.max_overlap;
  cheap.max_rope_excess = 5.0 * world_options.max_rope_excess;
  cheap.max_angle_excess = 5.0 * world_options.max_angle_excess;
  World drop = build(cheap);
  const std::vector<int> ids = add_chains(drop, placement, c);
  const double mgd = drop.mass(ids.front()) * g * d;
  const double energy_scale = n_beads * mgd;
  // At least the fall time of the whole insertion height (free fall, or at the terminal
  // speed when that is slower).
  const double h_step = world_options.time_step;
  const double v_cap = o.max_fall_speed > 0 ? o.max_fall_speed * d / h_step : 0.0;
  const double fall_s = std::max(std::sqrt(2.0 * height / g), v_cap > 0 ? height / v_cap : 0.0);
  const auto min_steps = static_cast<std::int64_t>(std::ceil(fall_s / h_step));
  std::int64_t settle = 0;
  bool plateau = false;
  const std::int64_t window = std::max<std::int64_t>(50, min_steps / 5);
  double window_sum = 0.0, previous_window = -1.0;
  int flat_windows = 0;
  for (; settle < o.settle_max_steps; ++settle) {
    (void)drop.step();
    if (v_cap > 0)
      for (const int b : ids) {
        const Vec3& v = drop.velocity(b);
        const double speed = v.norm();
        if (speed > v_cap) drop.set_velocity(b, v * (v_cap / speed));
      }
    if (o.drop_progress)
      o.drop_progress(static_cast<std::size_t>(settle + 1), static_cast<std::size_t>(std::max(min_steps, settle + 1)));
    const double ke = translational_energy(drop, ids);
    if (settle + 1 >= min_steps && ke <= o.settle_kinetic_energy * energy_scale) {
      ++settle;
      break;
    }
    // The plateau: whole windows after the fall time, each compared with the one before.
    if (o.plateau_ratio > 0 && settle + 1 > min_steps) {
      window_sum += ke;
      if ((settle + 1 - min_steps) % window == 0) {
        flat_windows = previous_window >= 0 && window_sum > o.plateau_ratio * previous_window ? flat_windows + 1 : 0;
        if (flat_windows == 2) {
          plateau = true;
          ++settle;
          break;
        }
        previous_window = window_sum;
        window_sum = 0.0;
      }
    }
  }
  // Relax with the caller's options (impulses start from zero).
  FillResult out{build(world_options), {}, placement.chain_of_bead, settle, 0, drop.iteration_cap_hits(), plateau,
                 0.0, false};
  std::vector<Vec3> pos(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) pos[k] = drop.position(ids[k]);
  ChainPlacement settled = placement;
  settled.positions = pos;
  out.beads = add_chains(out.world, settled, c);
  for (std::size_t k = 0; k < ids.size(); ++k) {
    out.world.set_velocity(out.beads[k], drop.velocity(ids[k]));
    out.world.set_angular_velocity(out.beads[k], drop.angular_velocity(ids[k]));
  }
  double ke = translational_energy(out.world, out.beads) / energy_scale;
  while (ke > o.relax_kinetic_energy && out.relax_steps < o.relax_max_steps) {
    (void)out.world.step();
    ke = translational_energy(out.world, out.beads) / energy_scale;
    ++out.relax_steps;
    if (o.relax_progress)
      o.relax_progress(static_cast<std::size_t>(out.relax_steps), static_cast<std::size_t>(o.relax_max_steps));
  }
  out.kinetic_energy = ke;
  out.relaxed = ke <= o.relax_kinetic_energy;
  return out;
}

double sphere_region_volume(const Vec3& c, double r, const Region& region) {
  if (const auto* b = std::get_if<BoxRegion>(&region)) {
    for (int k = 0; k < 3; ++k)
      if (c[k] + r <= b->lo[k] || c[k] - r >= b->hi[k]) return 0.0;
    if (inside(region, c, r)) return 4.0 / 3.0 * kPi * r * r * r;
    const double x0 = b->lo.x() - c.x(), x1 = b->hi.x() - c.x(), y0 = b->lo.y() - c.y(), y1 = b->hi.y() - c.y();
    std::vector<double> kinks{std::abs(x0), std::abs(x1), std::abs(y0), std::abs(y1)};
    for (const double x : {x0, x1})
      for (const double y : {y0, y1}) kinks.push_back(std::hypot(x, y));
    return integrate_slices(c, r, b->lo.z(), b->hi.z(), kinks,
                            [&](double rho) { return disc_rect(0.0, 0.0, rho, x0, x1, y0, y1); });
  }
  const auto& cyl = std::get<CylinderRegion>(region);
  if (cyl.sectors != 0) throw ConfigError("sim builder region: the volume of a sphere in a wedge is not computed");
  if (cyl.inner_radius > 0.0) {  // the annulus: the outer cylinder minus the inner one
    CylinderRegion outer = cyl, inner = cyl;
    outer.inner_radius = inner.inner_radius = 0.0;
    inner.radius = cyl.inner_radius;
    return sphere_region_volume(c, r, outer) - sphere_region_volume(c, r, inner);
  }
  const double e = std::hypot(c.x() - cyl.cx, c.y() - cyl.cy);
  if (e >= cyl.radius + r || c.z() + r <= cyl.z0 || c.z() - r >= cyl.z1) return 0.0;
  if (inside(region, c, r)) return 4.0 / 3.0 * kPi * r * r * r;
  const std::vector<double> kinks{std::abs(cyl.radius - e), cyl.radius + e};
  return integrate_slices(c, r, cyl.z0, cyl.z1, kinks,
                          [&](double rho) { return disc_disc(rho, cyl.radius, e); });
}

PackingMeasurement packing_fraction(const World& world, const Region& region) {
  validate(region);
  PackingMeasurement m;
  m.region_volume = region_volume(region);
  double solid = 0.0;
  for (int b = 0; b < world.body_count(); ++b) {
    if (world.kind(b) != BodyKind::kMobile) continue;
    const double v = sphere_region_volume(world.position(b), 0.5 * world.diameter(b), region);
    if (v > 0.0) {
      solid += v;
      ++m.spheres;
    }
  }
  m.fraction = solid / m.region_volume;
  return m;
}

}  // namespace shearzone::sim
