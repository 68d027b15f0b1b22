// python/src/sim.cpp: scenes and checkpoints for `shearzone._native`.
//
// A scene is a dict of sections of keys ({"sim": {"duration_s": 0.1}, ...}), exactly the
// scene file's sections and keys (sim::SceneSpec::for_each_key is the one list), so a
// Scene built in Python writes the same TOML (sim::write_scene) and is checked by the
// same rules (sim::build_scene) as a file. A checkpoint reads back as arrays through
// sim::read_checkpoint, with the state hash the command prints.
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

#include "bindings.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/sim/scene.hpp"
#include "shearzone/sim/sim_io.hpp"
#include "shearzone/sim/world.hpp"

namespace py = pybind11;
using namespace shearzone;

namespace {

std::pair<std::string, std::string> split_key(const char* name) {
  const std::string n(name);
  const auto dot = n.find('.');
  return {n.substr(0, dot), n.substr(dot + 1)};
}

/// The keys set in `spec`, as {section: {key: value}} (float, int, bool, str, list).
py::dict scene_dict(const sim::SceneSpec& spec) {
  py::dict d;
  sim::SceneSpec::for_each_key(spec, [&d](const char* name, const auto& key) {
    if (!key) return;
    const auto [section, k] = split_key(name);
    if (!d.contains(section)) d[py::str(section)] = py::dict();
    py::dict s = d[py::str(section)];
    s[py::str(k)] = py::cast(*key);
  });
  return d;
}

/// What a key takes, for messages.
template <class T>
const char* expected_of() {
  if constexpr (std::is_same_v<T, bool>) return "True or False";
  else if constexpr (std::is_same_v<T, std::int64_t>) return "a whole number";
  else if constexpr (std::is_same_v<T, double>) return "a finite number";
  else if constexpr (std::is_same_v<T, std::string>) return "text";
  else return "a list of finite numbers";
}

bool is_number(py::handle v) {
  return !py::isinstance<py::bool_>(v) && !py::isinstance<py::str>(v) &&
         (py::isinstance<py::int_>(v) || py::isinstance<py::float_>(v) ||
          py::hasattr(v, "__float__"));
}

/// One key's value converted to the member's type; ConfigError naming the key otherwise.
template <class T>
T key_value(py::handle v, const std::string& source, const char* name) {
  const auto refuse = [&] {
    return ConfigError(fmt::format("{}: key \"{}\": {}: expected {}", source, name,
                                   py::repr(v).cast<std::string>(), expected_of<T>()));
  };
  if constexpr (std::is_same_v<T, bool>) {
    if (!py::isinstance<py::bool_>(v) && !(py::hasattr(v, "dtype") && py::str(v.attr("dtype")).cast<std::string>() == "bool"))
      throw refuse();
    return v.cast<bool>();
  } else if constexpr (std::is_same_v<T, std::int64_t>) {
    if (!is_number(v)) throw refuse();
    const double x = v.attr("__float__")().cast<double>();
    if (!std::isfinite(x) || x != std::floor(x) || std::abs(x) > 9.0e15) throw refuse();
    return static_cast<std::int64_t>(x);
  } else if constexpr (std::is_same_v<T, double>) {
    if (!is_number(v)) throw refuse();
    const double x = v.attr("__float__")().cast<double>();
    if (!std::isfinite(x)) throw refuse();
    return x;
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!py::isinstance<py::str>(v)) throw refuse();
    return v.cast<std::string>();
  } else {
    if (py::isinstance<py::str>(v) || !py::hasattr(v, "__iter__")) throw refuse();
    std::vector<double> out;
    for (py::handle x : py::iter(v)) {
      if (!is_number(x)) throw refuse();
      const double d = x.attr("__float__")().cast<double>();
      if (!std::isfinite(d)) throw refuse();
      out.push_back(d);
    }
    return out;
  }
}

/// A scene dict as a SceneSpec: every key converted, unknown sections and keys refused
/// with the known ones listed.
sim::SceneSpec scene_spec(const py::dict& sections, const std::string& source) {
  sim::SceneSpec spec;
  spec.source = source;
  std::set<std::string> known_sections;
  std::map<std::string, std::string> section_keys;
  std::set<std::string> used;
  sim::SceneSpec::for_each_key(spec, [&](const char* name, auto& key) {
    const auto [section, k] = split_key(name);
    known_sections.insert(section);
    section_keys[section] += (section_keys[section].empty() ? "" : ", ") + k;
    if (!sections.contains(section)) return;
    py::handle s = sections[py::str(section)];
    if (!py::isinstance<py::dict>(s)) return;  // refused below
    py::dict keys = py::reinterpret_borrow<py::dict>(s);
    if (!keys.contains(k)) return;
    used.insert(name);
    using T = typename std::decay_t<decltype(key)>::value_type;
    key = key_value<T>(keys[py::str(k)], source, name);
  });
  for (auto item : sections) {
    const std::string section = py::str(item.first);
    if (known_sections.count(section) == 0) {
      std::string list;
      for (const auto& s : known_sections) list += (list.empty() ? "" : ", ") + s;
      throw ConfigError(fmt::format("{}: unknown section \"{}\"; expected one of {}", source, section, list));
    }
    if (!py::isinstance<py::dict>(item.second))
      throw ConfigError(fmt::format("{}: section \"{}\": {}: expected a dict of keys", source, section,
                                    py::repr(item.second).cast<std::string>()));
    for (auto kv : py::reinterpret_borrow<py::dict>(item.second)) {
      const std::string name = section + "." + py::str(kv.first).cast<std::string>();
      if (used.count(name) == 0)
        throw ConfigError(fmt::format("{}: unknown key \"{}\"; the section's keys are {}", source, name,
                                      section_keys[section]));
    }
  }
  return spec;
}

py::dict scene_from_toml(const std::string& path) { return scene_dict(sim::read_scene(path)); }

std::string scene_to_toml(const py::dict& sections, const std::string& comment) {
  std::ostringstream out;
  sim::write_scene(scene_spec(sections, "Scene"), out, comment);
  return out.str();
}

void scene_check(const py::dict& sections) { (void)sim::build_scene(scene_spec(sections, "Scene"), true); }

template <class T>
py::array_t<T> column(const std::vector<T>& v) {
  py::array_t<T> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

py::array_t<double> rows3(const std::vector<sim::Vec3>& v) {
  py::array_t<double> out({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int c = 0; c < 3; ++c) *out.mutable_data(i, c) = v[i][c];
  return out;
}

/// A checkpoint's bodies, ropes and walls as arrays, its step and time, and the state
/// hash of the world it continues (the `state hash` `shearzone sim` prints).
py::dict read_checkpoint(const std::string& path) {
  sim::WorldState s = sim::read_checkpoint(path);
  py::dict d;
  d["step"] = s.step;
  d["time_s"] = static_cast<double>(s.step) * s.options.time_step;
  d["time_step_s"] = s.options.time_step;
  d["iteration_cap_hits"] = s.iteration_cap_hits;
  d["position_m"] = rows3(s.position);
  d["velocity_m_per_s"] = rows3(s.velocity);
  d["angular_velocity_rad_per_s"] = rows3(s.angular_velocity);
  py::array_t<double> q({static_cast<py::ssize_t>(s.orientation.size()), py::ssize_t{4}});
  for (std::size_t i = 0; i < s.orientation.size(); ++i) {
    *q.mutable_data(i, 0) = s.orientation[i].w();
    *q.mutable_data(i, 1) = s.orientation[i].x();
    *q.mutable_data(i, 2) = s.orientation[i].y();
    *q.mutable_data(i, 3) = s.orientation[i].z();
  }
  d["orientation"] = q;
  d["diameter_m"] = column(s.diameter);
  d["mass_kg"] = column(s.mass);
  std::vector<std::uint8_t> kind;
  for (auto k : s.kind) kind.push_back(static_cast<std::uint8_t>(k));
  d["kind"] = column(kind);
  d["chain_id"] = column(sim::chain_ids_from_ropes(s));
  py::array_t<std::int64_t> ropes({static_cast<py::ssize_t>(s.ropes.size()), py::ssize_t{2}});
  for (std::size_t i = 0; i < s.ropes.size(); ++i) {
    *ropes.mutable_data(i, 0) = s.ropes[i].i;
    *ropes.mutable_data(i, 1) = s.ropes[i].j;
  }
  d["ropes"] = ropes;
  d["n_walls"] = s.walls.size();
  d["n_contacts"] = s.contacts.size();
  d["state_hash"] = fmt::format("{:016x}", sim::World::from_state(s).state_hash());
  return d;
}

}  // namespace

void bind_sim(py::module_& m) {
  m.def("scene_from_toml", &scene_from_toml, py::arg("path"));
  m.def("scene_to_toml", &scene_to_toml, py::arg("sections"), py::arg("comment") = "");
  m.def("scene_check", &scene_check, py::arg("sections"));
  m.def("read_checkpoint", &read_checkpoint, py::arg("path"));
}
