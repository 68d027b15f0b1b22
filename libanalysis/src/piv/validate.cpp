#include "shearzone/piv/validate.hpp"

#include <algorithm>
#include <cmath>

#include "shearzone/core/stats.hpp"

namespace shearzone::piv {

using core::VectorFlag;

std::size_t flag_outliers(core::VectorField& f, const PivOptions& o) {
  const int nx = static_cast<int>(f.nx()), ny = static_cast<int>(f.ny());
  std::vector<char> outlier(f.size(), 0);

  // Step 1: global limits (magnitude, std filter).
  double su = 0, sv = 0, suu = 0, svv = 0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < f.size(); ++k) {
    if (f.flag[k] != VectorFlag::kValid) continue;
    su += f.u_px[k];
    sv += f.v_px[k];
    suu += static_cast<double>(f.u_px[k]) * f.u_px[k];
    svv += static_cast<double>(f.v_px[k]) * f.v_px[k];
    ++n;
  }
  const double mu = n ? su / n : 0, mv = n ? sv / n : 0;
  const double sdu = n ? std::sqrt(std::max(0.0, suu / n - mu * mu)) : 0;
  const double sdv = n ? std::sqrt(std::max(0.0, svv / n - mv * mv)) : 0;
  for (std::size_t k = 0; k < f.size(); ++k) {
    if (f.flag[k] != VectorFlag::kValid) continue;
    if (std::hypot(f.u_px[k], f.v_px[k]) > o.max_displacement_px) outlier[k] = 1;
    if (o.std_threshold > 0 && (std::abs(f.u_px[k] - mu) > o.std_threshold * sdu ||
                                std::abs(f.v_px[k] - mv) > o.std_threshold * sdv))
      outlier[k] = 1;
  }

  // Step 2: normalised median test.
  if (o.median_threshold > 0) {
    const int r = o.median_radius;
#pragma omp parallel
    {
      std::vector<double> nu, nv, res;
#pragma omp for schedule(static)
      for (int i = 0; i < ny; ++i)
        for (int j = 0; j < nx; ++j) {
          const std::size_t k = f.index(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
          if (f.flag[k] != VectorFlag::kValid) continue;
          nu.clear();
          nv.clear();
          for (int di = -r; di <= r; ++di)
            for (int dj = -r; dj <= r; ++dj) {
              if (di == 0 && dj == 0) continue;
              const int ii = i + di, jj = j + dj;
              if (ii < 0 || jj < 0 || ii >= ny || jj >= nx) continue;
              const std::size_t q = f.index(static_cast<std::size_t>(ii), static_cast<std::size_t>(jj));
              if (f.flag[q] == VectorFlag::kMasked || f.flag[q] == VectorFlag::kInvalid) continue;
              nu.push_back(f.u_px[q]);
              nv.push_back(f.v_px[q]);
            }
          if (nu.size() < 2) continue;  // too few neighbours to judge
          for (int comp = 0; comp < 2; ++comp) {
            std::vector<double>& vals = comp == 0 ? nu : nv;
            const double x0 = comp == 0 ? f.u_px[k] : f.v_px[k];
            const double m = core::median_inplace(vals);
            res.resize(vals.size());
            for (std::size_t q = 0; q < vals.size(); ++q) res[q] = std::abs(vals[q] - m);
            const double rm = core::median_inplace(res);
            if (std::abs(x0 - m) / (rm + o.median_epsilon_px) > o.median_threshold) outlier[k] = 1;
          }
        }
    }
  }

  // Step 3: isolated vectors, peeled until none is left (each sweep judges on the
  // flags of the previous one, so small chance clusters erode from outside in).
  std::vector<VectorFlag> flags = f.flag;
  for (std::size_t k = 0; k < f.size(); ++k)
    if (outlier[k]) flags[k] = VectorFlag::kReplaced;
  for (int sweep = 0; sweep < 8; ++sweep) {
    std::vector<std::size_t> isolated;
    for (int i = 0; i < ny; ++i)
      for (int j = 0; j < nx; ++j) {
        const std::size_t k = f.index(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
        if (flags[k] != VectorFlag::kValid) continue;
        int unmasked = 0, valid = 0;
        for (int di = -2; di <= 2; ++di)
          for (int dj = -2; dj <= 2; ++dj) {
            const int ii = i + di, jj = j + dj;
            if ((di == 0 && dj == 0) || ii < 0 || jj < 0 || ii >= ny || jj >= nx) continue;
            const std::size_t q = f.index(static_cast<std::size_t>(ii), static_cast<std::size_t>(jj));
            if (flags[q] == VectorFlag::kMasked) continue;
            ++unmasked;
            valid += flags[q] == VectorFlag::kValid;
          }
        if (unmasked >= 4 && 4 * valid < unmasked) isolated.push_back(k);
      }
    if (isolated.empty()) break;
    for (std::size_t k : isolated) {
      flags[k] = VectorFlag::kInvalid;
      outlier[k] = 2;
    }
  }

  std::size_t count = 0;
  for (std::size_t k = 0; k < f.size(); ++k)
    if (outlier[k]) {
      f.flag[k] = outlier[k] == 2 ? VectorFlag::kInvalid : VectorFlag::kReplaced;
      ++count;
    }
  return count;
}

std::size_t demote_unsupported_replacements(core::VectorField& f, double min_valid_fraction) {
  const int nx = static_cast<int>(f.nx()), ny = static_cast<int>(f.ny());
  std::vector<std::size_t> demote;
  for (int i = 0; i < ny; ++i)
    for (int j = 0; j < nx; ++j) {
      const std::size_t k = f.index(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
      if (f.flag[k] != VectorFlag::kReplaced) continue;
      int around = 0, valid = 0;
      for (int di = -1; di <= 1; ++di)
        for (int dj = -1; dj <= 1; ++dj) {
          const int ii = i + di, jj = j + dj;
          if ((di == 0 && dj == 0) || ii < 0 || jj < 0 || ii >= ny || jj >= nx) continue;
          const VectorFlag q = f.flag[f.index(static_cast<std::size_t>(ii), static_cast<std::size_t>(jj))];
          if (q == VectorFlag::kMasked) continue;
          ++around;
          valid += q == VectorFlag::kValid;
        }
      if (valid < 3 || valid < min_valid_fraction * around) demote.push_back(k);
    }
  for (std::size_t k : demote) f.flag[k] = VectorFlag::kInvalid;  // decided on the flags before
  return demote.size();
}

void fill_holes(core::VectorField& f, const std::vector<VectorFlag>& holes) {
  const int nx = static_cast<int>(f.nx()), ny = static_cast<int>(f.ny());
  auto is_hole = [&](VectorFlag fl) {
    return std::find(holes.begin(), holes.end(), fl) != holes.end();
  };
  // known: 1 = measured value to use, 0 = unknown hole, -1 = ignored (masked, not a hole)
  std::vector<signed char> known(f.size());
  std::size_t unknown = 0;
  for (std::size_t k = 0; k < f.size(); ++k) {
    if (is_hole(f.flag[k])) {
      known[k] = 0;
      ++unknown;
    } else {
      known[k] = f.flag[k] == VectorFlag::kMasked ? -1 : 1;
    }
  }
  std::vector<std::size_t> fill_k;
  std::vector<float> fill_u, fill_v;
  while (unknown > 0) {
    fill_k.clear();
    fill_u.clear();
    fill_v.clear();
    for (int i = 0; i < ny; ++i)
      for (int j = 0; j < nx; ++j) {
        const std::size_t k = f.index(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
        if (known[k] != 0) continue;
        double su = 0, sv = 0;
        int n = 0;
        for (int di = -1; di <= 1; ++di)
          for (int dj = -1; dj <= 1; ++dj) {
            const int ii = i + di, jj = j + dj;
            if ((di == 0 && dj == 0) || ii < 0 || jj < 0 || ii >= ny || jj >= nx) continue;
            const std::size_t q = f.index(static_cast<std::size_t>(ii), static_cast<std::size_t>(jj));
            if (known[q] != 1) continue;
            su += f.u_px[q];
            sv += f.v_px[q];
            ++n;
          }
        if (n > 0) {
          fill_k.push_back(k);
          fill_u.push_back(static_cast<float>(su / n));
          fill_v.push_back(static_cast<float>(sv / n));
        }
      }
    if (fill_k.empty()) break;  // no known vector reachable
    for (std::size_t q = 0; q < fill_k.size(); ++q) {
      f.u_px[fill_k[q]] = fill_u[q];
      f.v_px[fill_k[q]] = fill_v[q];
      known[fill_k[q]] = 1;
    }
    unknown -= fill_k.size();
  }
  for (std::size_t k = 0; k < f.size(); ++k)
    if (known[k] == 0) {
      f.u_px[k] = 0.0f;
      f.v_px[k] = 0.0f;
    }
}

}  // namespace shearzone::piv
