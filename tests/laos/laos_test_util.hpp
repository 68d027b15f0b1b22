// Helpers for the laos tests: synthetic waveforms and tiny readers for the external
// example files (kept local so the stage tests do not depend on the io readers).
#pragma once

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <fstream>
#include <functional>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "shearzone/laos/analysis.hpp"

namespace shearzone::laos::testutil {

inline constexpr double kPi = std::numbers::pi;

/// LAOS_TEST_PRINT=1: print a measured error (the figures quoted in the README).
inline void note(const std::string& what, double value) {
  if (std::getenv("LAOS_TEST_PRINT")) std::cout << "[laos] " << what << ": " << value << "\n";
}
/// Relative error |a/b − 1| (absolute when b = 0).
inline double rel_err(double a, double b) { return b == 0 ? std::abs(a) : std::abs(a / b - 1); }

/// Timed record x = sign·x0 sin(ωt), t_i = i T/N for i = 0..N·cycles (the end sample
/// closes the last cycle); r = model(θ, t) with θ = ωt.
inline Waveform timed(double x0, double omega, int per_cycle, int cycles,
                      const std::function<double(double theta, double t)>& model,
                      double sign = 1.0) {
  Waveform w;
  const long n = static_cast<long>(per_cycle) * cycles;
  const double T = 2 * kPi / omega;
  for (long i = 0; i <= n; ++i) {
    const double t = T * static_cast<double>(i) / per_cycle;
    const double th = omega * t;
    w.time_s.push_back(t);
    w.drive.push_back(sign * x0 * std::sin(th));
    w.response.push_back(model(th, t));
  }
  return w;
}

/// Δx-triggered record without time: x runs 0 → x0 → −x0 → 0 on the grid k·dx
/// (x0/dx an integer), `cycles` times; r = model(θ) with θ the exact phase.
inline Waveform angle_sampled(double x0, double dx, int cycles,
                              const std::function<double(double theta)>& model) {
  Waveform w;
  const long q = std::lround(x0 / dx);
  for (int c = 0; c < cycles; ++c) {
    const long start = c == 0 ? 0 : 1;
    for (long k = start; k < 4 * q + 1; ++k) {
      long m;  // grid index of x
      double th;
      if (k <= q) {
        m = k;
      } else if (k <= 3 * q) {
        m = 2 * q - k;
      } else {
        m = k - 4 * q;
      }
      const double x = dx * static_cast<double>(m);
      const double u = std::clamp(x / x0, -1.0, 1.0);
      if (k <= q)
        th = std::asin(u);
      else if (k <= 3 * q)
        th = kPi - std::asin(u);
      else
        th = 2 * kPi + std::asin(u);
      w.drive.push_back(x);
      w.response.push_back(model(th + 2 * kPi * c));
    }
  }
  return w;
}

struct Table {
  std::vector<std::vector<double>> cols;
  double omega = NAN, gamma0 = NAN;
};

/// RepTate .laos: `omega=..;gamma=..;` then whitespace rows (lines starting with '#'
/// skipped); rheojax raw_signal: TAB rows, CRLF.
inline Table read_table(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  Table t;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (line.find("omega=") != std::string::npos) {
      const auto a = line.find("omega=") + 6, g = line.find("gamma=") + 6;
      t.omega = std::stod(line.substr(a));
      t.gamma0 = std::stod(line.substr(g));
      continue;
    }
    std::istringstream ss(line);
    std::vector<double> row;
    std::string cell;
    while (ss >> cell) row.push_back(std::stod(cell));
    if (t.cols.empty()) t.cols.resize(row.size());
    for (std::size_t k = 0; k < row.size() && k < t.cols.size(); ++k) t.cols[k].push_back(row[k]);
  }
  return t;
}

}  // namespace shearzone::laos::testutil
