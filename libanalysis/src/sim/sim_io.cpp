// The simulator's files: see shearzone/sim/sim_io.hpp.
#include "shearzone/sim/sim_io.hpp"

#include <algorithm>
#include <cstddef>
#include <limits>
#include <numeric>
#include <numbers>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/hdf5.hpp"

namespace shearzone::sim {
namespace {

constexpr const char* kCheckpointFormat = "shearzone-sim-checkpoint";
// Version 2 added /bodies/orientation and the freeze_sweeps and threads options; version 1
// files still read (identity orientations, default freeze and one thread).
constexpr std::int64_t kCheckpointVersion = 2;

/// The members given of each element of `rows`, one element after the other (a row of
/// a dataset per element).
template <class Out, class Row, class... T>
std::vector<Out> gather(const std::vector<Row>& rows, T Row::*... members) {
  std::vector<Out> out;
  out.reserve(rows.size() * sizeof...(T));
  for (const Row& r : rows) (out.push_back(static_cast<Out>(r.*members)), ...);
  return out;
}

std::vector<double> flatten(const std::vector<Vec3>& v) {
  std::vector<double> out;
  out.reserve(3 * v.size());
  for (const Vec3& a : v) {
    out.push_back(a.x());
    out.push_back(a.y());
    out.push_back(a.z());
  }
  return out;
}

void write_metadata(io::H5File& f, const core::Metadata& metadata) {
  for (const auto& [k, v] : metadata) f.set_attribute("/", k, v);
}

/// Reads a dataset and checks its shape: [n] (cols == 0) or [n, cols].
template <class T>
std::vector<T> read_checked(const io::H5File& f, const std::string& name, std::size_t n,
                            std::size_t cols) {
  if (!f.exists(name)) throw InputError(fmt::format("{}: dataset \"{}\": not found", f.path(), name));
  io::H5Array<T> a = f.read<T>(name);
  const std::vector<std::size_t> want =
      cols == 0 ? std::vector<std::size_t>{n} : std::vector<std::size_t>{n, cols};
  if (a.dims != want)
    throw InputError(fmt::format("{}: dataset \"{}\": shape [{}] (expected [{}])", f.path(), name,
                                 fmt::join(a.dims, ","), fmt::join(want, ",")));
  return std::move(a.data);
}

std::vector<Vec3> read_vec3(const io::H5File& f, const std::string& name, std::size_t n) {
  const std::vector<double> d = read_checked<double>(f, name, n, 3);
  std::vector<Vec3> out(n);
  for (std::size_t k = 0; k < n; ++k) out[k] = Vec3(d[3 * k], d[3 * k + 1], d[3 * k + 2]);
  return out;
}

int to_int(std::int64_t v, const io::H5File& f, const std::string& name) {
  if (v < -1 || v > std::numeric_limits<int>::max())
    throw InputError(fmt::format("{}: dataset \"{}\": index {} out of range", f.path(), name, v));
  return static_cast<int>(v);
}

/// A dataset of body indices (rows x width), each checked by to_int.
std::vector<int> read_bodies(const io::H5File& f, const std::string& name, std::size_t rows, std::size_t width) {
  std::vector<int> out;
  for (const std::int64_t v : read_checked<std::int64_t>(f, name, rows, width)) out.push_back(to_int(v, f, name));
  return out;
}

std::size_t count_attr(const io::H5File& f, const char* name) {
  if (!f.has_attribute("/", name))
    throw InputError(fmt::format("{}: attribute \"{}\": not found", f.path(), name));
  const std::int64_t v = f.attribute_int("/", name);
  if (v < 0) throw InputError(fmt::format("{}: attribute \"{}\": {} (expected >= 0)", f.path(), name, v));
  return static_cast<std::size_t>(v);
}

}  // namespace

void write_checkpoint(const std::filesystem::path& path, const World& world,
                      const core::Metadata& metadata) {
  const WorldState s = world.state();
  io::H5File f = io::H5File::create(path);
  f.set_attribute("/", "format", kCheckpointFormat);
  f.set_attribute("/", "format_version", kCheckpointVersion);
  f.set_attribute("/", "step", static_cast<std::int64_t>(s.step));
  f.set_attribute("/", "iteration_cap_hits", static_cast<std::int64_t>(s.iteration_cap_hits));
  f.set_attribute("/", "time_s", world.time());
  const Options& o = s.options;
  f.set_attribute("/", "option_time_step_s", o.time_step);
  f.set_attribute("/", "option_gravity_m_per_s2",
                  std::vector<double>{o.gravity.x(), o.gravity.y(), o.gravity.z()});
  f.set_attribute("/", "option_friction", o.friction);
  f.set_attribute("/", "option_tolerance", o.tolerance);
  f.set_attribute("/", "option_max_iterations", static_cast<std::int64_t>(o.max_iterations));
  f.set_attribute("/", "option_alert_margin", o.alert_margin);
  f.set_attribute("/", "option_max_overlap", o.max_overlap);
  f.set_attribute("/", "option_max_rope_excess", o.max_rope_excess);
  f.set_attribute("/", "option_max_angle_excess_rad", o.max_angle_excess);
  f.set_attribute("/", "option_freeze_sweeps", static_cast<std::int64_t>(o.freeze_sweeps));
  f.set_attribute("/", "option_threads", static_cast<std::int64_t>(o.threads));
  f.set_attribute("/", "option_sweep_order", std::string(o.alternate_sweeps ? "alternate" : "forward"));
  f.set_attribute("/", "option_anderson_depth", static_cast<std::int64_t>(o.anderson_depth));
  if (o.sectors != 0) {  // a periodic sector (absent: none)
    f.set_attribute("/", "option_sectors", static_cast<std::int64_t>(o.sectors));
    f.set_attribute("/", "option_sector_centre_m", std::vector<double>{o.sector_centre.x(), o.sector_centre.y()});
    f.set_attribute("/", "option_sector_start_rad", o.sector_start);
  }
  write_metadata(f, metadata);

  const std::size_t n = s.position.size();
  f.set_attribute("/", "n_bodies", static_cast<std::int64_t>(n));
  f.set_attribute("/", "n_walls", static_cast<std::int64_t>(s.walls.size()));
  f.set_attribute("/", "n_ropes", static_cast<std::int64_t>(s.ropes.size()));
  f.set_attribute("/", "n_angles", static_cast<std::int64_t>(s.angles.size()));
  f.set_attribute("/", "n_contacts", static_cast<std::int64_t>(s.contacts.size()));
  if (n > 0) {
    f.write("/bodies/position", {n, 3}, flatten(s.position));
    f.write("/bodies/velocity", {n, 3}, flatten(s.velocity));
    f.write("/bodies/angular_velocity", {n, 3}, flatten(s.angular_velocity));
    std::vector<double> q;
    q.reserve(4 * n);
    for (const Eigen::Quaterniond& r : s.orientation) {
      q.push_back(r.w());
      q.push_back(r.x());
      q.push_back(r.y());
      q.push_back(r.z());
    }
    f.write("/bodies/orientation", {n, 4}, q);
    f.write("/bodies/diameter", {n}, s.diameter);
    f.write("/bodies/mass", {n}, s.mass);
    f.write("/bodies/inertia", {n}, s.inertia);
    std::vector<std::uint8_t> kind(n);
    for (std::size_t b = 0; b < n; ++b) kind[b] = static_cast<std::uint8_t>(s.kind[b]);
    f.write("/bodies/kind", {n}, kind);
  }
  if (const std::size_t nw = s.walls.size(); nw > 0) {
    std::vector<Vec3> p, nn;
    std::vector<double> mu;
    for (const Wall& w : s.walls) {
      p.push_back(w.point);
      nn.push_back(w.normal);
      mu.push_back(w.friction);
    }
    f.write("/walls/point", {nw, 3}, flatten(p));
    f.write("/walls/normal", {nw, 3}, flatten(nn));
    f.write("/walls/friction", {nw}, mu);
  }
  if (const std::size_t nr = s.ropes.size(); nr > 0) {
    using Rope = WorldState::Rope;
    f.write("/ropes/bodies", {nr, 2}, gather<std::int64_t>(s.ropes, &Rope::i, &Rope::j));
    f.write("/ropes/max_length", {nr}, gather<double>(s.ropes, &Rope::max_length));
    f.write("/ropes/impulse", {nr}, gather<double>(s.ropes, &Rope::impulse));
    if (o.sectors != 0)
      f.write("/ropes/image", {nr}, gather<std::int64_t>(s.ropes, &Rope::image));
  }
  if (const std::size_t na = s.angles.size(); na > 0) {
    using Angle = WorldState::Angle;
    f.write("/angles/bodies", {na, 3}, gather<std::int64_t>(s.angles, &Angle::prev, &Angle::mid, &Angle::next));
    f.write("/angles/max_angle", {na}, gather<double>(s.angles, &Angle::max_angle));
    f.write("/angles/impulse", {na}, gather<double>(s.angles, &Angle::impulse));
    if (o.sectors != 0)
      f.write("/angles/image", {na, 2}, gather<std::int64_t>(s.angles, &Angle::image_prev, &Angle::image_next));
  }
  // Rotors (the vane): drive and reference placement; bodies in CSR form.
  f.set_attribute("/", "n_rotors", static_cast<std::int64_t>(s.rotors.size()));
  if (const std::size_t nr = s.rotors.size(); nr > 0) {
    std::vector<double> drive, ref, refq;
    std::vector<std::int64_t> offsets{0}, bodies;
    for (const Rotor& r : s.rotors) {
      for (double v : {r.centre.x(), r.centre.y(), r.centre.z(), r.axis.x(), r.axis.y(), r.axis.z(), r.phi0,
                       r.f_Hz, r.phase, r.t_start})
        drive.push_back(v);
      for (std::size_t k = 0; k < r.bodies.size(); ++k) {
        bodies.push_back(r.bodies[k]);
        for (int a = 0; a < 3; ++a) ref.push_back(r.reference[k](a));
        const Eigen::Quaterniond& q = r.reference_orientation[k];
        for (double v : {q.w(), q.x(), q.y(), q.z()}) refq.push_back(v);
      }
      offsets.push_back(static_cast<std::int64_t>(bodies.size()));
    }
    f.write("/rotors/drive", {nr, 10}, drive);
    f.write("/rotors/offsets", {nr + 1}, offsets);
    if (!bodies.empty()) {
      f.write("/rotors/bodies", {bodies.size()}, bodies);
      f.write("/rotors/reference", {bodies.size(), 3}, ref);
      f.write("/rotors/reference_orientation", {bodies.size(), 4}, refq);
    }
  }
  if (const std::size_t nc = s.contacts.size(); nc > 0) {
    std::vector<std::int64_t> ids;
    std::vector<Vec3> normal, pt;
    std::vector<double> gap, pn;
    std::vector<std::uint8_t> status;
    for (const ContactRecord& c : s.contacts) {
      ids.push_back(c.body_i);
      ids.push_back(c.wall);
      ids.push_back(c.body_j);
      normal.push_back(c.normal);
      pt.push_back(c.tangential_impulse);
      gap.push_back(c.gap);
      pn.push_back(c.normal_impulse);
      status.push_back(static_cast<std::uint8_t>(c.status));
    }
    f.write("/contacts/bodies", {nc, 3}, ids);
    f.write("/contacts/normal", {nc, 3}, flatten(normal));
    f.write("/contacts/gap", {nc}, gap);
    f.write("/contacts/normal_impulse", {nc}, pn);
    f.write("/contacts/tangential_impulse", {nc, 3}, flatten(pt));
    f.write("/contacts/status", {nc}, status);
    if (o.sectors != 0) {
      std::vector<std::int64_t> image;
      for (const ContactRecord& c : s.contacts) image.push_back(static_cast<std::int64_t>(c.image));
      f.write("/contacts/image", {nc}, image);
    }
  }
  f.close();
}

WorldState read_checkpoint(const std::filesystem::path& path) {
  const io::H5File f = io::H5File::open_read(path);
  if (!f.has_attribute("/", "format") || f.attribute_string("/", "format") != kCheckpointFormat)
    throw InputError(fmt::format("{}: not a shearzone sim checkpoint (attribute \"format\" is not \"{}\")",
                                 f.path(), kCheckpointFormat));
  const std::int64_t version = f.attribute_int("/", "format_version");
  if (version != kCheckpointVersion && version != 1)
    throw InputError(fmt::format("{}: checkpoint format_version {} (this build reads {})", f.path(),
                                 version, kCheckpointVersion));
  WorldState s;
  s.step = f.attribute_int("/", "step");
  s.iteration_cap_hits = f.attribute_int("/", "iteration_cap_hits");
  Options& o = s.options;
  o.time_step = f.attribute_double("/", "option_time_step_s");
  const std::vector<double> g = f.attribute_doubles("/", "option_gravity_m_per_s2");
  if (g.size() != 3)
    throw InputError(fmt::format("{}: attribute \"option_gravity_m_per_s2\": {} values (expected 3)",
                                 f.path(), g.size()));
  o.gravity = Vec3(g[0], g[1], g[2]);
  o.friction = f.attribute_double("/", "option_friction");
  o.tolerance = f.attribute_double("/", "option_tolerance");
  const std::int64_t iters = f.attribute_int("/", "option_max_iterations");
  if (iters < 1 || iters > std::numeric_limits<int>::max())
    throw InputError(fmt::format("{}: attribute \"option_max_iterations\": {}", f.path(), iters));
  o.max_iterations = static_cast<int>(iters);
  o.alert_margin = f.attribute_double("/", "option_alert_margin");
  o.max_overlap = f.attribute_double("/", "option_max_overlap");
  o.max_rope_excess = f.attribute_double("/", "option_max_rope_excess");
  o.max_angle_excess = f.attribute_double("/", "option_max_angle_excess_rad");
  if (version >= 2) {
    const std::int64_t freeze = f.attribute_int("/", "option_freeze_sweeps");
    const std::int64_t threads = f.attribute_int("/", "option_threads");
    if (freeze < 0 || freeze > 1000000)
      throw InputError(fmt::format("{}: attribute \"option_freeze_sweeps\": {}", f.path(), freeze));
    if (threads < 1 || threads > 256)
      throw InputError(fmt::format("{}: attribute \"option_threads\": {}", f.path(), threads));
    o.freeze_sweeps = static_cast<int>(freeze);
    o.threads = static_cast<int>(threads);
  }
  if (f.has_attribute("/", "option_sweep_order")) {  // absent in older files: alternate
    const std::string order = f.attribute_string("/", "option_sweep_order");
    if (order != "alternate" && order != "forward")
      throw InputError(fmt::format("{}: attribute \"option_sweep_order\": \"{}\" (expected alternate or forward)",
                                   f.path(), order));
    o.alternate_sweeps = order == "alternate";
  }
  if (f.has_attribute("/", "option_anderson_depth")) {  // absent in older files: 0
    const std::int64_t depth = f.attribute_int("/", "option_anderson_depth");
    if (depth < 0 || depth > 10)
      throw InputError(fmt::format("{}: attribute \"option_anderson_depth\": {} (expected 0 to 10)", f.path(), depth));
    o.anderson_depth = static_cast<int>(depth);
  }
  if (f.has_attribute("/", "option_sectors")) {  // a periodic sector
    const std::int64_t k = f.attribute_int("/", "option_sectors");
    if (k < 3 || k > 64)
      throw InputError(fmt::format("{}: attribute \"option_sectors\": {} (expected 3 to 64)", f.path(), k));
    const std::vector<double> c = f.attribute_doubles("/", "option_sector_centre_m");
    if (c.size() != 2)
      throw InputError(fmt::format("{}: attribute \"option_sector_centre_m\": {} values (expected 2)", f.path(), c.size()));
    o.sectors = static_cast<int>(k);
    o.sector_centre = Vec3(c[0], c[1], 0.0);
    o.sector_start = f.attribute_double("/", "option_sector_start_rad");
  }
  // Image offsets of a periodic sector's rows (absent without one: 0).
  auto images = [&](const char* name, std::size_t rows, std::size_t cols) {
    std::vector<int> v(rows * std::max<std::size_t>(cols, 1), 0);
    if (o.sectors == 0) return v;
    const auto raw = read_checked<std::int64_t>(f, name, rows, cols);
    for (std::size_t k = 0; k < raw.size(); ++k) {
      if (raw[k] < -1 || raw[k] > 1)
        throw InputError(fmt::format("{}: dataset \"{}\": {} (expected -1, 0 or 1)", f.path(), name, raw[k]));
      v[k] = static_cast<int>(raw[k]);
    }
    return v;
  };

  const std::size_t n = count_attr(f, "n_bodies");
  if (n > 0) {
    s.position = read_vec3(f, "/bodies/position", n);
    s.velocity = read_vec3(f, "/bodies/velocity", n);
    s.angular_velocity = read_vec3(f, "/bodies/angular_velocity", n);
    if (version >= 2) {
      const std::vector<double> q = read_checked<double>(f, "/bodies/orientation", n, 4);
      s.orientation.resize(n);
      for (std::size_t k = 0; k < n; ++k)
        s.orientation[k] = Eigen::Quaterniond(q[4 * k], q[4 * k + 1], q[4 * k + 2], q[4 * k + 3]);
    }
    s.diameter = read_checked<double>(f, "/bodies/diameter", n, 0);
    s.mass = read_checked<double>(f, "/bodies/mass", n, 0);
    s.inertia = read_checked<double>(f, "/bodies/inertia", n, 0);
    for (std::uint8_t k : read_checked<std::uint8_t>(f, "/bodies/kind", n, 0)) {
      if (k > 2) throw InputError(fmt::format("{}: dataset \"/bodies/kind\": {} (expected 0, 1 or 2)", f.path(), k));
      s.kind.push_back(static_cast<BodyKind>(k));
    }
  }
  if (const std::size_t nw = count_attr(f, "n_walls"); nw > 0) {
    const auto p = read_vec3(f, "/walls/point", nw);
    const auto nn = read_vec3(f, "/walls/normal", nw);
    const auto mu = read_checked<double>(f, "/walls/friction", nw, 0);
    for (std::size_t k = 0; k < nw; ++k) s.walls.push_back(Wall{p[k], nn[k], mu[k]});
  }
  if (const std::size_t nr = count_attr(f, "n_ropes"); nr > 0) {
    const auto ij = read_bodies(f, "/ropes/bodies", nr, 2);
    const auto len = read_checked<double>(f, "/ropes/max_length", nr, 0);
    const auto imp = read_checked<double>(f, "/ropes/impulse", nr, 0);
    const auto image = images("/ropes/image", nr, 0);
    for (std::size_t k = 0; k < nr; ++k) s.ropes.push_back({ij[2 * k], ij[2 * k + 1], len[k], imp[k], image[k]});
  }
  if (const std::size_t na = count_attr(f, "n_angles"); na > 0) {
    const auto abc = read_bodies(f, "/angles/bodies", na, 3);
    const auto amax = read_checked<double>(f, "/angles/max_angle", na, 0);
    const auto imp = read_checked<double>(f, "/angles/impulse", na, 0);
    const auto image = images("/angles/image", na, 2);
    for (std::size_t k = 0; k < na; ++k)
      s.angles.push_back(
          {abc[3 * k], abc[3 * k + 1], abc[3 * k + 2], amax[k], imp[k], image[2 * k], image[2 * k + 1]});
  }
  if (const std::size_t nc = count_attr(f, "n_contacts"); nc > 0) {
    const auto ids = read_checked<std::int64_t>(f, "/contacts/bodies", nc, 3);
    const auto normal = read_vec3(f, "/contacts/normal", nc);
    const auto gap = read_checked<double>(f, "/contacts/gap", nc, 0);
    const auto pn = read_checked<double>(f, "/contacts/normal_impulse", nc, 0);
    const auto pt = read_vec3(f, "/contacts/tangential_impulse", nc);
    const auto status = read_checked<std::uint8_t>(f, "/contacts/status", nc, 0);
    const auto image = images("/contacts/image", nc, 0);
    for (std::size_t k = 0; k < nc; ++k) {
      if (status[k] > 2)
        throw InputError(fmt::format("{}: dataset \"/contacts/status\": {} (expected 0, 1 or 2)", f.path(), status[k]));
      ContactRecord c;
      c.body_i = to_int(ids[3 * k], f, "/contacts/bodies");
      c.wall = to_int(ids[3 * k + 1], f, "/contacts/bodies");
      c.body_j = to_int(ids[3 * k + 2], f, "/contacts/bodies");
      c.normal = normal[k];
      c.gap = gap[k];
      c.normal_impulse = pn[k];
      c.tangential_impulse = pt[k];
      c.status = static_cast<ContactStatus>(status[k]);
      c.image = image[k];
      s.contacts.push_back(c);
    }
  }
  // Checkpoints written before rotors existed have no n_rotors: none.
  const std::size_t nrot = f.has_attribute("/", "n_rotors") ? count_attr(f, "n_rotors") : 0;
  if (nrot > 0) {
    const auto drive = read_checked<double>(f, "/rotors/drive", nrot, 10);
    const auto offsets = read_checked<std::int64_t>(f, "/rotors/offsets", nrot + 1, 0);
    if (offsets.front() != 0 || !std::is_sorted(offsets.begin(), offsets.end()) || offsets.back() < 0)
      throw InputError(fmt::format("{}: dataset \"/rotors/offsets\": expected 0 and non-decreasing counts", f.path()));
    const auto total = static_cast<std::size_t>(offsets.back());
    std::vector<std::int64_t> bodies;
    std::vector<double> ref, refq;
    if (total > 0) {
      bodies = read_checked<std::int64_t>(f, "/rotors/bodies", total, 0);
      ref = read_checked<double>(f, "/rotors/reference", total, 3);
      refq = read_checked<double>(f, "/rotors/reference_orientation", total, 4);
    }
    for (std::size_t r = 0; r < nrot; ++r) {
      Rotor rot;
      const double* d = drive.data() + 10 * r;
      rot.centre = Vec3(d[0], d[1], d[2]);
      rot.axis = Vec3(d[3], d[4], d[5]);
      rot.phi0 = d[6];
      rot.f_Hz = d[7];
      rot.phase = d[8];
      rot.t_start = d[9];
      for (auto k = static_cast<std::size_t>(offsets[r]); k < static_cast<std::size_t>(offsets[r + 1]); ++k) {
        rot.bodies.push_back(to_int(bodies[k], f, "/rotors/bodies"));
        rot.reference.emplace_back(ref[3 * k], ref[3 * k + 1], ref[3 * k + 2]);
        rot.reference_orientation.emplace_back(refq[4 * k], refq[4 * k + 1], refq[4 * k + 2], refq[4 * k + 3]);
      }
      s.rotors.push_back(std::move(rot));
    }
  }
  return s;
}

std::vector<std::int64_t> chain_ids_from_ropes(const WorldState& state) {
  const std::size_t n = state.position.size();
  std::vector<std::size_t> parent(n);
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  auto find = [&](std::size_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const auto& r : state.ropes) {
    const std::size_t a = find(static_cast<std::size_t>(r.i)), b = find(static_cast<std::size_t>(r.j));
    if (a != b) parent[std::max(a, b)] = std::min(a, b);  // the root is the smallest index
  }
  std::vector<std::int64_t> id(n, -1), root_id(n, -1);
  std::int64_t next = 0;
  for (std::size_t b = 0; b < n; ++b) {
    const std::size_t r = find(b);
    if (root_id[r] < 0) root_id[r] = next++;
    id[b] = root_id[r];
  }
  return id;
}

SnapshotWriter::SnapshotWriter(const std::filesystem::path& path, const World& world,
                               const core::Metadata& metadata, std::vector<std::int64_t> chain_ids)
    : n_(static_cast<std::size_t>(world.body_count())) {
  if (chain_ids.empty()) chain_ids = chain_ids_from_ropes(world.state());
  if (chain_ids.size() != n_)
    throw ConfigError(fmt::format("snapshot chain ids: {} given for {} bodies", chain_ids.size(), n_));
  file_ = std::make_unique<io::H5File>(io::H5File::create(path));
  io::H5File& f = *file_;
  f.set_attribute("/", "format", "shearzone-sim-snapshots");
  write_metadata(f, metadata);
  f.set_attribute("/", "n_bodies", static_cast<std::int64_t>(n_));
  std::vector<double> dia(n_);
  std::vector<std::uint8_t> kind(n_);
  for (std::size_t b = 0; b < n_; ++b) {
    dia[b] = world.diameter(static_cast<int>(b));
    kind[b] = static_cast<std::uint8_t>(world.kind(static_cast<int>(b)));
  }
  f.create_appendable("/time_s", {}, io::H5File::Type::kFloat64);
  f.create_appendable("/step", {}, io::H5File::Type::kInt64);
  f.create_appendable("/position", {n_, 3}, io::H5File::Type::kFloat64);
  f.create_appendable("/velocity", {n_, 3}, io::H5File::Type::kFloat64);
  f.create_appendable("/angular_velocity", {n_, 3}, io::H5File::Type::kFloat64);
  if (n_ > 0) {
    f.write("/diameter", {n_}, dia);
    f.write("/chain_id", {n_}, chain_ids);
    f.write("/kind", {n_}, kind);
  }
}

SnapshotWriter::~SnapshotWriter() = default;

void SnapshotWriter::append(const World& world) {
  if (!file_) throw InternalError("SnapshotWriter::append after close");
  if (static_cast<std::size_t>(world.body_count()) != n_)
    throw InternalError(fmt::format("snapshot: {} bodies (file has {})", world.body_count(), n_));
  const double t = world.time();
  const std::int64_t step = world.steps_done();
  file_->append("/time_s", &t);
  file_->append("/step", &step);
  buffer_.resize(3 * n_);
  auto put = [&](const char* name, auto get) {
    for (std::size_t b = 0; b < n_; ++b) {
      const Vec3& a = get(static_cast<int>(b));
      buffer_[3 * b] = a.x();
      buffer_[3 * b + 1] = a.y();
      buffer_[3 * b + 2] = a.z();
    }
    file_->append(name, buffer_.data());
  };
  put("/position", [&](int b) -> const Vec3& { return world.position(b); });
  put("/velocity", [&](int b) -> const Vec3& { return world.velocity(b); });
  put("/angular_velocity", [&](int b) -> const Vec3& { return world.angular_velocity(b); });
  times_.push_back(t);
  steps_.push_back(step);
}

void SnapshotWriter::close() {
  if (file_) {
    file_->close();
    file_.reset();
  }
}

void write_snapshot_xdmf(std::ostream& out, const std::string& h5_name, std::size_t n,
                         const std::vector<double>& times) {
  const std::size_t s = times.size();
  out << "<?xml version=\"1.0\" ?>\n"
      << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
      << "<Xdmf Version=\"2.0\">\n"
      << "  <Domain>\n"
      << "    <Grid Name=\"beads\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  auto slab = [&](std::size_t k, const char* name, const char* indent) {
    out << indent << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"1 " << n << " 3\" Type=\"HyperSlab\">\n"
        << indent << "  <DataItem Dimensions=\"3 3\" Format=\"XML\">" << k << " 0 0 1 1 1 1 " << n
        << " 3</DataItem>\n"
        << indent << "  <DataItem Dimensions=\"" << s << ' ' << n
        << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5_name << ":/" << name
        << "</DataItem>\n"
        << indent << "</DataItem>\n";
  };
  auto scalar = [&](const char* name, const char* type, int precision) {
    out << "        <Attribute Name=\"" << name << "\" AttributeType=\"Scalar\" Center=\"Node\">\n"
        << "          <DataItem Dimensions=\"" << n << "\" NumberType=\"" << type << "\" Precision=\""
        << precision << "\" Format=\"HDF\">" << h5_name << ":/" << name << "</DataItem>\n"
        << "        </Attribute>\n";
  };
  for (std::size_t k = 0; k < s; ++k) {
    out << "      <Grid Name=\"snapshot_" << k << "\" GridType=\"Uniform\">\n"
        << "        <Time Value=\"" << io::format_number(times[k]) << "\"/>\n"
        << "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n
        << "\" NodesPerElement=\"1\"/>\n"
        << "        <Geometry GeometryType=\"XYZ\">\n";
    slab(k, "position", "          ");
    out << "        </Geometry>\n";
    for (const char* vec : {"velocity", "angular_velocity"}) {
      out << "        <Attribute Name=\"" << vec << "\" AttributeType=\"Vector\" Center=\"Node\">\n";
      slab(k, vec, "          ");
      out << "        </Attribute>\n";
    }
    if (n > 0) {
      scalar("diameter", "Float", 8);
      scalar("chain_id", "Int", 8);
      scalar("kind", "UChar", 1);
    }
    out << "      </Grid>\n";
  }
  out << "    </Grid>\n"
      << "  </Domain>\n"
      << "</Xdmf>\n";
}

const std::vector<std::string>& DiagnosticsCsv::columns() {
  static const std::vector<std::string> c{
      "step",          "time_s",           "iterations",       "residual",
      "cap_hit",       "contacts",         "active_contacts",  "sliding_contacts",
      "sticking_contacts", "active_ropes", "active_angles",    "max_overlap_over_d",
      "max_rope_excess_over_d", "max_angle_excess_rad", "kinetic_energy_J", "row_updates",
      "active_row_updates", "frozen_skips", "rows"};
  return c;
}

DiagnosticsCsv::DiagnosticsCsv(std::ostream& out, const core::Metadata& metadata)
    : csv_(std::make_unique<io::CsvWriter>(out, metadata, columns())) {}

DiagnosticsCsv::~DiagnosticsCsv() = default;

void DiagnosticsCsv::row(const StepDiagnostics& d, double time_s) {
  csv_->row(std::vector<std::string>{
      std::to_string(d.step), io::format_number(time_s), std::to_string(d.iterations),
      io::format_number(d.residual), d.hit_iteration_cap ? "1" : "0", std::to_string(d.contacts),
      std::to_string(d.active_contacts), std::to_string(d.sliding_contacts),
      std::to_string(d.sticking_contacts), std::to_string(d.active_ropes), std::to_string(d.active_angles),
      io::format_number(d.max_overlap), io::format_number(d.max_rope_excess),
      io::format_number(d.max_angle_excess), io::format_number(d.kinetic_energy),
      std::to_string(d.row_updates), std::to_string(d.active_row_updates), std::to_string(d.frozen_skips),
      std::to_string(d.rows)});
}

}  // namespace shearzone::sim
