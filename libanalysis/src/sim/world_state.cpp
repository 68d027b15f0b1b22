// The contact-dynamics engine: its state, checkpoints and hash (see
// shearzone/sim/world.hpp for the model).
#include "shearzone/sim/world.hpp"

#include <cmath>
#include <limits>
#include <string>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/hash.hpp"
#include "solver_rows.hpp"
#include "world_internal.hpp"

namespace shearzone::sim {

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
