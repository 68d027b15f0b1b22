// The contact-dynamics engine: the contact search and the rows of a step (see
// shearzone/sim/world.hpp for the model).
#include "shearzone/sim/world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "solver_rows.hpp"
#include "world_internal.hpp"

namespace shearzone::sim {

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
  detail::apply_row_impulse(body_[static_cast<std::size_t>(r.i)], body_[static_cast<std::size_t>(r.j)], r.image, r.ri,
                            r.rj, r.n, p, sec);
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

}  // namespace shearzone::sim
