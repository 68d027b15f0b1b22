// The contact-dynamics engine: bodies, constraints, rotors and the step (see
// shearzone/sim/world.hpp for the model; the stages: world_contacts.cpp, world_solve.cpp,
// world_state.cpp).
#include "shearzone/sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/check.hpp"
#include "shearzone/core/error.hpp"
#include "solver_rows.hpp"
#include "world_internal.hpp"

namespace shearzone::sim {

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

}  // namespace shearzone::sim
