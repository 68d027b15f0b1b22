// The contact-dynamics engine: see shearzone/sim/world.hpp for the model.
#include "shearzone/sim/world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/check.hpp"
#include "shearzone/core/error.hpp"

namespace shearzone::sim {
namespace {

bool finite(const Vec3& a) { return std::isfinite(a.x()) && std::isfinite(a.y()) && std::isfinite(a.z()); }

constexpr std::uint64_t kWallKeyBit = std::uint64_t{1} << 63;

std::uint64_t pair_key(int i, int j) {
  return (static_cast<std::uint64_t>(i) << 32) | static_cast<std::uint64_t>(j);
}
std::uint64_t wall_key(int w, int j) {
  return kWallKeyBit | (static_cast<std::uint64_t>(w) << 32) | static_cast<std::uint64_t>(j);
}

/// Relative straight-chain guard on W_a (§0b item 10): below it the angle row is
/// treated as inactive (sin θ ≈ 0, the constraint cannot bind within one step).
constexpr double kAngleGuard = 1e-12;

struct Fnv {
  std::uint64_t h = 1469598103934665603ULL;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t k = 0; k < n; ++k) {
      h ^= c[k];
      h *= 1099511628211ULL;
    }
  }
  void d(double a) { bytes(&a, sizeof a); }
  void v(const Vec3& a) {
    d(a.x());
    d(a.y());
    d(a.z());
  }
  void u(std::uint64_t a) { bytes(&a, sizeof a); }
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
}

int World::add_sphere(const Vec3& position, double diameter, double density, BodyKind kind) {
  if (!finite(position))
    throw ConfigError(fmt::format("sim sphere {}: non-finite position", x_.size()));
  if (!(diameter > 0.0) || !std::isfinite(diameter))
    throw ConfigError(fmt::format("sim sphere {}: diameter {} (expected > 0)", x_.size(), diameter));
  if (!(density > 0.0) || !std::isfinite(density))
    throw ConfigError(fmt::format("sim sphere {}: density {} (expected > 0)", x_.size(), density));
  SHEARZONE_CHECK(x_.size() < static_cast<std::size_t>(std::numeric_limits<int>::max()));
  const double m = density * std::numbers::pi * diameter * diameter * diameter / 6.0;
  const double inertia = m * diameter * diameter / 10.0;
  x_.push_back(position);
  v_.push_back(Vec3::Zero());
  w_.push_back(Vec3::Zero());
  radius_.push_back(0.5 * diameter);
  mass_.push_back(m);
  inertia_.push_back(inertia);
  inv_mass_.push_back(kind == BodyKind::mobile ? 1.0 / m : 0.0);
  inv_inertia_.push_back(kind == BodyKind::mobile ? 1.0 / inertia : 0.0);
  kind_.push_back(kind);
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
  walls_.push_back(w);
  return static_cast<int>(walls_.size()) - 1;
}

void World::check_body(int b, const char* what) const {
  if (b < 0 || b >= body_count())
    throw ConfigError(fmt::format("sim {}: body {} does not exist ({} bodies)", what, b, body_count()));
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
  if (kind_[static_cast<std::size_t>(body)] == BodyKind::fixed)
    throw ConfigError(fmt::format("sim body {} is fixed: its velocity is zero", body));
  if (!finite(v)) throw ConfigError(fmt::format("sim body {}: non-finite velocity", body));
  v_[static_cast<std::size_t>(body)] = v;
}

void World::set_angular_velocity(int body, const Vec3& omega) {
  check_body(body, "angular velocity");
  if (kind_[static_cast<std::size_t>(body)] == BodyKind::fixed)
    throw ConfigError(fmt::format("sim body {} is fixed: its angular velocity is zero", body));
  if (!finite(omega)) throw ConfigError(fmt::format("sim body {}: non-finite angular velocity", body));
  w_[static_cast<std::size_t>(body)] = omega;
}

// Uniform cell grid over the bounding box of all spheres (cell ≥ d_max + alert), rebuilt
// every step; the contact list comes out sorted by key (i < j pairs, then wall rows).
void World::find_contacts(double alert) {
  const std::size_t n = x_.size();
  contacts_.clear();
  if (n == 0) return;
  double rmax = 0.0;
  Vec3 lo = x_[0], hi = x_[0];
  for (std::size_t b = 0; b < n; ++b) {
    rmax = std::max(rmax, radius_[b]);
    lo = lo.cwiseMin(x_[b]);
    hi = hi.cwiseMax(x_[b]);
  }
  double cell = 2.0 * rmax + alert;
  std::array<std::int64_t, 3> dims{};
  const double max_cells = 4.0 * static_cast<double>(n) + 64.0;
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
  cell_of_.resize(n);
  cell_start_.assign(static_cast<std::size_t>(ncell) + 1, 0);
  for (std::size_t b = 0; b < n; ++b) {
    const std::int64_t c = (coord(x_[b], 2) * dims[1] + coord(x_[b], 1)) * dims[0] + coord(x_[b], 0);
    cell_of_[b] = static_cast<int>(c);
    ++cell_start_[static_cast<std::size_t>(c) + 1];
  }
  for (std::int64_t c = 0; c < ncell; ++c)
    cell_start_[static_cast<std::size_t>(c) + 1] += cell_start_[static_cast<std::size_t>(c)];
  cell_bodies_.resize(n);
  {
    std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t b = 0; b < n; ++b) cell_bodies_[static_cast<std::size_t>(fill[static_cast<std::size_t>(cell_of_[b])]++)] = static_cast<int>(b);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const bool mi = kind_[i] == BodyKind::mobile;
    const std::int64_t cx = coord(x_[i], 0), cy = coord(x_[i], 1), cz = coord(x_[i], 2);
    for (std::int64_t z = std::max<std::int64_t>(cz - 1, 0); z <= std::min(cz + 1, dims[2] - 1); ++z)
      for (std::int64_t y = std::max<std::int64_t>(cy - 1, 0); y <= std::min(cy + 1, dims[1] - 1); ++y)
        for (std::int64_t xx = std::max<std::int64_t>(cx - 1, 0); xx <= std::min(cx + 1, dims[0] - 1);
             ++xx) {
          const auto c = static_cast<std::size_t>((z * dims[1] + y) * dims[0] + xx);
          for (int s = cell_start_[c]; s < cell_start_[c + 1]; ++s) {
            const auto j = static_cast<std::size_t>(cell_bodies_[static_cast<std::size_t>(s)]);
            if (j <= i) continue;
            if (!mi && kind_[j] != BodyKind::mobile) continue;
            const Vec3 dx = x_[j] - x_[i];
            const double dist = dx.norm();
            const double gap = dist - radius_[i] - radius_[j];
            if (gap >= alert) continue;
            ContactRow r;
            r.i = static_cast<int>(i);
            r.j = static_cast<int>(j);
            r.key = pair_key(r.i, r.j);
            // Coincident centres: any normal is as good as another; pick +z.
            r.n = dist > 0.0 ? Vec3(dx / dist) : Vec3(Vec3::UnitZ());
            r.gap = gap;
            r.ri = radius_[i];
            r.rj = radius_[j];
            r.wn = inv_mass_[i] + inv_mass_[j];
            r.wt = r.wn + r.ri * r.ri * inv_inertia_[i] + r.rj * r.rj * inv_inertia_[j];
            r.mu = opt_.friction;
            contacts_.push_back(r);
          }
        }
  }
  std::sort(contacts_.begin(), contacts_.end(),
            [](const ContactRow& a, const ContactRow& b) { return a.key < b.key; });
  for (std::size_t w = 0; w < walls_.size(); ++w) {
    const Wall& wall = walls_[w];
    for (std::size_t j = 0; j < n; ++j) {
      if (kind_[j] != BodyKind::mobile) continue;
      const double gap = (x_[j] - wall.point).dot(wall.normal) - radius_[j];
      if (gap >= alert) continue;
      ContactRow r;
      r.wall = static_cast<int>(w);
      r.j = static_cast<int>(j);
      r.key = wall_key(r.wall, r.j);
      r.n = wall.normal;
      r.gap = gap;
      r.rj = radius_[j];
      r.wn = inv_mass_[j];
      r.wt = r.wn + r.rj * r.rj * inv_inertia_[j];
      r.mu = wall.friction;
      contacts_.push_back(r);
    }
  }
}

void World::apply_contact(const ContactRow& r, const Vec3& p) {
  const auto j = static_cast<std::size_t>(r.j);
  const Vec3 np = r.n.cross(p);
  v_[j] += inv_mass_[j] * p;
  w_[j] -= (inv_inertia_[j] * r.rj) * np;
  if (r.i >= 0) {
    const auto i = static_cast<std::size_t>(r.i);
    v_[i] -= inv_mass_[i] * p;
    w_[i] -= (inv_inertia_[i] * r.ri) * np;
  }
}

// Row geometry at x(t) and the warm start (impulses of the previous step, applied).
void World::prepare_rows() {
  // Contacts: merge-join with the previous step's rows (both sorted by key).
  std::size_t p = 0;
  for (ContactRow& r : contacts_) {
    while (p < previous_.size() && previous_[p].key < r.key) ++p;
    if (p < previous_.size() && previous_[p].key == r.key) {
      r.pn = previous_[p].pn;
      r.pt = previous_[p].pt - previous_[p].pt.dot(r.n) * r.n;
      r.status = previous_[p].status;
      if (r.pn > 0.0 || r.pt.squaredNorm() > 0.0) apply_contact(r, r.pn * r.n + r.pt);
    }
  }
  for (RopeRow& r : ropes_) {
    const auto i = static_cast<std::size_t>(r.i), j = static_cast<std::size_t>(r.j);
    const Vec3 dx = x_[j] - x_[i];
    const double dist = dx.norm();
    r.e = dist > 0.0 ? Vec3(dx / dist) : Vec3(Vec3::UnitX());
    r.c = r.max_length - dist;
    r.wb = inv_mass_[i] + inv_mass_[j];
    if (r.wb <= 0.0) {
      r.lambda = 0.0;
      continue;
    }
    if (r.lambda > 0.0) {
      v_[i] += (inv_mass_[i] * r.lambda) * r.e;
      v_[j] -= (inv_mass_[j] * r.lambda) * r.e;
    }
  }
  for (AngleRow& r : angles_) {
    const auto a = static_cast<std::size_t>(r.a), b = static_cast<std::size_t>(r.b),
               c = static_cast<std::size_t>(r.c);
    const Vec3 b1 = x_[b] - x_[a], b2 = x_[c] - x_[b];
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
      r.wa = A.squaredNorm() * inv_mass_[a] + r.gb.squaredNorm() * inv_mass_[b] +
             B.squaredNorm() * inv_mass_[c];
      r.scale = 0.5 * (l1 + l2);
      const double wref = (inv_mass_[a] + inv_mass_[b] + inv_mass_[c]) / (l1 * l2);
      r.live = r.wa > kAngleGuard * wref;
    }
    if (!r.live) {
      r.lambda = 0.0;
      continue;
    }
    if (r.lambda > 0.0) {
      v_[a] += (inv_mass_[a] * r.lambda) * r.ga;
      v_[b] += (inv_mass_[b] * r.lambda) * r.gb;
      v_[c] += (inv_mass_[c] * r.lambda) * r.gc;
    }
  }
}

bool World::sweep_contact(ContactRow& r, double inv_h, double& dv2, double& wp2) {
  const auto j = static_cast<std::size_t>(r.j);
  Vec3 u = v_[j] - r.rj * w_[j].cross(r.n);
  if (r.i >= 0) {
    const auto i = static_cast<std::size_t>(r.i);
    u -= v_[i] + r.ri * w_[i].cross(r.n);
  }
  const double un = u.dot(r.n);
  const Vec3 ut = u - un * r.n;
  const LocalContactResult s =
      solve_sphere_contact(un - r.wn * r.pn, ut - r.wt * r.pt, r.gap * inv_h, r.wn, r.wt, r.mu);
  const double dpn = s.normal_impulse - r.pn;
  const Vec3 dpt = s.tangential_impulse - r.pt;
  r.pn = s.normal_impulse;
  r.pt = s.tangential_impulse;
  r.status = s.status;
  if (dpn != 0.0 || dpt.squaredNorm() != 0.0) apply_contact(r, dpn * r.n + dpt);
  dv2 += r.wn * r.wn * dpn * dpn + r.wt * r.wt * dpt.squaredNorm();
  wp2 += r.wn * r.wn * r.pn * r.pn + r.wt * r.wt * r.pt.squaredNorm();
  return r.gap <= 0.0 || r.pn != 0.0 || r.pt.squaredNorm() != 0.0;
}

bool World::sweep_rope(RopeRow& r, double inv_h, double& dv2, double& wp2) {
  if (r.wb <= 0.0) return false;
  const auto i = static_cast<std::size_t>(r.i), j = static_cast<std::size_t>(r.j);
  const double rate = r.e.dot(v_[j] - v_[i]);
  const double lam = std::max(0.0, r.lambda + (rate - r.c * inv_h) / r.wb);
  const double dl = lam - r.lambda;
  r.lambda = lam;
  if (dl != 0.0) {
    v_[i] += (inv_mass_[i] * dl) * r.e;
    v_[j] -= (inv_mass_[j] * dl) * r.e;
  }
  dv2 += r.wb * r.wb * dl * dl;
  wp2 += r.wb * r.wb * lam * lam;
  return r.c <= 0.0 || lam != 0.0;
}

bool World::sweep_angle(AngleRow& r, double inv_h, double& dv2, double& wp2) {
  if (!r.live) return false;
  const auto a = static_cast<std::size_t>(r.a), b = static_cast<std::size_t>(r.b),
             c = static_cast<std::size_t>(r.c);
  const double rate = r.ga.dot(v_[a]) + r.gb.dot(v_[b]) + r.gc.dot(v_[c]);
  const double lam = std::max(0.0, r.lambda - (rate + r.ca * inv_h) / r.wa);
  const double dl = lam - r.lambda;
  r.lambda = lam;
  if (dl != 0.0) {
    v_[a] += (inv_mass_[a] * dl) * r.ga;
    v_[b] += (inv_mass_[b] * dl) * r.gb;
    v_[c] += (inv_mass_[c] * dl) * r.gc;
  }
  const double s2 = r.scale * r.scale * r.wa * r.wa;
  dv2 += s2 * dl * dl;
  wp2 += s2 * lam * lam;
  return r.ca <= 0.0 || lam != 0.0;
}

StepDiagnostics World::step() {
  const double h = opt_.time_step;
  const double inv_h = 1.0 / h;
  const std::int64_t this_step = step_ + 1;
  const std::size_t n = x_.size();

  // Alert distance from the fastest sphere (mobile or kinematic) and one gravity step.
  double vmax = 0.0, dmin = std::numeric_limits<double>::infinity();
  std::size_t fastest = 0;
  for (std::size_t b = 0; b < n; ++b) {
    const double speed = v_[b].norm() + radius_[b] * w_[b].norm();
    if (!(speed <= vmax)) {
      vmax = speed;
      fastest = b;
    }
    dmin = std::min(dmin, 2.0 * radius_[b]);
  }
  const double alert = 2.0 * (vmax + opt_.gravity.norm() * h) * h + opt_.alert_margin * (n ? dmin : 0.0);
  if (!std::isfinite(alert))
    throw NoResultError(fmt::format(
        "sim diverged at step {}: non-finite alert distance from body {} (speed {} m/s)", this_step,
        fastest, vmax));

  find_contacts(alert);
  for (std::size_t b = 0; b < n; ++b)
    if (kind_[b] == BodyKind::mobile) v_[b] += h * opt_.gravity;
  prepare_rows();

  StepDiagnostics d;
  d.step = this_step;
  const int nc = static_cast<int>(contacts_.size());
  const int nr = static_cast<int>(ropes_.size());
  const int na = static_cast<int>(angles_.size());
  const std::int64_t rows_per_sweep = nc + nr + na;
  double residual = 0.0;
  int it = 0;
  if (rows_per_sweep > 0) {
    for (it = 1; it <= opt_.max_iterations; ++it) {
      double dv2 = 0.0, wp2 = 0.0;
      std::int64_t active = 0;
      if (it % 2 == 1) {
        for (int k = 0; k < nc; ++k)
          active += sweep_contact(contacts_[static_cast<std::size_t>(k)], inv_h, dv2, wp2) ? 1 : 0;
        for (int k = 0; k < nr; ++k)
          active += sweep_rope(ropes_[static_cast<std::size_t>(k)], inv_h, dv2, wp2) ? 1 : 0;
        for (int k = 0; k < na; ++k)
          active += sweep_angle(angles_[static_cast<std::size_t>(k)], inv_h, dv2, wp2) ? 1 : 0;
      } else {
        for (int k = na - 1; k >= 0; --k)
          active += sweep_angle(angles_[static_cast<std::size_t>(k)], inv_h, dv2, wp2) ? 1 : 0;
        for (int k = nr - 1; k >= 0; --k)
          active += sweep_rope(ropes_[static_cast<std::size_t>(k)], inv_h, dv2, wp2) ? 1 : 0;
        for (int k = nc - 1; k >= 0; --k)
          active += sweep_contact(contacts_[static_cast<std::size_t>(k)], inv_h, dv2, wp2) ? 1 : 0;
      }
      d.row_updates += rows_per_sweep;
      d.active_row_updates += active;
      residual = wp2 > 0.0 ? std::sqrt(dv2 / wp2) : (dv2 > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
      if (residual <= opt_.tolerance) break;
    }
    if (it > opt_.max_iterations) {
      it = opt_.max_iterations;
      d.hit_iteration_cap = true;
      ++cap_hits_;
    }
  }
  d.iterations = it;
  d.residual = residual;

  for (std::size_t b = 0; b < n; ++b)
    if (kind_[b] != BodyKind::fixed) x_[b] += h * v_[b];
  step_ = this_step;
  previous_ = contacts_;
  check_state(d);
  return d;
}

void World::check_state(StepDiagnostics& d) const {
  const std::size_t n = x_.size();
  for (std::size_t b = 0; b < n; ++b) {
    if (!finite(x_[b]) || !finite(v_[b]) || !finite(w_[b]))
      throw NoResultError(fmt::format("sim diverged at step {}: non-finite state of body {}", d.step, b));
    if (kind_[b] == BodyKind::mobile)
      d.kinetic_energy += 0.5 * mass_[b] * v_[b].squaredNorm() + 0.5 * inertia_[b] * w_[b].squaredNorm();
  }
  // Contacts: status counts from the final sweep, overlaps at the new positions.
  double worst = 0.0;
  const ContactRow* worst_row = nullptr;
  for (const ContactRow& r : contacts_) {
    ++d.contacts;
    if (r.pn > 0.0) {
      ++d.active_contacts;
      if (r.status == ContactStatus::sliding) ++d.sliding_contacts;
      else ++d.sticking_contacts;
    }
    const auto j = static_cast<std::size_t>(r.j);
    double gap = 0.0, dia = 0.0;
    if (r.i >= 0) {
      const auto i = static_cast<std::size_t>(r.i);
      gap = (x_[j] - x_[i]).norm() - radius_[i] - radius_[j];
      dia = radius_[i] + radius_[j];
    } else {
      const Wall& wall = walls_[static_cast<std::size_t>(r.wall)];
      gap = (x_[j] - wall.point).dot(wall.normal) - radius_[j];
      dia = 2.0 * radius_[j];
    }
    const double ov = -gap / dia;
    if (ov > worst) {
      worst = ov;
      worst_row = &r;
    }
  }
  d.max_overlap = worst;
  if (worst_row != nullptr && worst > opt_.max_overlap) {
    if (worst_row->i >= 0)
      throw NoResultError(fmt::format(
          "sim diverged at step {}: overlap {:.4g} d between bodies {} and {} (limit {} d)", d.step,
          worst, worst_row->i, worst_row->j, opt_.max_overlap));
    throw NoResultError(fmt::format(
        "sim diverged at step {}: overlap {:.4g} d between body {} and wall {} (limit {} d)", d.step,
        worst, worst_row->j, worst_row->wall, opt_.max_overlap));
  }
  for (const RopeRow& r : ropes_) d.active_ropes += r.lambda > 0.0 ? 1 : 0;
  const auto [rope_excess, worst_rope] = largest_excess(ropes_, [&](const RopeRow& r) {
    const auto i = static_cast<std::size_t>(r.i), j = static_cast<std::size_t>(r.j);
    return ((x_[j] - x_[i]).norm() - r.max_length) / (radius_[i] + radius_[j]);
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
    const Vec3 b1 = x_[b] - x_[a], b2 = x_[c] - x_[b];
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

std::vector<ContactRecord> World::contacts() const {
  std::vector<ContactRecord> out;
  out.reserve(contacts_.size());
  for (const ContactRow& r : contacts_) {
    ContactRecord c;
    c.body_i = r.i;
    c.wall = r.wall;
    c.body_j = r.j;
    c.normal = r.n;
    c.gap = r.gap;
    c.normal_impulse = r.pn;
    c.tangential_impulse = r.pt;
    c.status = r.pn > 0.0 ? r.status : ContactStatus::open;
    out.push_back(c);
  }
  return out;
}

WorldState World::state() const {
  WorldState s;
  s.options = opt_;
  s.step = step_;
  s.iteration_cap_hits = cap_hits_;
  s.position = x_;
  s.velocity = v_;
  s.angular_velocity = w_;
  s.diameter.reserve(radius_.size());
  for (double r : radius_) s.diameter.push_back(2.0 * r);
  s.mass = mass_;
  s.inertia = inertia_;
  s.kind = kind_;
  s.walls = walls_;
  for (const RopeRow& r : ropes_) s.ropes.push_back({r.i, r.j, r.max_length, r.lambda});
  for (const AngleRow& r : angles_) s.angles.push_back({r.a, r.b, r.c, r.max_angle, r.lambda});
  s.contacts.reserve(contacts_.size());
  for (const ContactRow& r : contacts_) {
    ContactRecord c;
    c.body_i = r.i;
    c.wall = r.wall;
    c.body_j = r.j;
    c.normal = r.n;
    c.gap = r.gap;
    c.normal_impulse = r.pn;
    c.tangential_impulse = r.pt;
    c.status = r.status;
    s.contacts.push_back(c);
  }
  return s;
}

World World::from_state(const WorldState& s) {
  World w(s.options);
  const std::size_t n = s.position.size();
  auto bad = [](const std::string& what) { throw ConfigError("sim state: " + what); };
  if (s.velocity.size() != n || s.angular_velocity.size() != n || s.diameter.size() != n ||
      s.mass.size() != n || s.inertia.size() != n || s.kind.size() != n)
    bad(fmt::format("body arrays of different lengths ({} positions)", n));
  if (n > static_cast<std::size_t>(std::numeric_limits<int>::max())) bad("too many bodies");
  if (s.step < 0 || s.iteration_cap_hits < 0) bad("negative step count");
  for (std::size_t b = 0; b < n; ++b) {
    const BodyKind k = s.kind[b];
    if (k != BodyKind::mobile && k != BodyKind::fixed && k != BodyKind::kinematic)
      bad(fmt::format("body {}: unknown kind {}", b, static_cast<int>(k)));
    if (!finite(s.position[b]) || !finite(s.velocity[b]) || !finite(s.angular_velocity[b]))
      bad(fmt::format("body {}: non-finite position or velocity", b));
    if (!(s.diameter[b] > 0.0) || !std::isfinite(s.diameter[b]) || !(s.mass[b] > 0.0) ||
        !std::isfinite(s.mass[b]) || !(s.inertia[b] > 0.0) || !std::isfinite(s.inertia[b]))
      bad(fmt::format("body {}: diameter, mass and inertia must be positive and finite", b));
    w.x_.push_back(s.position[b]);
    w.v_.push_back(s.velocity[b]);
    w.w_.push_back(s.angular_velocity[b]);
    w.radius_.push_back(0.5 * s.diameter[b]);
    w.mass_.push_back(s.mass[b]);
    w.inertia_.push_back(s.inertia[b]);
    w.inv_mass_.push_back(k == BodyKind::mobile ? 1.0 / s.mass[b] : 0.0);
    w.inv_inertia_.push_back(k == BodyKind::mobile ? 1.0 / s.inertia[b] : 0.0);
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
    w.ropes_.back().lambda = r.impulse;
  }
  for (const WorldState::Angle& a : s.angles) {
    w.add_angle_limit(a.prev, a.mid, a.next, a.max_angle);
    if (!(a.impulse >= 0.0) || !std::isfinite(a.impulse)) bad("angle impulse negative or non-finite");
    w.angles_.back().lambda = a.impulse;
  }
  const int nb = static_cast<int>(n);
  for (const ContactRecord& c : s.contacts) {
    const std::size_t k = w.contacts_.size();
    if (c.body_j < 0 || c.body_j >= nb) bad(fmt::format("contact {}: body {} out of range", k, c.body_j));
    const bool wall_row = c.body_i < 0;
    if (wall_row ? (c.wall < 0 || c.wall >= static_cast<int>(w.walls_.size()))
                 : (c.body_i >= c.body_j || c.wall != -1))
      bad(fmt::format("contact {}: neither a body pair i < j nor a body-wall row", k));
    if (!finite(c.normal) || !std::isfinite(c.gap) || !std::isfinite(c.normal_impulse) ||
        !finite(c.tangential_impulse))
      bad(fmt::format("contact {}: non-finite value", k));
    ContactRow r;
    r.i = wall_row ? -1 : c.body_i;
    r.wall = wall_row ? c.wall : -1;
    r.j = c.body_j;
    r.key = wall_row ? wall_key(r.wall, r.j) : pair_key(r.i, r.j);
    if (k > 0 && !(w.contacts_.back().key < r.key))
      bad(fmt::format("contact {}: rows not in the engine's order", k));
    const auto j = static_cast<std::size_t>(r.j);
    r.n = c.normal;
    r.gap = c.gap;
    r.rj = w.radius_[j];
    if (wall_row) {
      r.wn = w.inv_mass_[j];
      r.wt = r.wn + r.rj * r.rj * w.inv_inertia_[j];
      r.mu = w.walls_[static_cast<std::size_t>(r.wall)].friction;
    } else {
      const auto i = static_cast<std::size_t>(r.i);
      r.ri = w.radius_[i];
      r.wn = w.inv_mass_[i] + w.inv_mass_[j];
      r.wt = r.wn + r.ri * r.ri * w.inv_inertia_[i] + r.rj * r.rj * w.inv_inertia_[j];
      r.mu = w.opt_.friction;
    }
    r.pn = c.normal_impulse;
    r.pt = c.tangential_impulse;
    r.status = c.status;
    w.contacts_.push_back(r);
  }
  w.previous_ = w.contacts_;
  w.step_ = s.step;
  w.cap_hits_ = s.iteration_cap_hits;
  return w;
}

std::uint64_t World::state_hash() const {
  Fnv f;
  f.u(static_cast<std::uint64_t>(step_));
  for (std::size_t b = 0; b < x_.size(); ++b) {
    f.v(x_[b]);
    f.v(v_[b]);
    f.v(w_[b]);
  }
  for (const ContactRow& r : contacts_) {
    f.u(r.key);
    f.d(r.pn);
    f.v(r.pt);
  }
  for (const RopeRow& r : ropes_) f.d(r.lambda);
  for (const AngleRow& r : angles_) f.d(r.lambda);
  return f.h;
}

}  // namespace shearzone::sim
