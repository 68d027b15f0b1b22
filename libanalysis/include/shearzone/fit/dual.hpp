// shearzone/fit/dual.hpp: a small forward-mode dual number for exact Jacobians.
//
// Dual<N> carries a value and its N partial derivatives. A model functor written as
// a template over its scalar type (`template <class T> T operator()(const T* p,
// double x) const`) is instantiated with Dual<kParams> to give the model value and
// its exact gradient with respect to the parameters in one pass (automatic
// differentiation, no finite differences). Only the functions the models need are
// provided; each is differentiated analytically below.
#pragma once

#include <array>
#include <cmath>
#include <numbers>

namespace shearzone::fit {

template <int N>
struct Dual {
  double v = 0.0;                 ///< value
  std::array<double, N> d{};      ///< partial derivatives

  Dual() = default;
  Dual(double value) : v(value) {}  // NOLINT: constants mix freely with duals
  /// The k-th independent variable with value `value`.
  static Dual variable(double value, int k) {
    Dual r(value);
    r.d[static_cast<std::size_t>(k)] = 1.0;
    return r;
  }

  Dual& operator+=(const Dual& b) { return *this = *this + b; }
  Dual& operator-=(const Dual& b) { return *this = *this - b; }
  Dual& operator*=(const Dual& b) { return *this = *this * b; }
  Dual& operator/=(const Dual& b) { return *this = *this / b; }

  /// Value and derivatives scaled: a*v, a*d.
  friend Dual scaled(const Dual& a, double value, double dfactor) {
    Dual r(value);
    for (int k = 0; k < N; ++k) r.d[k] = dfactor * a.d[k];
    return r;
  }
  friend Dual operator+(const Dual& a, const Dual& b) {
    Dual r(a.v + b.v);
    for (int k = 0; k < N; ++k) r.d[k] = a.d[k] + b.d[k];
    return r;
  }
  friend Dual operator-(const Dual& a, const Dual& b) {
    Dual r(a.v - b.v);
    for (int k = 0; k < N; ++k) r.d[k] = a.d[k] - b.d[k];
    return r;
  }
  friend Dual operator-(const Dual& a) { return scaled(a, -a.v, -1.0); }
  friend Dual operator*(const Dual& a, const Dual& b) {
    Dual r(a.v * b.v);
    for (int k = 0; k < N; ++k) r.d[k] = a.d[k] * b.v + a.v * b.d[k];
    return r;
  }
  friend Dual operator/(const Dual& a, const Dual& b) {
    const double q = a.v / b.v;
    Dual r(q);
    for (int k = 0; k < N; ++k) r.d[k] = (a.d[k] - q * b.d[k]) / b.v;
    return r;
  }
  friend bool operator<(const Dual& a, const Dual& b) { return a.v < b.v; }
  friend bool operator>(const Dual& a, const Dual& b) { return a.v > b.v; }

  friend Dual exp(const Dual& a) {
    const double e = std::exp(a.v);
    return scaled(a, e, e);
  }
  friend Dual log(const Dual& a) { return scaled(a, std::log(a.v), 1.0 / a.v); }
  friend Dual sqrt(const Dual& a) {
    const double s = std::sqrt(a.v);
    return scaled(a, s, 0.5 / s);
  }
  friend Dual sin(const Dual& a) { return scaled(a, std::sin(a.v), std::cos(a.v)); }
  friend Dual cos(const Dual& a) { return scaled(a, std::cos(a.v), -std::sin(a.v)); }
  friend Dual atan(const Dual& a) { return scaled(a, std::atan(a.v), 1.0 / (1.0 + a.v * a.v)); }
  friend Dual erf(const Dual& a) {
    return scaled(a, std::erf(a.v), 2.0 / std::sqrt(std::numbers::pi) * std::exp(-a.v * a.v));
  }
  friend Dual abs(const Dual& a) { return scaled(a, std::fabs(a.v), a.v < 0 ? -1.0 : 1.0); }
  /// a^b for a > 0 (both may depend on the parameters).
  friend Dual pow(const Dual& a, const Dual& b) { return exp(b * log(a)); }
  /// a^c for a constant exponent c (a may be negative when c is an integer).
  friend Dual pow(const Dual& a, double c) {
    return scaled(a, std::pow(a.v, c), c * std::pow(a.v, c - 1.0));
  }
  /// c^b for a constant base c > 0.
  friend Dual pow(double c, const Dual& b) {
    const double p = std::pow(c, b.v);
    return scaled(b, p, p * std::log(c));
  }
};

/// The value of a double or a dual (for branches in models).
inline double value_of(double x) { return x; }
template <int N>
double value_of(const Dual<N>& x) { return x.v; }

}  // namespace shearzone::fit
