// Units of rheometer logs: a normalised spelling looked up in a small table per kind.
#include "shearzone/io/units.hpp"

#include <array>
#include <numbers>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::io {
namespace {

struct UnitEntry {
  const char* spelling;  ///< normalised (see normalize_unit)
  double scale;
};

constexpr double kDeg = std::numbers::pi / 180.0;

constexpr std::array kTime{UnitEntry{"s", 1.0}, UnitEntry{"sec", 1.0}, UnitEntry{"ms", 1e-3},
                           UnitEntry{"min", 60.0}};
constexpr std::array kAngle{UnitEntry{"rad", 1.0}, UnitEntry{"mrad", 1e-3},
                            UnitEntry{"urad", 1e-6}, UnitEntry{"deg", kDeg}};
constexpr std::array kTorque{UnitEntry{"Nm", 1.0}, UnitEntry{"mNm", 1e-3},
                             UnitEntry{"uNm", 1e-6}, UnitEntry{"nNm", 1e-9}};
constexpr std::array kStrain{UnitEntry{"", 1.0}, UnitEntry{"1", 1.0}, UnitEntry{"%", 1e-2}};
constexpr std::array kStress{UnitEntry{"Pa", 1.0}, UnitEntry{"mPa", 1e-3},
                             UnitEntry{"kPa", 1e3}, UnitEntry{"MPa", 1e6}};

template <std::size_t N>
std::optional<double> lookup(const std::array<UnitEntry, N>& table, const std::string& key) {
  for (const auto& e : table)
    if (key == e.spelling) return e.scale;
  return std::nullopt;
}

bool starts_with_at(std::string_view s, std::size_t i, std::string_view what) {
  return s.substr(i, what.size()) == what;
}

}  // namespace

const char* unit_kind_name(UnitKind kind) {
  switch (kind) {
    case UnitKind::kTime: return "time";
    case UnitKind::kAngle: return "angle";
    case UnitKind::kTorque: return "torque";
    case UnitKind::kStrain: return "strain";
    case UnitKind::kStress: return "stress";
  }
  return "?";
}

std::string accepted_units(UnitKind kind) {
  switch (kind) {
    case UnitKind::kTime: return "s, ms, min";
    case UnitKind::kAngle: return "rad, mrad, µrad, deg (°)";
    case UnitKind::kTorque:
      return "N·m, mN·m, µN·m, nN·m (also written N m, Nm, N.m, N-m, mNm, uN m, µNm ...)";
    case UnitKind::kStrain: return "1 or - (dimensionless), %";
    case UnitKind::kStress: return "Pa, mPa, kPa, MPa";
  }
  return "";
}

std::string normalize_unit(std::string_view u) {
  u = trim_blanks(u);
  if (u.size() >= 2 && ((u.front() == '[' && u.back() == ']') ||
                        (u.front() == '(' && u.back() == ')'))) {
    u = u.substr(1, u.size() - 2);
  }
  std::string out;
  for (std::size_t i = 0; i < u.size();) {
    const char c = u[i];
    if (starts_with_at(u, i, "\xC2\xB5") || starts_with_at(u, i, "\xCE\xBC")) {  // µ, μ
      out += 'u';
      i += 2;
    } else if (starts_with_at(u, i, "\xC2\xB0")) {  // °
      out += "deg";
      i += 2;
    } else if (starts_with_at(u, i, "\xC2\xB7") || starts_with_at(u, i, "\xC2\xA0")) {
      i += 2;  // middle dot, no-break space
    } else if (starts_with_at(u, i, "\xE2\x8B\x85") || starts_with_at(u, i, "\xE2\x80\xAF") ||
               starts_with_at(u, i, "\xE2\x88\x99")) {
      i += 3;  // dot operator, narrow no-break space, bullet operator
    } else if (c == ' ' || c == '\t' || c == '.' || c == '*' || c == '_' ||
               (c == '-' && u.size() > 1)) {
      ++i;
    } else {
      out += c;
      ++i;
    }
  }
  if (out == "-") out.clear();
  if (out == "degree" || out == "degrees") out = "deg";
  if (out == "pct" || out == "percent") out = "%";
  return out;
}

std::optional<double> find_unit_scale(std::string_view unit, UnitKind kind) {
  const std::string key = normalize_unit(unit);
  switch (kind) {
    case UnitKind::kTime: return lookup(kTime, key);
    case UnitKind::kAngle: return lookup(kAngle, key);
    case UnitKind::kTorque: return lookup(kTorque, key);
    case UnitKind::kStrain: return lookup(kStrain, key);
    case UnitKind::kStress: return lookup(kStress, key);
  }
  return std::nullopt;
}

double parse_unit(std::string_view unit, UnitKind kind, const std::string& where) {
  if (auto s = find_unit_scale(unit, kind)) return *s;
  throw InputError(fmt::format("{}: unknown {} unit \"{}\"; accepted: {}", where,
                               unit_kind_name(kind), unit, accepted_units(kind)));
}

}  // namespace shearzone::io
