// The contact-dynamics engine: see shearzone/sim/world.hpp for the model.
#include "shearzone/sim/world.hpp"

#include <algorithm>
#include <atomic>
#include <thread>
#include <array>
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include <Eigen/Cholesky>
#include <fmt/format.h>
#include <omp.h>

#include "shearzone/core/check.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/hash.hpp"
#include "local_solve.hpp"
#include "solver_rows.hpp"

namespace shearzone::sim {
namespace {

bool finite(const Vec3& a) { return std::isfinite(a.x()) && std::isfinite(a.y()) && std::isfinite(a.z()); }

constexpr std::uint64_t kWallKeyBit = std::uint64_t{1} << 63;

constexpr std::uint64_t kImageKeyBit = std::uint64_t{1} << 31;

/// Body pair (i, j); a seam row (j seen as R x_j) sorts after i's plain rows.
std::uint64_t pair_key(int i, int j, int image = 0) {
  return (static_cast<std::uint64_t>(i) << 32) | (image != 0 ? kImageKeyBit : 0) | static_cast<std::uint64_t>(j);
}
std::uint64_t wall_key(int w, int j) {
  return kWallKeyBit | (static_cast<std::uint64_t>(w) << 32) | static_cast<std::uint64_t>(j);
}

/// Relative straight-chain guard on W_a: below it the angle row is
/// treated as inactive (sin θ ≈ 0, the constraint cannot bind within one step).
constexpr double kAngleGuard = 1e-12;


struct Fnv : core::Fnv1a {
  void v(const Vec3& a) {
    d(a.x());
    d(a.y());
    d(a.z());
  }
};

/// The row with the largest positive violation `excess(row)` (nullptr and 0 when none
/// exceeds 0): one search for the overlap, rope and angle checks of a step.
template <class Row, class Excess>
std::pair<double, const Row*> largest_excess(const std::vector<Row>& rows, Excess excess) {
  double worst = 0.0;
  const Row* at = nullptr;
  for (const Row& r : rows) {
    const double e = excess(r);
    if (e > worst) {
      worst = e;
      at = &r;
    }
  }
  return {worst, at};
}

}  // namespace

/// Largest contact-search distance per step, in smallest bead diameters.
constexpr double kMaxAlertDiameters = 8.0;
constexpr double kRoundoffUlps = 64.0;  // see "Stopping test" in world.hpp

World::World(const Options& options) : opt_(options) {
  auto bad = [](const char* name, double value, const char* expected) {
    throw ConfigError(fmt::format("sim option {}: {} (expected {})", name, value, expected));
  };
  if (!(opt_.time_step > 0.0) || !std::isfinite(opt_.time_step)) bad("time_step", opt_.time_step, "> 0");
  if (!finite(opt_.gravity)) bad("gravity", opt_.gravity.norm(), "finite");
  if (!(opt_.friction >= 0.0) || !std::isfinite(opt_.friction)) bad("friction", opt_.friction, ">= 0");
  if (!(opt_.tolerance > 0.0)) bad("tolerance", opt_.tolerance, "> 0");
  if (opt_.max_iterations < 1) bad("max_iterations", opt_.max_iterations, ">= 1");
  if (!(opt_.alert_margin >= 0.0) || !std::isfinite(opt_.alert_margin))
    bad("alert_margin", opt_.alert_margin, ">= 0");
  if (!(opt_.max_overlap > 0.0)) bad("max_overlap", opt_.max_overlap, "> 0");
  if (!(opt_.max_rope_excess > 0.0)) bad("max_rope_excess", opt_.max_rope_excess, "> 0");
  if (!(opt_.max_angle_excess > 0.0)) bad("max_angle_excess", opt_.max_angle_excess, "> 0");
  if (opt_.freeze_sweeps < 0 || opt_.freeze_sweeps > 1000000)
    bad("freeze_sweeps", opt_.freeze_sweeps, "in [0, 1e6]");
  if (opt_.threads < 1 || opt_.threads > 256) bad("threads", opt_.threads, "in [1, 256]");
  if (opt_.anderson_depth < 0 || opt_.anderson_depth > 10) bad("anderson_depth", opt_.anderson_depth, "in [0, 10]");
  if (opt_.parallel_min_rows_per_thread < 0)
    bad("parallel_min_rows_per_thread", opt_.parallel_min_rows_per_thread, ">= 0");
  if (opt_.sectors != 0 && (opt_.sectors < 3 || opt_.sectors > 64)) bad("sectors", opt_.sectors, "0 or in [3, 64]");
  if (!finite(opt_.sector_centre) || !std::isfinite(opt_.sector_start))
    bad("sector_centre, sector_start", opt_.sector_start, "finite");
}

namespace detail {

Sector::Sector(const Options& o) {
  if (o.sectors < 3) return;
  on = true;
  width = 2.0 * std::numbers::pi / o.sectors;
  c = std::cos(width);
  s = std::sin(width);
  if (o.sectors == 4) {  // exact quarter turns
    c = 0.0;
    s = 1.0;
  }
  cx = o.sector_centre.x();
  cy = o.sector_centre.y();
  start = o.sector_start;
  nx = -std::sin(start);
  ny = std::cos(start);
}

int Sector::wedges(const Vec3& x) const {
  if (!on) return 0;
  const double dx = x.x() - cx, dy = x.y() - cy;
  if (dx == 0.0 && dy == 0.0) return 0;
  const int k = static_cast<int>(std::lround(2.0 * std::numbers::pi / width));
  int m = static_cast<int>(std::floor((std::atan2(dy, dx) - start) / width));
  m = ((m % k) + k) % k;  // the nearest turn: in (−k/2, k/2]
  return 2 * m > k ? m - k : m;
}

}  // namespace detail

bool sector_contains(const Options& options, const Vec3& x) { return detail::Sector(options).wedges(x) == 0; }

int World::add_sphere(const Vec3& position, double diameter, double density, BodyKind kind) {
  if (!finite(position))
    throw ConfigError(fmt::format("sim sphere {}: non-finite position", x_.size()));
  if (!(diameter > 0.0) || !std::isfinite(diameter))
    throw ConfigError(fmt::format("sim sphere {}: diameter {} (expected > 0)", x_.size(), diameter));
  if (!(density > 0.0) || !std::isfinite(density))
    throw ConfigError(fmt::format("sim sphere {}: density {} (expected > 0)", x_.size(), density));
  SHEARZONE_CHECK(x_.size() < static_cast<std::size_t>(std::numeric_limits<int>::max()));
  // A periodic sector holds every body by its image inside the wedge.
  const detail::Sector sec(opt_);
  if (sec.wedges(position) != 0)
    throw ConfigError(fmt::format("sim sphere {}: at ({}, {}, {}), outside the periodic sector (expected azimuth in "
                                  "[{}, {}) rad: give its image inside)",
                                  x_.size(), position.x(), position.y(), position.z(), sec.start,
                                  sec.start + sec.width));
  const double m = density * std::numbers::pi * diameter * diameter * diameter / 6.0;
  const double inertia = m * diameter * diameter / 10.0;
  body_.resize(x_.size());  // drop the wall sentinels; step() puts them back
  x_.push_back(position);
  q_.push_back(Eigen::Quaterniond::Identity());
  SolverBody sb;
  sb.inv_mass = kind == BodyKind::kMobile ? 1.0 / m : 0.0;
  sb.inv_inertia = kind == BodyKind::kMobile ? 1.0 / inertia : 0.0;
  body_.push_back(sb);
  radius_.push_back(0.5 * diameter);
  mass_.push_back(m);
  inertia_.push_back(inertia);
  kind_.push_back(kind);
  rotor_of_.push_back(-1);
  return static_cast<int>(x_.size()) - 1;
}

int World::add_wall(const Wall& wall) {
  const double nn = wall.normal.norm();
  if (!finite(wall.point) || !(nn > 0.0) || !std::isfinite(nn))
    throw ConfigError(fmt::format("sim wall {}: non-finite point or zero normal", walls_.size()));
  if (!(wall.friction >= 0.0) || !std::isfinite(wall.friction))
    throw ConfigError(fmt::format("sim wall {}: friction {} (expected >= 0)", walls_.size(), wall.friction));
  Wall w = wall;
  w.normal /= nn;
  if (opt_.sectors != 0 && (w.normal.x() != 0.0 || w.normal.y() != 0.0))
    throw ConfigError(fmt::format("sim wall {}: a periodic sector takes only horizontal walls (normal along z), "
                                  "not ({}, {}, {})",
                                  walls_.size(), w.normal.x(), w.normal.y(), w.normal.z()));
  walls_.push_back(w);
  return static_cast<int>(walls_.size()) - 1;
}

World::World(const World&) = default;
World::World(World&&) noexcept = default;
World& World::operator=(const World&) = default;
World& World::operator=(World&&) noexcept = default;
World::~World() = default;

const World::SolverBody& World::body_at(int b) const {
  if (b < 0 || b >= body_count()) check_body(b, "access");
  return body_[static_cast<std::size_t>(b)];
}
const Vec3& World::velocity(int b) const { return body_at(b).v; }
const Vec3& World::angular_velocity(int b) const { return body_at(b).w; }
int World::rope_count() const { return static_cast<int>(ropes_.size()); }
int World::angle_count() const { return static_cast<int>(angles_.size()); }
double World::rope_impulse(int r) const { return ropes_.at(static_cast<std::size_t>(r)).lambda; }
double World::angle_impulse(int a) const { return angles_.at(static_cast<std::size_t>(a)).lambda; }

void World::check_body(int b, const char* what) const {
  if (b < 0 || b >= body_count())
    throw ConfigError(fmt::format("sim {}: body {} does not exist ({} bodies)", what, b, body_count()));
}

int World::nearest_image(int i, int j) const {
  const detail::Sector sec(opt_);
  if (!sec.on) return 0;
  const Vec3& xi = x_[static_cast<std::size_t>(i)];
  const Vec3& xj = x_[static_cast<std::size_t>(j)];
  int best = 0;
  double best_d = (xj - xi).squaredNorm();
  for (int k : {-1, 1})
    if (const double d = (sec.place(xj, k) - xi).squaredNorm(); d < best_d) {
      best_d = d;
      best = k;
    }
  return best;
}

int World::add_rope(int i, int j, double max_length) {
  check_body(i, "rope");
  check_body(j, "rope");
  if (i == j) throw ConfigError(fmt::format("sim rope: body {} tied to itself", i));
  if (!(max_length > 0.0) || !std::isfinite(max_length))
    throw ConfigError(fmt::format("sim rope {}-{}: max length {} (expected > 0)", i, j, max_length));
  RopeRow r;
  r.i = i;
  r.j = j;
  r.max_length = max_length;
  r.image = static_cast<std::int8_t>(nearest_image(i, j));
  ropes_.push_back(r);
  return static_cast<int>(ropes_.size()) - 1;
}

int World::add_angle_limit(int prev, int mid, int next, double max_angle) {
  check_body(prev, "angle limit");
  check_body(mid, "angle limit");
  check_body(next, "angle limit");
  if (prev == mid || mid == next || prev == next)
    throw ConfigError(fmt::format("sim angle limit {}-{}-{}: bodies must differ", prev, mid, next));
  if (!(max_angle > 0.0) || !(max_angle < std::numbers::pi))
    throw ConfigError(fmt::format("sim angle limit at {}: {} rad (expected in (0, pi))", mid, max_angle));
  AngleRow a;
  a.a = prev;
  a.b = mid;
  a.c = next;
  a.max_angle = max_angle;
  a.cos_max = std::cos(max_angle);
  a.image_a = static_cast<std::int8_t>(nearest_image(mid, prev));
  a.image_c = static_cast<std::int8_t>(nearest_image(mid, next));
  angles_.push_back(a);
  return static_cast<int>(angles_.size()) - 1;
}

void World::add_chain(std::span<const int> beads, double max_bond_length, double max_angle) {
  for (std::size_t k = 0; k + 1 < beads.size(); ++k) add_rope(beads[k], beads[k + 1], max_bond_length);
  if (max_angle < std::numbers::pi)
    for (std::size_t k = 1; k + 1 < beads.size(); ++k)
      add_angle_limit(beads[k - 1], beads[k], beads[k + 1], max_angle);
}

void World::set_velocity(int body, const Vec3& v) {
  check_body(body, "velocity");
  if (kind_[static_cast<std::size_t>(body)] == BodyKind::kFixed)
    throw ConfigError(fmt::format("sim body {} is fixed: its velocity is zero", body));
  if (!finite(v)) throw ConfigError(fmt::format("sim body {}: non-finite velocity", body));
  body_[static_cast<std::size_t>(body)].v = v;
}

void World::set_angular_velocity(int body, const Vec3& omega) {
  check_body(body, "angular velocity");
  if (kind_[static_cast<std::size_t>(body)] == BodyKind::kFixed)
    throw ConfigError(fmt::format("sim body {} is fixed: its angular velocity is zero", body));
  if (!finite(omega)) throw ConfigError(fmt::format("sim body {}: non-finite angular velocity", body));
  body_[static_cast<std::size_t>(body)].w = omega;
}

// Uniform cell grid over the bounding box of all spheres (cell ≥ d_max + alert), rebuilt
// every step; the contact list comes out sorted by key (i < j pairs, then wall rows).
// Wall rows get the sentinel body n as their i (partition_rows moves it to the slab's).
void World::find_contacts(double alert) {
  const std::size_t n = x_.size();
  contacts_.clear();
  info_.clear();
  if (n == 0) return;
  double rmax = 0.0;
  for (std::size_t b = 0; b < n; ++b) rmax = std::max(rmax, radius_[b]);
  // Periodic sector: the images R x_j of the bodies within reach of the wedge's first
  // side (they lie beyond its second side) join the grid as entries n, n + 1, ...; a
  // body within its own radius of the axis is its own image and gets none.
  const detail::Sector sec(opt_);
  ghost_of_.clear();
  ghost_x_.clear();
  if (sec.on) {
    const double reach = 2.0 * rmax + alert;
    for (std::size_t b = 0; b < n; ++b) {
      if (std::hypot(x_[b].x() - sec.cx, x_[b].y() - sec.cy) < radius_[b]) continue;
      if (sec.first_side(x_[b]) < reach) {
        ghost_of_.push_back(static_cast<int>(b));
        ghost_x_.push_back(sec.place(x_[b], 1));
      }
    }
  }
  const std::size_t entries = n + ghost_x_.size();
  auto at = [&](std::size_t e) -> const Vec3& { return e < n ? x_[e] : ghost_x_[e - n]; };
  Vec3 lo = x_[0], hi = x_[0];
  for (std::size_t e = 0; e < entries; ++e) {
    lo = lo.cwiseMin(at(e));
    hi = hi.cwiseMax(at(e));
  }
  double cell = 2.0 * rmax + alert;
  std::array<std::int64_t, 3> dims{};
  const double max_cells = 4.0 * static_cast<double>(entries) + 64.0;
  for (;;) {
    double total = 1.0;
    for (int k = 0; k < 3; ++k) {
      const double nk = std::floor((hi[k] - lo[k]) / cell) + 1.0;
      total *= nk;
      dims[static_cast<std::size_t>(k)] = static_cast<std::int64_t>(std::min(nk, 1e9));
    }
    if (total <= max_cells) break;
    cell *= 1.26;
  }
  auto coord = [&](const Vec3& p, int k) {
    const auto c = static_cast<std::int64_t>(std::floor((p[k] - lo[k]) / cell));
    return std::clamp<std::int64_t>(c, 0, dims[static_cast<std::size_t>(k)] - 1);
  };
  const std::int64_t ncell = dims[0] * dims[1] * dims[2];
  cell_of_.resize(entries);
  cell_start_.assign(static_cast<std::size_t>(ncell) + 1, 0);
  for (std::size_t b = 0; b < entries; ++b) {
    const Vec3& p = at(b);
    const std::int64_t c = (coord(p, 2) * dims[1] + coord(p, 1)) * dims[0] + coord(p, 0);
    cell_of_[b] = static_cast<int>(c);
    ++cell_start_[static_cast<std::size_t>(c) + 1];
  }
  for (std::int64_t c = 0; c < ncell; ++c)
    cell_start_[static_cast<std::size_t>(c) + 1] += cell_start_[static_cast<std::size_t>(c)];
  cell_bodies_.resize(entries);
  {
    std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t b = 0; b < entries; ++b)
      cell_bodies_[static_cast<std::size_t>(fill[static_cast<std::size_t>(cell_of_[b])]++)] =
          static_cast<int>(b);
  }
  const int sentinel = static_cast<int>(n);
  const double fric = opt_.friction;
  std::vector<std::size_t> order;  // scratch of the per-body sort, reused
  std::vector<ContactRow> rows;
  std::vector<ContactInfo> infos;
  for (std::size_t i = 0; i < n; ++i) {
    const bool mi = kind_[i] == BodyKind::kMobile;
    const std::size_t first = contacts_.size();
    const std::int64_t cx = coord(x_[i], 0), cy = coord(x_[i], 1), cz = coord(x_[i], 2);
    for (std::int64_t z = std::max<std::int64_t>(cz - 1, 0); z <= std::min(cz + 1, dims[2] - 1); ++z)
      for (std::int64_t y = std::max<std::int64_t>(cy - 1, 0); y <= std::min(cy + 1, dims[1] - 1); ++y)
        for (std::int64_t xx = std::max<std::int64_t>(cx - 1, 0); xx <= std::min(cx + 1, dims[0] - 1);
             ++xx) {
          const auto c = static_cast<std::size_t>((z * dims[1] + y) * dims[0] + xx);
          for (int s = cell_start_[c]; s < cell_start_[c + 1]; ++s) {
            const auto e = static_cast<std::size_t>(cell_bodies_[static_cast<std::size_t>(s)]);
            // An image pairs with every other body (each seam pair has one image side).
            const int image = e < n ? 0 : 1;
            const std::size_t j = e < n ? e : static_cast<std::size_t>(ghost_of_[e - n]);
            if (image == 0 ? j <= i : j == i) continue;
            if (!mi && kind_[j] != BodyKind::kMobile) continue;
            const Vec3 dx = at(e) - x_[i];
            const double dist = dx.norm();
            const double gap = dist - radius_[i] - radius_[j];
            if (gap >= alert) continue;
            ContactRow r;
            r.i = static_cast<int>(i);
            r.j = static_cast<int>(j);
            r.image = static_cast<std::int8_t>(image);
            // Coincident centres: any normal is as good as another; pick +z.
            r.n = dist > 0.0 ? Vec3(dx / dist) : Vec3(Vec3::UnitZ());
            r.ri = radius_[i];
            r.rj = radius_[j];
            r.mu = fric;
            contacts_.push_back(r);
            info_.push_back({pair_key(r.i, r.j, image), r.i, -1, gap});
          }
        }
    // Rows of body i in the order of j (the cells are visited in grid order).
    if (contacts_.size() - first > 1) {
      order.resize(contacts_.size() - first);
      for (std::size_t k = 0; k < order.size(); ++k) order[k] = first + k;
      std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return info_[a].key < info_[b].key; });
      rows.clear();
      infos.clear();
      for (std::size_t k : order) {
        rows.push_back(contacts_[k]);
        infos.push_back(info_[k]);
      }
      std::copy(rows.begin(), rows.end(), contacts_.begin() + static_cast<std::ptrdiff_t>(first));
      std::copy(infos.begin(), infos.end(), info_.begin() + static_cast<std::ptrdiff_t>(first));
    }
  }
  for (std::size_t w = 0; w < walls_.size(); ++w) {
    const Wall& wall = walls_[w];
    for (std::size_t j = 0; j < n; ++j) {
      if (kind_[j] != BodyKind::kMobile) continue;
      const double gap = (x_[j] - wall.point).dot(wall.normal) - radius_[j];
      if (gap >= alert) continue;
      ContactRow r;
      r.i = sentinel;
      r.j = static_cast<int>(j);
      r.n = wall.normal;
      r.rj = radius_[j];
      r.mu = wall.friction;
      contacts_.push_back(r);
      info_.push_back({wall_key(static_cast<int>(w), r.j), -1, static_cast<int>(w), gap});
    }
  }
  const double inv_h = 1.0 / opt_.time_step;
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    ContactRow& r = contacts_[k];
    const SolverBody& bi = body_[static_cast<std::size_t>(r.i)];
    const SolverBody& bj = body_[static_cast<std::size_t>(r.j)];
    const double wn = bi.inv_mass + bj.inv_mass;
    const double wt = wn + r.ri * r.ri * bi.inv_inertia + r.rj * r.rj * bj.inv_inertia;
    r.inv_wn = 1.0 / wn;
    r.inv_wt = 1.0 / wt;
    r.bias = info_[k].gap * inv_h;
  }
}

void World::apply_contact(const ContactRow& r, const Vec3& p, const detail::Sector& sec) {
  SolverBody& bi = body_[static_cast<std::size_t>(r.i)];
  SolverBody& bj = body_[static_cast<std::size_t>(r.j)];
  const Vec3 np = r.n.cross(p);
  if (r.image != 0) {  // j's side of a seam row, in j's frame
    bj.v += bj.inv_mass * sec.rot(p, -1);
    bj.w -= (bj.inv_inertia * r.rj) * sec.rot(np, -1);
  } else {
    bj.v += bj.inv_mass * p;
    bj.w -= (bj.inv_inertia * r.rj) * np;
  }
  bi.v -= bi.inv_mass * p;
  bi.w -= (bi.inv_inertia * r.ri) * np;
}

// Row geometry at x(t) and the warm start (impulses of the previous step, applied).
void World::prepare_rows() {
  const double inv_h = 1.0 / opt_.time_step;
  const detail::Sector sec(opt_);
  // Contacts: merge-join with the previous step's rows (both sorted by key).
  std::size_t p = 0;
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    ContactRow& r = contacts_[k];
    const std::uint64_t key = info_[k].key;
    while (p < previous_.size() && previous_[p].key < key) ++p;
    if (p < previous_.size() && previous_[p].key == key) {
      r.pn = previous_[p].pn;
      r.pt = previous_[p].pt - previous_[p].pt.dot(r.n) * r.n;
      r.status = previous_[p].status;
      if (r.pn > 0.0 || r.pt.squaredNorm() > 0.0) apply_contact(r, r.pn * r.n + r.pt, sec);
    }
  }
  for (RopeRow& r : ropes_) {
    r.frozen_until = 0;
    r.quiet = 0;
    SolverBody& bi = body_[static_cast<std::size_t>(r.i)];
    SolverBody& bj = body_[static_cast<std::size_t>(r.j)];
    const Vec3 dx = sec.place(x_[static_cast<std::size_t>(r.j)], r.image) - x_[static_cast<std::size_t>(r.i)];
    const double dist = dx.norm();
    r.e = dist > 0.0 ? Vec3(dx / dist) : Vec3(Vec3::UnitX());
    r.ej = sec.rot(r.e, -r.image);
    r.c = r.max_length - dist;
    r.bias = r.c * inv_h;
    r.wb = bi.inv_mass + bj.inv_mass;
    if (r.wb <= 0.0) {
      r.lambda = 0.0;
      continue;
    }
    if (r.lambda > 0.0) {
      bi.v += (bi.inv_mass * r.lambda) * r.e;
      bj.v -= (bj.inv_mass * r.lambda) * r.ej;
    }
  }
  for (AngleRow& r : angles_) {
    r.frozen_until = 0;
    r.quiet = 0;
    SolverBody& ba = body_[static_cast<std::size_t>(r.a)];
    SolverBody& bb = body_[static_cast<std::size_t>(r.b)];
    SolverBody& bc = body_[static_cast<std::size_t>(r.c)];
    const Vec3 b1 = x_[static_cast<std::size_t>(r.b)] - sec.place(x_[static_cast<std::size_t>(r.a)], r.image_a);
    const Vec3 b2 = sec.place(x_[static_cast<std::size_t>(r.c)], r.image_c) - x_[static_cast<std::size_t>(r.b)];
    const double l1 = b1.norm(), l2 = b2.norm();
    r.live = false;
    if (l1 > 0.0 && l2 > 0.0) {
      const Vec3 e1 = b1 / l1, e2 = b2 / l2;
      const double cs = std::clamp(e1.dot(e2), -1.0, 1.0);
      const Vec3 A = (e2 - cs * e1) / l1, B = (e1 - cs * e2) / l2;
      r.ga = -A;
      r.gb = A - B;
      r.gc = B;
      r.ca = cs - r.cos_max;
      r.bias = r.ca * inv_h;
      r.wa = A.squaredNorm() * ba.inv_mass + r.gb.squaredNorm() * bb.inv_mass +
             B.squaredNorm() * bc.inv_mass;
      r.scale = 0.5 * (l1 + l2);
      const double wref = (ba.inv_mass + bb.inv_mass + bc.inv_mass) / (l1 * l2);
      r.live = r.wa > kAngleGuard * wref;
      r.ga = sec.rot(r.ga, -r.image_a);  // each gradient in its body's own frame
      r.gc = sec.rot(r.gc, -r.image_c);
    }
    if (!r.live) {
      r.lambda = 0.0;
      continue;
    }
    if (r.lambda > 0.0) {
      ba.v += (ba.inv_mass * r.lambda) * r.ga;
      bb.v += (bb.inv_mass * r.lambda) * r.gb;
      bc.v += (bc.inv_mass * r.lambda) * r.gc;
    }
  }
}

// Sweep order. One thread: every row in one list. T threads: slabs along the longest
// axis of the mobile bodies' bounding box, cut at the quantiles of their coordinate; a
// row belongs to a slab when all its bodies do (fixed and kinematic bodies are placed by
// their coordinate like the rest; a wall row follows its body and uses the slab's
// sentinel), the others go to the boundary list.
void World::partition_rows() {
  const int T = opt_.threads;
  const std::size_t n = x_.size();
  lists_.resize(static_cast<std::size_t>(T) + 1);
  for (RowLists& l : lists_) l.clear();
  auto live_rope = [&](const RopeRow& r) { return r.wb > 0.0; };
  if (T == 1) {
    RowLists& l = lists_[0];
    l.contacts.resize(contacts_.size());
    for (std::size_t k = 0; k < contacts_.size(); ++k) l.contacts[k] = static_cast<int>(k);
    for (std::size_t k = 0; k < ropes_.size(); ++k)
      if (live_rope(ropes_[k])) l.ropes.push_back(static_cast<int>(k));
    for (std::size_t k = 0; k < angles_.size(); ++k)
      if (angles_[k].live) l.angles.push_back(static_cast<int>(k));
    return;
  }
  // Slabs along each axis, cut at the quantiles of the mobile bodies' coordinate; the
  // axis kept is the one whose slabs are most contiguous in body order (fewest slab
  // changes from body b to b + 1), so that each thread streams its own part of the body
  // and row arrays (measured on a layered pour: 1.45x with 2 threads when cut along the
  // layers, 0.8x across them); ties go to the longest extent.
  std::vector<double> coord;
  coord.reserve(n);
  std::vector<int> slab(n);
  std::int64_t best_changes = std::numeric_limits<std::int64_t>::max();
  double best_extent = -1.0;
  for (int axis = 0; axis < 3; ++axis) {
    coord.clear();
    for (std::size_t b = 0; b < n; ++b)
      if (kind_[b] == BodyKind::kMobile) coord.push_back(x_[b][axis]);
    if (coord.empty())
      for (std::size_t b = 0; b < n; ++b) coord.push_back(x_[b][axis]);
    std::vector<double> cuts;
    for (int t = 1; t < T && !coord.empty(); ++t) {
      const auto at = static_cast<std::ptrdiff_t>(coord.size() * static_cast<std::size_t>(t) /
                                                  static_cast<std::size_t>(T));
      std::nth_element(coord.begin(), coord.begin() + at, coord.end());
      cuts.push_back(coord[static_cast<std::size_t>(at)]);
    }
    std::sort(cuts.begin(), cuts.end());
    const auto [mn, mx] = std::minmax_element(coord.begin(), coord.end());
    const double extent = coord.empty() ? 0.0 : *mx - *mn;
    std::int64_t changes = 0;
    for (std::size_t b = 0; b < n; ++b) {
      slab[b] = static_cast<int>(std::upper_bound(cuts.begin(), cuts.end(), x_[b][axis]) - cuts.begin());
      if (b > 0 && slab[b] != slab[b - 1]) ++changes;
    }
    if (changes < best_changes || (changes == best_changes && extent > best_extent)) {
      best_changes = changes;
      best_extent = extent;
      slab_.swap(slab);
      slab.resize(n);
    }
  }
  RowLists& boundary = lists_[static_cast<std::size_t>(T)];
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    ContactRow& r = contacts_[k];
    const int sj = slab_[static_cast<std::size_t>(r.j)];
    if (info_[k].i < 0) {  // wall row: the slab's own sentinel
      r.i = static_cast<int>(n) + sj;
      lists_[static_cast<std::size_t>(sj)].contacts.push_back(static_cast<int>(k));
    } else if (r.image == 0 && slab_[static_cast<std::size_t>(r.i)] == sj) {
      lists_[static_cast<std::size_t>(sj)].contacts.push_back(static_cast<int>(k));
    } else {
      boundary.contacts.push_back(static_cast<int>(k));
    }
  }
  for (std::size_t k = 0; k < ropes_.size(); ++k) {
    const RopeRow& r = ropes_[k];
    if (!live_rope(r)) continue;
    const int si = slab_[static_cast<std::size_t>(r.i)];
    (r.image == 0 && si == slab_[static_cast<std::size_t>(r.j)] ? lists_[static_cast<std::size_t>(si)] : boundary)
        .ropes.push_back(static_cast<int>(k));
  }
  for (std::size_t k = 0; k < angles_.size(); ++k) {
    const AngleRow& r = angles_[k];
    if (!r.live) continue;
    const int sa = slab_[static_cast<std::size_t>(r.a)];
    const bool inside = r.image_a == 0 && r.image_c == 0 && sa == slab_[static_cast<std::size_t>(r.b)] &&
                        sa == slab_[static_cast<std::size_t>(r.c)];
    (inside ? lists_[static_cast<std::size_t>(sa)] : boundary).angles.push_back(static_cast<int>(k));
  }
}

namespace {

/// Centralised sense-counting barrier that spins (with a pause, then yielding) instead
/// of sleeping. The last thread to arrive bumps the generation (release); the others
/// wait for it (acquire), so every write before the barrier is seen after it.
class SpinBarrier {
 public:
  void reset(int threads) {
    threads_ = threads;
    count_.store(0, std::memory_order_relaxed);
  }
  void wait() {
    const int gen = generation_.load(std::memory_order_acquire);
    if (count_.fetch_add(1, std::memory_order_acq_rel) == threads_ - 1) {
      count_.store(0, std::memory_order_relaxed);
      generation_.fetch_add(1, std::memory_order_release);
      return;
    }
    for (int spins = 0; generation_.load(std::memory_order_acquire) == gen; ++spins) {
#if defined(__x86_64__) || defined(__i386__)
      __builtin_ia32_pause();
#endif
      if (spins > 4096) std::this_thread::yield();
    }
  }

 private:
  std::atomic<int> count_{0};
  std::atomic<int> generation_{0};
  int threads_ = 1;
};

/// Coulomb's cone for P_n > 0: P_t kept inside it (sticking), else scaled back onto
/// |P_t| = μ P_n along itself (radial return, sliding). The sweep's local solve and the
/// projection of an Anderson extrapolation.
inline ContactStatus radial_return(Vec3& pt, double pn, double mu) {
  const double limit = mu * pn;
  const double p2 = pt.squaredNorm();
  if (p2 <= limit * limit) return ContactStatus::kSticking;
  pt *= limit / std::sqrt(p2);
  return ContactStatus::kSliding;
}

/// Freeze bookkeeping of a visit that left a zero-impulse row unchanged: frozen after
/// two quiet visits in a row.
template <class Row>
void note_quiet(Row& r, int sweep, int freeze_sweeps) {
  if (freeze_sweeps > 0 && ++r.quiet >= 2) r.frozen_until = sweep + freeze_sweeps;
}

}  // namespace

// One pass over a list of rows (contacts, ropes, angles; reversed when backward).
// `check`: solve only the frozen rows (the convergence check of "Freezing" in world.hpp);
// otherwise solve every row that is not frozen. `aa` (Anderson acceleration, recording
// sweeps only): every row of the list, visited or skipped, records its residual F (the
// change this sweep made) and output G, the new difference column and the partial dot
// products into `sums` (2m values: the new Gram row, ΔFᵀ D F).
void World::sweep_lists(const RowLists& lists, bool forward, int sweep, bool check, SweepTotals& out,
                        detail::Anderson* aa, double* sums) {
  SweepTotals t;  // local: the totals of the slabs share cache lines
  SolverBody* const B = body_.data();
  const int freeze = opt_.freeze_sweeps;
  const detail::Sector sec(opt_);
  ContactRow* const C = contacts_.data();
  RopeRow* const R = ropes_.data();
  AngleRow* const A = angles_.data();

  // Anderson bookkeeping: entries [at, at + n) of the impulse vector.
  const bool rec = aa != nullptr;
  const int m = rec ? aa->m : 0;
  double* const fprev = rec ? aa->fprev() : nullptr;
  double* const gprev = rec ? aa->gprev() : nullptr;
  double* const dfp = rec && aa->push >= 0 ? aa->dF(aa->push) : nullptr;
  double* const dgp = rec && aa->push >= 0 ? aa->dG(aa->push) : nullptr;
  const double* held[10];  // columns 0 … count−1 (the new one included)
  const int nh = rec && dfp ? aa->count : 0;
  for (int h = 0; h < nh; ++h) held[h] = aa->dF(h);
  double hsum[10] = {}, bsum[10] = {};  // local: `sums` may share cache lines with other parts
  std::int32_t* const zs = rec ? aa->zero_since.data() : nullptr;
  const std::int32_t quiet_below = rec ? aa->skip_below : 0;
  auto record = [&](std::size_t row, std::size_t at, int n, const double* f, const double* g, const double* w) {
    zs[row] = detail::Anderson::kNever;
    for (int e = 0; e < n; ++e) {
      const std::size_t i = at + static_cast<std::size_t>(e);
      if (dfp) {
        const double df = f[e] - fprev[i];
        dfp[i] = df;
        dgp[i] = g[e] - gprev[i];
        for (int h = 0; h < nh; ++h) {
          const double a = w[e] * held[h][i];
          hsum[h] += a * dfp[i];
          bsum[h] += a * f[e];
        }
      }
      fprev[i] = f[e];
      gprev[i] = g[e];
    }
  };
  // A row left at zero impulse (skipped while frozen, or open and staying open): F = 0,
  // G = 0. A row quiet since before the previous sweep and before the last write of the
  // slot this sweep overwrites (Anderson::skip_below) holds zeros in every vector entry
  // it owns already: nothing to read or write. Otherwise its F and G are recorded as
  // zeros (the weights matter only where the previous F or G was not zero).
  auto record_zero = [&](std::size_t row, std::size_t at, int n, auto&& weights) {
    if (zs[row] <= quiet_below) return;
    if (zs[row] == detail::Anderson::kNever) zs[row] = aa->iter;
    bool was_zero = true;
    for (int e = 0; e < n; ++e) was_zero = was_zero && fprev[at + e] == 0.0 && gprev[at + e] == 0.0;
    if (was_zero) {
      if (dfp)
        for (int e = 0; e < n; ++e) dfp[at + e] = dgp[at + e] = 0.0;
      return;
    }
    double w[4];
    weights(w);
    const double zero[4] = {};
    const std::int32_t since = zs[row];
    record(row, at, n, zero, zero, w);
    zs[row] = since;
  };
  auto contact_weights = [](const ContactRow& r) {
    return [&r](double* w) {
      w[0] = 1.0 / (r.inv_wn * r.inv_wn);
      w[1] = w[2] = w[3] = 1.0 / (r.inv_wt * r.inv_wt);
    };
  };

  // A visit that left a zero-impulse row unchanged; one that changed a row.
  auto stays_open = [&](auto& r, bool closed) {
    if (closed) ++t.active;
    else note_quiet(r, sweep, freeze);
  };
  auto unfreeze = [&](auto& r) {
    r.quiet = 0;
    r.frozen_until = 0;
    ++t.changed;
  };
  // Frozen rows are skipped by normal sweeps, and only they are solved by a check sweep.
  auto skip = [&](const auto& r) {
    if ((r.frozen_until > sweep) != check) {
      ++t.skipped;
      return true;
    }
    ++t.updates;
    return false;
  };

  auto contact = [&](ContactRow& r) {
    const std::size_t row = static_cast<std::size_t>(&r - C), at = 4 * row;
    if (skip(r)) {
      if (rec) record_zero(row, at, 4, contact_weights(r));
      return;
    }
    SolverBody& bi = B[r.i];
    SolverBody& bj = B[r.j];
    const Vec3 n = r.n;
    Vec3 vj = bj.v, wj = bj.w;
    if (r.image != 0) {  // a seam row: j's velocities seen from i's side
      vj = sec.rot(vj, 1);
      wj = sec.rot(wj, 1);
    }
    const Vec3 u = (vj - bi.v) - (r.rj * wj + r.ri * bi.w).cross(n);
    const double un = u.dot(n);
    double pn = r.pn - (un + r.bias) * r.inv_wn;
    Vec3 pt;
    ContactStatus status = ContactStatus::kOpen;
    if (!(pn > 0.0)) {
      pn = 0.0;
      pt.setZero();
    } else {
      pt = r.pt - r.inv_wt * (u - un * n);
      status = radial_return(pt, pn, r.mu);
    }
    const double dpn = pn - r.pn;
    const Vec3 dpt = pt - r.pt;
    r.status = status;
    const bool closed = r.bias <= 0.0;
    if (dpn == 0.0 && dpt.squaredNorm() == 0.0) {
      if (pn == 0.0) {  // open, stays open
        stays_open(r, closed);
        if (rec) record_zero(row, at, 4, contact_weights(r));
        return;
      }
    }
    unfreeze(r);
    r.pn = pn;
    r.pt = pt;
    const double wn = bi.inv_mass + bj.inv_mass;
    const double wt = wn + r.ri * r.ri * bi.inv_inertia + r.rj * r.rj * bj.inv_inertia;
    const Vec3 p = dpn * n + dpt;
    const Vec3 np = n.cross(p);
    if (r.image != 0) {
      bj.v += bj.inv_mass * sec.rot(p, -1);
      bj.w -= (bj.inv_inertia * r.rj) * sec.rot(np, -1);
    } else {
      bj.v += bj.inv_mass * p;
      bj.w -= (bj.inv_inertia * r.rj) * np;
    }
    bi.v -= bi.inv_mass * p;
    bi.w -= (bi.inv_inertia * r.ri) * np;
    t.dv2 += wn * wn * dpn * dpn + wt * wt * dpt.squaredNorm();
    t.wp2 += wn * wn * pn * pn + wt * wt * pt.squaredNorm();
    if (closed || pn != 0.0) ++t.active;
    if (rec) {
      const double f[4] = {dpn, dpt.x(), dpt.y(), dpt.z()};
      const double g[4] = {pn, pt.x(), pt.y(), pt.z()};
      const double w[4] = {wn * wn, wt * wt, wt * wt, wt * wt};
      record(row, at, 4, f, g, w);
    }
  };

  // The end of a rope or angle visit: λ is the new impulse, `closed` whether the
  // constraint is at or past its limit, w2 the squared residual weight, `apply(dλ)` puts
  // the change on the bodies; `at` its entry in the Anderson vectors.
  auto finish_scalar = [&](auto& r, std::size_t at, double lam, bool closed, double w2, auto&& apply) {
    const double dl = lam - r.lambda;
    if (rec) {
      const std::size_t row = at - 3 * contacts_.size();
      if (dl == 0.0 && lam == 0.0) record_zero(row, at, 1, [w2](double* w) { w[0] = w2; });
      else record(row, at, 1, &dl, &lam, &w2);
    }
    if (dl == 0.0 && lam == 0.0) {
      stays_open(r, closed);
      return;
    }
    unfreeze(r);
    r.lambda = lam;
    if (dl != 0.0) apply(dl);
    t.dv2 += w2 * dl * dl;
    t.wp2 += w2 * lam * lam;
    ++t.active;
  };

  auto rope = [&](RopeRow& r) {
    const std::size_t at = rec ? aa->ropes_at + static_cast<std::size_t>(&r - R) : 0;
    if (skip(r)) {
      if (rec) record_zero(at - 3 * contacts_.size(), at, 1, [&r](double* w) { w[0] = r.wb * r.wb; });
      return;
    }
    SolverBody& bi = B[r.i];
    SolverBody& bj = B[r.j];
    const double rate = r.image != 0 ? r.ej.dot(bj.v) - r.e.dot(bi.v) : r.e.dot(bj.v - bi.v);
    finish_scalar(r, at, std::max(0.0, r.lambda + (rate - r.bias) / r.wb), r.c <= 0.0, r.wb * r.wb,
                  [&](double dl) {
                    bi.v += (bi.inv_mass * dl) * r.e;
                    bj.v -= (bj.inv_mass * dl) * r.ej;
                  });
  };

  auto angle = [&](AngleRow& r) {
    const std::size_t at = rec ? aa->angles_at + static_cast<std::size_t>(&r - A) : 0;
    if (skip(r)) {
      if (rec) record_zero(at - 3 * contacts_.size(), at, 1, [&r](double* w) { w[0] = r.scale * r.scale * r.wa * r.wa; });
      return;
    }
    SolverBody& ba = B[r.a];
    SolverBody& bb = B[r.b];
    SolverBody& bc = B[r.c];
    const double rate = r.ga.dot(ba.v) + r.gb.dot(bb.v) + r.gc.dot(bc.v);
    finish_scalar(r, at, std::max(0.0, r.lambda - (rate + r.bias) / r.wa), r.ca <= 0.0,
                  r.scale * r.scale * r.wa * r.wa, [&](double dl) {
                    ba.v += (ba.inv_mass * dl) * r.ga;
                    bb.v += (bb.inv_mass * dl) * r.gb;
                    bc.v += (bc.inv_mass * dl) * r.gc;
                  });
  };

  if (forward) {
    for (int k : lists.contacts) contact(C[k]);
    for (int k : lists.ropes) rope(R[k]);
    for (int k : lists.angles) angle(A[k]);
  } else {
    for (auto it = lists.angles.rbegin(); it != lists.angles.rend(); ++it) angle(A[*it]);
    for (auto it = lists.ropes.rbegin(); it != lists.ropes.rend(); ++it) rope(R[*it]);
    for (auto it = lists.contacts.rbegin(); it != lists.contacts.rend(); ++it) contact(C[*it]);
  }
  out = t;
  if (rec)
    for (int h = 0; h < m; ++h) {
      sums[h] = hsum[h];
      sums[m + h] = bsum[h];
    }
}

// Anderson acceleration (Options::anderson_depth; type II, Walker & Ni 2011). A recording
// sweep (sweep_lists) stores each row's F = G − P_in and G, the new difference column and
// the partial dot products; the m × m least-squares solve runs on one thread
// (detail::anderson_solve); anderson_apply then sets P̃ = G − Σ γ ΔG per row, projected on
// the constraints, and applies P̃ − G to the bodies, so P̃ is the next sweep's input. The
// weights D are the residual's (W_n², W_t², W_b², (ℓ W_a)²): the combination minimises the
// norm the stopping test measures.
void World::anderson_begin(detail::Anderson& a) {
  a.m = opt_.anderson_depth;
  a.ropes_at = 4 * contacts_.size();
  a.angles_at = a.ropes_at + ropes_.size();
  a.stride = a.angles_at + angles_.size();
  a.buf.swap(aa_buf_);
  a.buf.resize(a.stride * static_cast<std::size_t>(2 + 2 * a.m));
  a.part.assign(lists_.size() * static_cast<std::size_t>(2 * a.m), 0.0);
  a.zero_since.assign(contacts_.size() + ropes_.size() + angles_.size(), detail::Anderson::kNever);
  a.iter = 0;
  std::fill(std::begin(a.last_push), std::end(a.last_push), 0);
  a.best = a.best_step = std::numeric_limits<double>::infinity();
}

void World::anderson_apply(const RowLists& lists, detail::Anderson& a, int sweep) {
  const double* dg[10];
  double gam[10];
  int nh = 0;
  for (int j = 0; j < a.count; ++j) {
    if (a.gamma[j] == 0.0) continue;
    dg[nh] = a.dG(j);
    gam[nh++] = a.gamma[j];
  }
  if (nh == 0) return;
  // A row quiet since before every held column was written has zeros in them: P̃ = G = 0.
  std::int32_t quiet_below = detail::Anderson::kNever;
  for (int j = 0; j < a.count; ++j) quiet_below = std::min(quiet_below, a.last_push[j] - 1);
  const std::int32_t* const zs = a.zero_since.data();
  const std::size_t nc = contacts_.size();
  // Σ γ ΔG at entry i.
  auto shift = [&](std::size_t i) {
    double v = 0.0;
    for (int h = 0; h < nh; ++h) v += gam[h] * dg[h][i];
    return v;
  };
  // A row frozen for the next sweep keeps G (zero impulse).
  SolverBody* const B = body_.data();
  const detail::Sector sec(opt_);
  for (int k : lists.contacts) {
    if (zs[k] <= quiet_below) continue;
    ContactRow& r = contacts_[static_cast<std::size_t>(k)];
    if (r.frozen_until > sweep + 1) continue;
    const std::size_t at = 4 * static_cast<std::size_t>(k);
    double pn = r.pn - shift(at);
    Vec3 pt;
    if (!(pn > 0.0)) {
      pn = 0.0;
      pt.setZero();
    } else {
      pt = r.pt - Vec3(shift(at + 1), shift(at + 2), shift(at + 3));
      (void)radial_return(pt, pn, r.mu);
    }
    const double dpn = pn - r.pn;
    const Vec3 dpt = pt - r.pt;
    if (dpn != 0.0 || dpt.squaredNorm() != 0.0) {
      r.quiet = 0;
      r.pn = pn;
      r.pt = pt;
      apply_contact(r, dpn * r.n + dpt, sec);
    }
  }
  // A rope or angle row (`row` its index among all rows, `at` its vector entry): λ̃ ≥ 0,
  // `apply(dλ)` puts the change on the bodies.
  auto scalar = [&](auto& r, std::size_t row, std::size_t at, auto&& apply) {
    if (zs[row] <= quiet_below || r.frozen_until > sweep + 1) return;
    const double p = std::max(0.0, r.lambda - shift(at));
    const double dl = p - r.lambda;
    if (dl == 0.0) return;
    r.quiet = 0;
    r.lambda = p;
    apply(dl);
  };
  for (int k : lists.ropes) {
    const std::size_t i = static_cast<std::size_t>(k);
    RopeRow& r = ropes_[i];
    scalar(r, nc + i, a.ropes_at + i, [&](double dl) {
      B[r.i].v += (B[r.i].inv_mass * dl) * r.e;
      B[r.j].v -= (B[r.j].inv_mass * dl) * r.ej;
    });
  }
  for (int k : lists.angles) {
    const std::size_t i = static_cast<std::size_t>(k);
    AngleRow& r = angles_[i];
    scalar(r, nc + ropes_.size() + i, a.angles_at + i, [&](double dl) {
      B[r.a].v += (B[r.a].inv_mass * dl) * r.ga;
      B[r.b].v += (B[r.b].inv_mass * dl) * r.gb;
      B[r.c].v += (B[r.c].inv_mass * dl) * r.gc;
    });
  }
}

void World::integrate_positions() {
  const double h = opt_.time_step;
  const std::size_t n = x_.size();
  for (std::size_t b = 0; b < n; ++b) {
    if (kind_[b] == BodyKind::kFixed) continue;
    const SolverBody& sb = body_[b];
    x_[b] += h * sb.v;
    const double rate = sb.w.norm();
    if (rate > 0.0) {
      const Eigen::Quaterniond dq(Eigen::AngleAxisd(rate * h, sb.w / rate));
      q_[b] = (dq * q_[b]).normalized();
    }
  }
}

// Stage 5 (periodic sector): a mobile sphere whose centre left the wedge is moved to its
// image inside (position, velocity, spin, orientation); the image offsets of its rope and
// angle rows follow, and its contact rows (the next step's warm start and the records)
// are re-expressed from the new images: the normal and impulses rotated into the frame
// of the row's first body, the pair put back in the engine's order (i < j, or j seen as
// R x_j). A row whose bodies would be more than one wedge apart is dropped.
void World::wrap_sector() {
  const detail::Sector sec(opt_);
  if (!sec.on) return;
  const std::size_t n = x_.size();
  wrapped_.assign(n, 0);
  bool any = false;
  for (std::size_t b = 0; b < n; ++b) {
    if (kind_[b] != BodyKind::kMobile) continue;
    const int m = sec.wedges(x_[b]);
    if (m == 0) continue;
    x_[b] = sec.place(x_[b], -m);
    body_[b].v = sec.turn(body_[b].v, -m);
    body_[b].w = sec.turn(body_[b].w, -m);
    q_[b] = (Eigen::Quaterniond(Eigen::AngleAxisd(-m * sec.width, Vec3::UnitZ())) * q_[b]).normalized();
    wrapped_[b] = static_cast<std::int8_t>(m);
    any = true;
  }
  if (!any) return;
  auto shift = [&](int b) { return static_cast<int>(wrapped_[static_cast<std::size_t>(b)]); };
  auto one_wedge = [&](int k, const char* what, int a, int b) {
    if (k < -1 || k > 1)
      throw NoResultError(fmt::format("sim diverged at step {}: the {} between bodies {} and {} spans more than one "
                                      "wedge of the periodic sector (a bead too near its axis)",
                                      step_, what, a, b));
    return static_cast<std::int8_t>(k);
  };
  for (RopeRow& r : ropes_) r.image = one_wedge(r.image + shift(r.j) - shift(r.i), "rope", r.i, r.j);
  for (AngleRow& r : angles_) {
    r.image_a = one_wedge(r.image_a + shift(r.a) - shift(r.b), "angle row", r.a, r.b);
    r.image_c = one_wedge(r.image_c + shift(r.c) - shift(r.b), "angle row", r.c, r.b);
  }
  std::vector<std::size_t> keep;
  keep.reserve(contacts_.size());
  bool moved = false;
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    ContactRow& r = contacts_[k];
    ContactInfo& c = info_[k];
    const int wj = shift(r.j), wi = c.i >= 0 ? shift(c.i) : 0;
    if (wi == 0 && wj == 0) {
      keep.push_back(k);
      continue;
    }
    moved = true;
    if (c.i < 0) {  // a wall row (horizontal wall): the impulse in j's new frame
      r.n = sec.turn(r.n, -wj);
      r.pt = sec.turn(r.pt, -wj);
      c.key = wall_key(c.wall, r.j);
      keep.push_back(k);
      continue;
    }
    int image = r.image + wj - wi;
    r.n = sec.turn(r.n, -wi);
    r.pt = sec.turn(r.pt, -wi);
    if (image < -1 || image > 1) continue;
    if (image == -1 || (image == 0 && c.i > r.j)) {  // (i, j, k) is (j, i, −k) seen from j
      r.n = -sec.turn(r.n, -image);
      r.pt = -sec.turn(r.pt, -image);
      std::swap(c.i, r.j);
      std::swap(r.ri, r.rj);
      image = -image;
    }
    r.i = c.i;
    r.image = static_cast<std::int8_t>(image);
    c.key = pair_key(c.i, r.j, image);
    keep.push_back(k);
  }
  if (!moved) return;
  std::sort(keep.begin(), keep.end(), [&](std::size_t a, std::size_t b) { return info_[a].key < info_[b].key; });
  std::vector<ContactRow> rows;
  std::vector<ContactInfo> infos;
  rows.reserve(keep.size());
  infos.reserve(keep.size());
  for (std::size_t k : keep) {
    rows.push_back(contacts_[k]);
    infos.push_back(info_[k]);
  }
  contacts_.swap(rows);
  info_.swap(infos);
}

namespace detail {

/// The stopping logic of one step's sweeps, shared by the serial and the threaded loop.
/// Sweep `sweep` (1-based) is forward when odd. A sweep that meets the tolerance with
/// frozen rows skipped is followed by a check sweep over the frozen rows only: the step
/// has converged when none of them changes (the state is then the one the residual was
/// measured on); otherwise the changed rows are unfrozen and the normal sweeps go on.
/// The check sweeps count as sweeps.
struct SweepControl {
  SweepControl(const Options& o, StepDiagnostics& diag, std::size_t parts, double roundoff_dv)
      : opt(o), d(diag), part(parts), roundoff(roundoff_dv) {}
  const Options& opt;
  StepDiagnostics& d;
  std::vector<SweepTotals> part;  ///< per slab, then the rows across slabs
  bool check = false;             ///< the next sweep is a check sweep
  bool was_check = false;         ///< the sweep just finished was a check sweep
  Anderson* aa = nullptr;         ///< acceleration scratch (anderson_depth > 0)
  double roundoff = 0.0;          ///< a sweep correction √Σ|WΔP|² at or below this is round-off (m/s)
  bool converged = false;
  int iterations = 0;
  double residual = 0.0;

  /// Sums the parts of sweep `sweep`; true when the sweeps stop (converged or the cap).
  bool finish_sweep(int sweep) {
    SweepTotals sum;
    for (const SweepTotals& p : part) {  // fixed order: deterministic
      sum.dv2 += p.dv2;
      sum.wp2 += p.wp2;
      sum.updates += p.updates;
      sum.active += p.active;
      sum.skipped += p.skipped;
      sum.changed += p.changed;
    }
    d.row_updates += sum.updates;
    d.active_row_updates += sum.active;
    iterations = sweep;
    was_check = check;
    if (check) {
      check = false;
      if (sum.changed == 0) {
        converged = true;
        return true;
      }
    } else {
      d.frozen_skips += sum.skipped;
      residual = sum.wp2 > 0.0 ? std::sqrt(sum.dv2 / sum.wp2)
                               : (sum.dv2 > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
      if (residual <= opt.tolerance || std::sqrt(sum.dv2) <= roundoff) {
        if (sum.skipped == 0) {
          converged = true;
          return true;
        }
        check = true;
      }
    }
    return sweep >= opt.max_iterations;
  }
};

/// Anderson bookkeeping before a recording sweep (one thread): the slot of the new
/// difference column, when the previous sweep left F and G.
void anderson_before(Anderson& a) {
  ++a.iter;
  a.skip_below = a.iter - 1;  // quiet at the previous recording sweep: F and G are zeros
  if (a.have_prev) {
    a.push = (a.newest + 1) % a.m;
    a.newest = a.push;
    a.count = std::min(a.count + 1, a.m);
    // ... and the slot's old content is zero if it was quiet when the slot was last written
    a.skip_below = std::min(a.skip_below, a.last_push[a.push] - 1);
    a.last_push[a.push] = a.iter;
  } else {
    a.push = -1;
  }
}

void anderson_solve(Anderson& a, std::size_t parts);

/// After a sweep that did not stop the step (one thread): true when the impulses are to
/// be extrapolated (γ set). No extrapolation after a check sweep (F and G not recorded:
/// the columns restart), before one (it must see the state the residual was measured
/// on), and when the residual grew past twice the best since the last restart (the
/// extrapolation went astray: the columns restart). A step whose residual has not
/// reached a new low for kAndersonStall sweeps goes on with plain NLGS (the extrapolation
/// can cycle where rows switch between open and closed; NLGS then still converges).
constexpr int kAndersonStall = 50;
bool anderson_after(Anderson& a, const SweepControl& c, std::size_t parts) {
  if (a.off) return false;
  if (c.residual < a.best_step) {
    a.best_step = c.residual;
    a.since_best = 0;
  } else if (++a.since_best >= kAndersonStall) {
    a.off = true;
    return false;
  }
  auto restart = [&] {
    a.count = 0;
    a.newest = -1;
    a.best = c.residual;
  };
  if (c.was_check) {
    restart();
    a.have_prev = false;
    return false;
  }
  a.have_prev = true;
  if (c.check) return false;
  if (!(c.residual <= 2.0 * a.best)) {
    restart();
    return false;
  }
  a.best = std::min(a.best, c.residual);
  if (a.push < 0) return false;
  anderson_solve(a, parts);
  for (int j = 0; j < a.count; ++j)
    if (a.gamma[j] != 0.0) return true;
  return false;
}

/// The coefficients γ (one thread, after the gathers): the partial sums added in part
/// order (deterministic), the new Gram row stored, then (ΔFᵀDΔF + ε tr I) γ = ΔFᵀD F
/// with ε = 1e-10 against nearly dependent columns. γ = 0 (plain NLGS) without columns
/// or when the solve is not finite.
void anderson_solve(Anderson& a, std::size_t parts) {
  std::fill(std::begin(a.gamma), std::end(a.gamma), 0.0);
  const int m = a.m, n = a.count;
  double row[10] = {}, rhs[10] = {};
  for (std::size_t p = 0; p < parts; ++p) {
    const double* s = a.part.data() + p * static_cast<std::size_t>(2 * m);
    for (int j = 0; j < n; ++j) {
      row[j] += s[j];
      rhs[j] += s[m + j];
    }
  }
  for (int j = 0; j < n; ++j) a.H[a.push][j] = a.H[j][a.push] = row[j];
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 10, 10>;  // on the stack
  using SmallVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 10, 1>;
  Small M(n, n);
  SmallVec b(n);
  double trace = 0.0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) M(i, j) = a.H[i][j];
    b(i) = rhs[i];
    trace += a.H[i][i];
  }
  if (!(trace > 0.0)) return;
  M.diagonal().array() += 1e-10 * trace;
  const SmallVec g = M.ldlt().solve(b);
  if (!g.allFinite()) return;
  for (int j = 0; j < n; ++j) a.gamma[j] = g(j);
}

}  // namespace detail

// Stage 1 (before the search): the solver view with T wall sentinels (zero velocity,
// zero inverse mass), and the alert distance from the fastest sphere (mobile or
// kinematic) and one gravity step. Refuses a non-finite distance and one beyond
// kMaxAlertDiameters.
double World::contact_search_distance(std::int64_t this_step) {
  const double h = opt_.time_step;
  const std::size_t n = x_.size();
  body_.resize(n + static_cast<std::size_t>(opt_.threads));
  for (std::size_t s = n; s < body_.size(); ++s) body_[s] = SolverBody{};
  double vmax = 0.0, dmin = std::numeric_limits<double>::infinity();
  std::size_t fastest = 0;
  for (std::size_t b = 0; b < n; ++b) {
    const double speed = body_[b].v.norm() + radius_[b] * body_[b].w.norm();
    if (!(speed <= vmax)) {
      vmax = speed;
      fastest = b;
    }
    dmin = std::min(dmin, 2.0 * radius_[b]);
  }
  const double alert = 2.0 * (vmax + opt_.gravity.norm() * h) * h + opt_.alert_margin * (n ? dmin : 0.0);
  roundoff_dv_ = kRoundoffUlps * std::numeric_limits<double>::epsilon() * (vmax + opt_.gravity.norm() * h);
  if (!std::isfinite(alert))
    throw NoResultError(fmt::format(
        "sim diverged at step {}: non-finite alert distance from body {} (speed {} m/s)", this_step,
        fastest, vmax));
  // A body that moves several diameters in one step makes every pair within reach a
  // contact row (memory and time grow as n^2) and the step is meaningless anyway.
  if (n && alert > kMaxAlertDiameters * dmin)
    throw NoResultError(fmt::format(
        "sim: time step too large at step {}: the contact search reaches {:.3g} d (body {} at {:.3g} m/s, "
        "|g| h = {:.3g} m/s); expected at most {} d: lower sim.time_step_s",
        this_step, alert / dmin, fastest, vmax, opt_.gravity.norm() * h, kMaxAlertDiameters));
  return alert;
}

// Stage 2: free velocities, v <- v + h g for mobile spheres.
void World::add_free_velocities() {
  const double h = opt_.time_step;
  for (std::size_t b = 0; b < x_.size(); ++b)
    if (kind_[b] == BodyKind::kMobile) body_[b].v += h * opt_.gravity;
}

void World::sweep_serial(detail::SweepControl& c) {
  detail::Anderson* const aa = c.aa;
  for (int sweep = 1;; ++sweep) {
    c.part[0] = SweepTotals{};
    detail::Anderson* const rec = aa && !c.check && !aa->off ? aa : nullptr;
    sweep_lists(lists_[0], !opt_.alternate_sweeps || sweep % 2 == 1, sweep, c.check, c.part[0], rec,
                rec ? rec->part.data() : nullptr);
    if (c.finish_sweep(sweep)) break;
    if (aa) {
      if (detail::anderson_after(*aa, c, 1)) anderson_apply(lists_[0], *aa, sweep);
      if (!c.check) detail::anderson_before(*aa);
    }
  }
}

// Slabs in parallel, then the rows across slabs on one thread (before the slabs in
// backward sweeps). Two to three barriers per sweep: OpenMP's own barriers put a waiting
// thread to sleep after a short spin, and the wake-up costs milliseconds on a virtual
// machine (measured: 15 000 beads, 2 threads, 0.9 s per step against 0.1 s serial), so
// the sweep loop synchronises through a spinning barrier (SpinBarrier) instead.
void World::sweep_parallel(detail::SweepControl& c, int rows) {
  const int T = opt_.threads;
  bool stop = false, extrapolate = false;
  const std::size_t boundary = static_cast<std::size_t>(T);
  detail::Anderson* const aa = c.aa;
  const std::size_t width = aa ? static_cast<std::size_t>(2 * aa->m) : 0;
  auto sums = [&](detail::Anderson* rec, std::size_t part) { return rec ? rec->part.data() + part * width : nullptr; };
  SpinBarrier barrier;
  // Small problems run the same slabs on one thread (the same bits: the slabs share no
  // body), since waking the pool each step costs more than the sweep saves there.
  const int workers =
      static_cast<std::int64_t>(rows) >= static_cast<std::int64_t>(opt_.parallel_min_rows_per_thread) * T ? T : 1;
#pragma omp parallel num_threads(workers)
  {
#pragma omp single
    barrier.reset(omp_get_num_threads());
    const int nthreads = omp_get_num_threads();
    const int me = omp_get_thread_num();
    for (int sweep = 1;; ++sweep) {
      const bool forward = !opt_.alternate_sweeps || sweep % 2 == 1;
      detail::Anderson* const rec = aa && !c.check && !aa->off ? aa : nullptr;
      if (!forward) {
        if (me == 0) sweep_lists(lists_[boundary], false, sweep, c.check, c.part[boundary], rec, sums(rec, boundary));
        barrier.wait();
      }
      for (int s = me; s < T; s += nthreads) {
        const std::size_t p = static_cast<std::size_t>(s);
        sweep_lists(lists_[p], forward, sweep, c.check, c.part[p], rec, sums(rec, p));
      }
      barrier.wait();
      if (me == 0) {
        if (forward) sweep_lists(lists_[boundary], true, sweep, c.check, c.part[boundary], rec, sums(rec, boundary));
        stop = c.finish_sweep(sweep);
        extrapolate = false;
        if (!stop && aa) {
          extrapolate = detail::anderson_after(*aa, c, boundary + 1);
          if (!c.check) detail::anderson_before(*aa);
        }
      }
      barrier.wait();
      if (stop) break;
      if (extrapolate) {  // the slabs, then the rows across them (they share bodies)
        for (int s = me; s < T; s += nthreads) anderson_apply(lists_[static_cast<std::size_t>(s)], *aa, sweep);
        barrier.wait();
        if (me == 0) anderson_apply(lists_[boundary], *aa, sweep);
        barrier.wait();
      }
    }
  }
}

// Stage 4: nonlinear Gauss-Seidel sweeps until the tolerance or max_iterations.
void World::solve(StepDiagnostics& d) {
  bool any_rows = false;
  for (const RowLists& l : lists_) any_rows = any_rows || !l.contacts.empty() || !l.ropes.empty() || !l.angles.empty();
  if (!any_rows) return;
  detail::SweepControl c(opt_, d, static_cast<std::size_t>(opt_.threads) + 1, roundoff_dv_);
  detail::Anderson aa;
  if (opt_.anderson_depth > 0) {
    anderson_begin(aa);
    detail::anderson_before(aa);
    c.aa = &aa;
  }
  if (opt_.threads == 1) sweep_serial(c);
  else sweep_parallel(c, d.rows);
  if (c.aa) aa_buf_.swap(aa.buf);
  if (!c.converged) {
    d.hit_iteration_cap = true;
    ++cap_hits_;
  }
  d.iterations = c.iterations;
  d.residual = c.residual;
}

// Stage 6: the final impulses, keyed, for the next step's warm start.
void World::remember_impulses() {
  previous_.resize(contacts_.size());
  for (std::size_t k = 0; k < contacts_.size(); ++k)
    previous_[k] = {info_[k].key, contacts_[k].pn, contacts_[k].pt, contacts_[k].status};
}

StepDiagnostics World::step() {
  static_assert(sizeof(SolverBody) == 64, "one cache line per body");
  static_assert(sizeof(ContactRow) == 128, "two cache lines per contact row");
  const std::int64_t this_step = step_ + 1;
  drive_rotors();
  find_contacts(contact_search_distance(this_step));  // 1. contact detection
  add_free_velocities();                              // 2. free velocities
  prepare_rows();                                     // 3. warm start
  partition_rows();
  StepDiagnostics d;                                  // 4. solve
  d.step = this_step;
  d.rows = static_cast<int>(contacts_.size() + ropes_.size() + angles_.size());
  solve(d);
  rotor_torques();
  integrate_positions();                              // 5. positions
  step_ = this_step;                                  // 6. diagnostics
  place_rotors();                                     //    (rotors at φ(t + h) exactly)
  wrap_sector();
  remember_impulses();
  check_state(d);
  return d;
}

void World::check_state(StepDiagnostics& d) const {
  const std::size_t n = x_.size();
  const detail::Sector sec(opt_);
  if (sec.on)  // fixed and kinematic bodies must stay inside the wedge (they have no wrap)
    for (std::size_t b = 0; b < n; ++b)
      if (kind_[b] == BodyKind::kKinematic && sec.wedges(x_[b]) != 0)
        throw NoResultError(fmt::format("sim at step {}: kinematic body {} at ({}, {}, {}) left the periodic sector "
                                        "(azimuth [{}, {}) rad)",
                                        d.step, b, x_[b].x(), x_[b].y(), x_[b].z(), sec.start, sec.start + sec.width));
  for (std::size_t b = 0; b < n; ++b) {
    const SolverBody& sb = body_[b];
    if (!finite(x_[b]) || !finite(sb.v) || !finite(sb.w))
      throw NoResultError(fmt::format("sim diverged at step {}: non-finite state of body {}", d.step, b));
    if (kind_[b] == BodyKind::kMobile)
      d.kinetic_energy += 0.5 * mass_[b] * sb.v.squaredNorm() + 0.5 * inertia_[b] * sb.w.squaredNorm();
  }
  // Contacts: status counts from the final sweep, overlaps at the new positions.
  double worst = 0.0;
  std::size_t worst_row = contacts_.size();
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    const ContactRow& r = contacts_[k];
    const ContactInfo& c = info_[k];
    ++d.contacts;
    if (r.pn > 0.0) {
      ++d.active_contacts;
      if (r.status == ContactStatus::kSliding) ++d.sliding_contacts;
      else ++d.sticking_contacts;
    }
    const auto j = static_cast<std::size_t>(r.j);
    double gap = 0.0, dia = 0.0;
    if (c.i >= 0) {
      const auto i = static_cast<std::size_t>(c.i);
      gap = (sec.place(x_[j], r.image) - x_[i]).norm() - radius_[i] - radius_[j];
      dia = radius_[i] + radius_[j];
    } else {
      const Wall& wall = walls_[static_cast<std::size_t>(c.wall)];
      gap = (x_[j] - wall.point).dot(wall.normal) - radius_[j];
      dia = 2.0 * radius_[j];
    }
    const double ov = -gap / dia;
    if (ov > worst) {
      worst = ov;
      worst_row = k;
    }
  }
  d.max_overlap = worst;
  if (worst_row < contacts_.size() && worst > opt_.max_overlap) {
    const ContactInfo& c = info_[worst_row];
    const int j = contacts_[worst_row].j;
    if (c.i >= 0)
      throw NoResultError(fmt::format(
          "sim diverged at step {}: overlap {:.4g} d between bodies {} and {} (limit {} d)", d.step,
          worst, c.i, j, opt_.max_overlap));
    throw NoResultError(fmt::format(
        "sim diverged at step {}: overlap {:.4g} d between body {} and wall {} (limit {} d)", d.step,
        worst, j, c.wall, opt_.max_overlap));
  }
  for (const RopeRow& r : ropes_) d.active_ropes += r.lambda > 0.0 ? 1 : 0;
  const auto [rope_excess, worst_rope] = largest_excess(ropes_, [&](const RopeRow& r) {
    const auto i = static_cast<std::size_t>(r.i), j = static_cast<std::size_t>(r.j);
    return ((sec.place(x_[j], r.image) - x_[i]).norm() - r.max_length) / (radius_[i] + radius_[j]);
  });
  d.max_rope_excess = rope_excess;
  if (worst_rope != nullptr && rope_excess > opt_.max_rope_excess)
    throw NoResultError(fmt::format(
        "sim diverged at step {}: rope between bodies {} and {} stretched {:.4g} d beyond its "
        "length (limit {} d)",
        d.step, worst_rope->i, worst_rope->j, rope_excess, opt_.max_rope_excess));
  for (const AngleRow& r : angles_) d.active_angles += r.lambda > 0.0 ? 1 : 0;
  const auto [angle_excess, worst_angle] = largest_excess(angles_, [&](const AngleRow& r) {
    const auto a = static_cast<std::size_t>(r.a), b = static_cast<std::size_t>(r.b),
               c = static_cast<std::size_t>(r.c);
    const Vec3 b1 = x_[b] - sec.place(x_[a], r.image_a), b2 = sec.place(x_[c], r.image_c) - x_[b];
    const double l = b1.norm() * b2.norm();
    if (!(l > 0.0)) return 0.0;
    return std::acos(std::clamp(b1.dot(b2) / l, -1.0, 1.0)) - r.max_angle;
  });
  d.max_angle_excess = angle_excess;
  if (worst_angle != nullptr && angle_excess > opt_.max_angle_excess)
    throw NoResultError(fmt::format(
        "sim diverged at step {}: turning angle at body {} (chain {}-{}-{}) exceeds its limit by "
        "{:.4g} deg (limit {:.4g} deg)",
        d.step, worst_angle->b, worst_angle->a, worst_angle->b, worst_angle->c,
        angle_excess * 180.0 / std::numbers::pi, opt_.max_angle_excess * 180.0 / std::numbers::pi));
}

ContactRecord World::record(std::size_t k) const {
  const ContactRow& r = contacts_[k];
  ContactRecord c;
  c.body_i = info_[k].i;
  c.wall = info_[k].wall;
  c.body_j = r.j;
  c.normal = r.n;
  c.gap = info_[k].gap;
  c.normal_impulse = r.pn;
  c.tangential_impulse = r.pt;
  c.status = r.status;  // raw: the status of the last visit
  c.image = r.image;
  return c;
}

std::vector<ContactRecord> World::contacts() const {
  std::vector<ContactRecord> out;
  out.reserve(contacts_.size());
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    out.push_back(record(k));
    if (!(contacts_[k].pn > 0.0)) out.back().status = ContactStatus::kOpen;
  }
  return out;
}

double Rotor::angle(double t) const {
  return phi0 * std::sin(2.0 * std::numbers::pi * f_Hz * (t - t_start) + phase);
}

namespace {

/// c + R(φ) (x₀ − c) and R(φ) q₀ for a rotor sphere.
Vec3 rotor_position(const Rotor& r, std::size_t k, double phi) {
  return r.centre + Eigen::AngleAxisd(phi, r.axis) * (r.reference[k] - r.centre);
}

void check_drive(double phi0, double f_Hz, double phase, double t_start) {
  if (!std::isfinite(phi0) || !(f_Hz >= 0.0) || !std::isfinite(f_Hz) || !std::isfinite(phase) ||
      !std::isfinite(t_start))
    throw ConfigError(fmt::format("sim rotor: drive phi0 = {} rad, f = {} Hz, phase = {}, t_start = {} s: expected "
                                  "finite values, f >= 0",
                                  phi0, f_Hz, phase, t_start));
}

}  // namespace

int World::add_rotor(std::span<const int> bodies, const Vec3& centre, const Vec3& axis, double phi0, double f_Hz,
                     double phase, double t_start) {
  check_drive(phi0, f_Hz, phase, t_start);
  if (!finite(centre) || !finite(axis) || !(axis.norm() > 0.0))
    throw ConfigError("sim rotor: the axis needs a finite point and a non-zero direction");
  if (bodies.empty()) throw ConfigError("sim rotor: no body");
  if (opt_.sectors != 0 && (axis.x() != 0.0 || axis.y() != 0.0 || centre.x() != opt_.sector_centre.x() ||
                            centre.y() != opt_.sector_centre.y()))
    throw ConfigError("sim rotor: in a periodic sector the rotor turns about the sector's axis (vertical, through "
                      "sector_centre)");
  rotor_of_.resize(x_.size(), -1);
  Rotor r;
  r.centre = centre;
  r.axis = axis.normalized();
  r.phi0 = phi0;
  r.f_Hz = f_Hz;
  r.phase = phase;
  r.t_start = t_start;
  const double phi = r.angle(time());
  const Eigen::AngleAxisd back(-phi, r.axis);
  for (int b : bodies) {
    check_body(b, "rotor");
    const auto ub = static_cast<std::size_t>(b);
    if (kind_[ub] != BodyKind::kKinematic)
      throw ConfigError(fmt::format("sim rotor: body {} is not kinematic", b));
    if (rotor_of_[ub] != -1) throw ConfigError(fmt::format("sim rotor: body {} is already in rotor {}", b, rotor_of_[ub]));
    rotor_of_[ub] = static_cast<int>(rotors_.size());
    r.bodies.push_back(b);
    r.reference.push_back(centre + back * (x_[ub] - centre));
    r.reference_orientation.push_back((Eigen::Quaterniond(back) * q_[ub]).normalized());
  }
  rotors_.push_back(std::move(r));
  rotor_torque_.push_back(0.0);
  return static_cast<int>(rotors_.size()) - 1;
}

void World::set_rotor_drive(int ri, double phi0, double f_Hz, double phase, double t_start) {
  check_drive(phi0, f_Hz, phase, t_start);
  Rotor& r = rotors_.at(static_cast<std::size_t>(ri));
  r.phi0 = phi0;
  r.f_Hz = f_Hz;
  r.phase = phase;
  r.t_start = t_start;
  place_rotors();
}

double World::rotor_angle(int r) const { return rotors_.at(static_cast<std::size_t>(r)).angle(time()); }

double World::rotor_torque(int r) const { return rotor_torque_.at(static_cast<std::size_t>(r)); }

void World::drive_rotors() {
  const double h = opt_.time_step;
  const double t0 = time(), t1 = static_cast<double>(step_ + 1) * h;
  for (const Rotor& r : rotors_) {
    const double p0 = r.angle(t0), p1 = r.angle(t1);
    const Vec3 w = (p1 - p0) / h * r.axis;
    for (std::size_t k = 0; k < r.bodies.size(); ++k) {
      SolverBody& sb = body_[static_cast<std::size_t>(r.bodies[k])];
      sb.v = (rotor_position(r, k, p1) - rotor_position(r, k, p0)) / h;
      sb.w = w;
    }
  }
}

void World::place_rotors() {
  const double t = time();
  for (const Rotor& r : rotors_) {
    const double phi = r.angle(t);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(phi, r.axis));
    for (std::size_t k = 0; k < r.bodies.size(); ++k) {
      const auto b = static_cast<std::size_t>(r.bodies[k]);
      x_[b] = rotor_position(r, k, phi);
      q_[b] = (q * r.reference_orientation[k]).normalized();
    }
  }
}

void World::rotor_torques() {
  if (rotors_.empty()) return;
  std::fill(rotor_torque_.begin(), rotor_torque_.end(), 0.0);
  const double h = opt_.time_step;
  const int n = static_cast<int>(x_.size());
  for (const ContactRow& c : contacts_) {
    if (c.i >= n) continue;  // wall rows: rotor spheres have none
    const int ri = rotor_of_[static_cast<std::size_t>(c.i)], rj = rotor_of_[static_cast<std::size_t>(c.j)];
    if (ri < 0 && rj < 0) continue;
    const Vec3 P = c.pn * c.n + c.pt;  // on j; −P on i
    const Vec3 p = x_[static_cast<std::size_t>(c.i)] + c.ri * c.n;  // contact point
    // The drive balances the beads' push: motor torque = −(torque of the beads on the rotor).
    if (ri >= 0) {
      const Rotor& r = rotors_[static_cast<std::size_t>(ri)];
      rotor_torque_[static_cast<std::size_t>(ri)] += ((p - r.centre).cross(P)).dot(r.axis) / h;
    }
    if (rj >= 0) {
      const Rotor& r = rotors_[static_cast<std::size_t>(rj)];
      rotor_torque_[static_cast<std::size_t>(rj)] -= ((p - r.centre).cross(P)).dot(r.axis) / h;
    }
  }
}

WorldState at_time_step(WorldState s, double h) {
  const double ratio = h / s.options.time_step;
  s.options.time_step = h;
  for (auto& c : s.contacts) {
    c.normal_impulse *= ratio;
    c.tangential_impulse *= ratio;
  }
  for (auto& r : s.ropes) r.impulse *= ratio;
  for (auto& a : s.angles) a.impulse *= ratio;
  return s;
}

WorldState World::state() const {
  WorldState s;
  s.options = opt_;
  s.step = step_;
  s.iteration_cap_hits = cap_hits_;
  s.position = x_;
  s.orientation = q_;
  const std::size_t n = x_.size();
  s.velocity.reserve(n);
  s.angular_velocity.reserve(n);
  for (std::size_t b = 0; b < n; ++b) {
    s.velocity.push_back(body_[b].v);
    s.angular_velocity.push_back(body_[b].w);
  }
  s.diameter.reserve(radius_.size());
  for (double r : radius_) s.diameter.push_back(2.0 * r);
  s.mass = mass_;
  s.inertia = inertia_;
  s.kind = kind_;
  s.walls = walls_;
  for (const RopeRow& r : ropes_) s.ropes.push_back({r.i, r.j, r.max_length, r.lambda, r.image});
  for (const AngleRow& r : angles_) s.angles.push_back({r.a, r.b, r.c, r.max_angle, r.lambda, r.image_a, r.image_c});
  s.contacts.reserve(contacts_.size());
  for (std::size_t k = 0; k < contacts_.size(); ++k) s.contacts.push_back(record(k));
  s.rotors = rotors_;
  return s;
}

World World::from_state(const WorldState& s) {
  World w(s.options);
  const std::size_t n = s.position.size();
  auto bad = [](const std::string& what) { throw ConfigError("sim state: " + what); };
  if (s.velocity.size() != n || s.angular_velocity.size() != n || s.diameter.size() != n ||
      s.mass.size() != n || s.inertia.size() != n || s.kind.size() != n ||
      (!s.orientation.empty() && s.orientation.size() != n))
    bad(fmt::format("body arrays of different lengths ({} positions)", n));
  if (n > static_cast<std::size_t>(std::numeric_limits<int>::max())) bad("too many bodies");
  if (s.step < 0 || s.iteration_cap_hits < 0) bad("negative step count");
  for (std::size_t b = 0; b < n; ++b) {
    const BodyKind k = s.kind[b];
    if (k != BodyKind::kMobile && k != BodyKind::kFixed && k != BodyKind::kKinematic)
      bad(fmt::format("body {}: unknown kind {}", b, static_cast<int>(k)));
    if (!finite(s.position[b]) || !finite(s.velocity[b]) || !finite(s.angular_velocity[b]))
      bad(fmt::format("body {}: non-finite position or velocity", b));
    if (!(s.diameter[b] > 0.0) || !std::isfinite(s.diameter[b]) || !(s.mass[b] > 0.0) ||
        !std::isfinite(s.mass[b]) || !(s.inertia[b] > 0.0) || !std::isfinite(s.inertia[b]))
      bad(fmt::format("body {}: diameter, mass and inertia must be positive and finite", b));
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    if (!s.orientation.empty()) {
      q = s.orientation[b];
      const double qn = q.norm();
      if (!std::isfinite(qn) || std::abs(qn - 1.0) > 1e-6)
        bad(fmt::format("body {}: orientation quaternion of norm {} (expected 1)", b, qn));
    }
    w.x_.push_back(s.position[b]);
    w.q_.push_back(q);  // as stored: renormalising could change the bits
    SolverBody sb;
    sb.v = s.velocity[b];
    sb.w = s.angular_velocity[b];
    sb.inv_mass = k == BodyKind::kMobile ? 1.0 / s.mass[b] : 0.0;
    sb.inv_inertia = k == BodyKind::kMobile ? 1.0 / s.inertia[b] : 0.0;
    w.body_.push_back(sb);
    w.radius_.push_back(0.5 * s.diameter[b]);
    w.mass_.push_back(s.mass[b]);
    w.inertia_.push_back(s.inertia[b]);
    w.kind_.push_back(k);
  }
  for (const Wall& wall : s.walls) {
    if (!finite(wall.point) || !finite(wall.normal) || !(wall.normal.norm() > 0.0) ||
        !(wall.friction >= 0.0) || !std::isfinite(wall.friction))
      bad(fmt::format("wall {}: non-finite point, zero normal or bad friction", w.walls_.size()));
    w.walls_.push_back(wall);  // as stored: renormalising could change the bits
  }
  for (const WorldState::Rope& r : s.ropes) {
    w.add_rope(r.i, r.j, r.max_length);
    if (!(r.impulse >= 0.0) || !std::isfinite(r.impulse)) bad("rope impulse negative or non-finite");
    if (r.image < -1 || r.image > 1 || (r.image != 0 && s.options.sectors == 0))
      bad(fmt::format("rope {}-{}: image {} (expected 0, or -1..1 in a periodic sector)", r.i, r.j, r.image));
    w.ropes_.back().lambda = r.impulse;
    w.ropes_.back().image = static_cast<std::int8_t>(r.image);
  }
  for (const WorldState::Angle& a : s.angles) {
    w.add_angle_limit(a.prev, a.mid, a.next, a.max_angle);
    if (!(a.impulse >= 0.0) || !std::isfinite(a.impulse)) bad("angle impulse negative or non-finite");
    for (const int k : {a.image_prev, a.image_next})
      if (k < -1 || k > 1 || (k != 0 && s.options.sectors == 0))
        bad(fmt::format("angle row at {}: image {} (expected 0, or -1..1 in a periodic sector)", a.mid, k));
    w.angles_.back().lambda = a.impulse;
    w.angles_.back().image_a = static_cast<std::int8_t>(a.image_prev);
    w.angles_.back().image_c = static_cast<std::int8_t>(a.image_next);
  }
  const int nb = static_cast<int>(n);
  std::uint64_t last_key = 0;
  for (std::size_t k = 0; k < s.contacts.size(); ++k) {
    const ContactRecord& c = s.contacts[k];
    if (c.body_j < 0 || c.body_j >= nb) bad(fmt::format("contact {}: body {} out of range", k, c.body_j));
    const bool wall_row = c.body_i < 0;
    if (c.image != 0 && (c.image != 1 || wall_row || s.options.sectors == 0))
      bad(fmt::format("contact {}: image {} (expected 0, or 1 for a body pair in a periodic sector)", k, c.image));
    if (wall_row ? (c.wall < 0 || c.wall >= static_cast<int>(w.walls_.size()))
                 : (c.image == 0 ? c.body_i >= c.body_j : c.body_i == c.body_j) || c.wall != -1 || c.body_i >= nb)
      bad(fmt::format("contact {}: neither a body pair i < j (i != j across a seam) nor a body-wall row", k));
    if (!finite(c.normal) || !std::isfinite(c.gap) || !std::isfinite(c.normal_impulse) ||
        !finite(c.tangential_impulse))
      bad(fmt::format("contact {}: non-finite value", k));
    const std::uint64_t key = wall_row ? wall_key(c.wall, c.body_j) : pair_key(c.body_i, c.body_j, c.image);
    if (k > 0 && !(last_key < key)) bad(fmt::format("contact {}: rows not in the engine's order", k));
    last_key = key;
    // Only the warm-start data and the records matter: the rows are rebuilt every step.
    ContactRow r;
    r.i = wall_row ? nb : c.body_i;
    r.j = c.body_j;
    r.n = c.normal;
    r.pn = c.normal_impulse;
    r.pt = c.tangential_impulse;
    r.status = c.status;
    r.image = static_cast<std::int8_t>(c.image);
    w.contacts_.push_back(r);
    w.info_.push_back({key, wall_row ? -1 : c.body_i, wall_row ? c.wall : -1, c.gap});
    w.previous_.push_back({key, r.pn, r.pt, r.status});
  }
  w.step_ = s.step;
  w.cap_hits_ = s.iteration_cap_hits;
  w.rotor_of_.assign(n, -1);
  for (std::size_t ri = 0; ri < s.rotors.size(); ++ri) {
    const Rotor& r = s.rotors[ri];
    check_drive(r.phi0, r.f_Hz, r.phase, r.t_start);
    if (r.reference.size() != r.bodies.size() || r.reference_orientation.size() != r.bodies.size() ||
        !finite(r.centre) || !finite(r.axis) || !(std::abs(r.axis.norm() - 1.0) < 1e-9))
      bad(fmt::format("rotor {}: inconsistent arrays, a non-finite centre or a non-unit axis", ri));
    for (std::size_t k = 0; k < r.bodies.size(); ++k) {
      const int b = r.bodies[k];
      if (b < 0 || b >= nb || s.kind[static_cast<std::size_t>(b)] != BodyKind::kKinematic ||
          w.rotor_of_[static_cast<std::size_t>(b)] != -1 || !finite(r.reference[k]))
        bad(fmt::format("rotor {}: body {} out of range, not kinematic, in two rotors or non-finite", ri, b));
      w.rotor_of_[static_cast<std::size_t>(b)] = static_cast<int>(ri);
    }
    w.rotors_.push_back(r);  // positions as stored: they are the rotor's at this step
    w.rotor_torque_.push_back(0.0);
  }
  return w;
}

std::uint64_t World::state_hash() const {
  Fnv f;
  f.u(static_cast<std::uint64_t>(step_));
  for (std::size_t b = 0; b < x_.size(); ++b) {
    f.v(x_[b]);
    f.v(body_[b].v);
    f.v(body_[b].w);
    f.d(q_[b].w());
    f.d(q_[b].x());
    f.d(q_[b].y());
    f.d(q_[b].z());
  }
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    f.u(info_[k].key);
    f.d(contacts_[k].pn);
    f.v(contacts_[k].pt);
  }
  for (const RopeRow& r : ropes_) f.d(r.lambda);
  for (const AngleRow& r : angles_) f.d(r.lambda);
  if (opt_.sectors != 0) {  // the seams' image offsets (none without a sector: the hashes stay)
    for (const RopeRow& r : ropes_) f.u(static_cast<std::uint64_t>(r.image + 1));
    for (const AngleRow& r : angles_) f.u(static_cast<std::uint64_t>(3 * (r.image_a + 1) + r.image_c + 1));
  }
  return f.h;
}

}  // namespace shearzone::sim
