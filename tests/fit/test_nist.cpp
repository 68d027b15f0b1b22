// NIST StRD nonlinear regression: every problem in tests/data/nist-strd from both
// start points through fit::solve(), compared with the certified values.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "shearzone/fit/least_squares.hpp"

using namespace shearzone;
using namespace shearzone::fit;

namespace {

/// Parameters must match the certified values to at least this many significant
/// digits (log relative error). NIST/Ceres/lmfit suites use 4 to 6; Ceres followed by
/// a Gauss–Newton polish reaches 10.4–11 (the rounding limit of the certified values)
/// and this fitter 9.7 at worst (docs/fits-collapse.md), so 6 leaves a wide margin.
constexpr double kMinParamLre = 6.0;
/// Standard errors: 4 digits (the SE also depends on the residual variance, whose
/// certified value is given to 11 digits; 4 is the required minimum).
constexpr double kMinSeLre = 4.0;
/// LRE is capped here: the certified values are printed with 11 significant digits.
constexpr double kLreCap = 11.0;

struct NistData {
  std::string name;
  std::vector<double> start1, start2, certified, certified_se, x, y;
};

NistData read_nist(const std::string& name) {
  NistData d;
  d.name = name;
  std::ifstream in(std::string(SHEARZONE_TEST_DATA_DIR) + "/nist-strd/" + name + ".dat");
  REQUIRE(in.good());
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) {
    if (!l.empty() && l.back() == '\r') l.pop_back();
    lines.push_back(l);
  }
  const std::regex param(R"(^\s*b\d+\s*=\s*(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$)");
  std::size_t data_start = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    std::smatch m;
    if (std::regex_match(lines[i], m, param)) {
      d.start1.push_back(std::stod(m[1]));
      d.start2.push_back(std::stod(m[2]));
      d.certified.push_back(std::stod(m[3]));
      d.certified_se.push_back(std::stod(m[4]));
    }
    if (lines[i].rfind("Data:", 0) == 0) data_start = i + 1;
  }
  for (std::size_t i = data_start; i < lines.size(); ++i) {
    std::istringstream ss(lines[i]);
    double y = 0, x = 0;
    if (ss >> y >> x) {
      d.y.push_back(y);
      d.x.push_back(x);
    }
  }
  REQUIRE(!d.certified.empty());
  REQUIRE(d.x.size() > d.certified.size());
  return d;
}

double lre(double est, double cert) {
  if (est == cert) return kLreCap;
  return std::min(kLreCap, -std::log10(std::fabs(est - cert) / std::fabs(cert)));
}

// The NIST models as functors (the same kind of functor the toolkit's models are).
#define SZ_NIST_MODEL(Name, K, expr)                              \
  struct Name {                                                   \
    static constexpr int kParams = K;                             \
    template <class T>                                            \
    T operator()(const T* b, double x) const {                    \
      using std::atan;                                            \
      using std::cos;                                             \
      using std::exp;                                             \
      using std::pow;                                             \
      using std::sin;                                             \
      [[maybe_unused]] constexpr double pi = std::numbers::pi;    \
      return expr;                                                \
    }                                                             \
  };

SZ_NIST_MODEL(Misra1a, 2, b[0] * (1.0 - exp(-b[1] * x)))
SZ_NIST_MODEL(Chwirut2, 3, exp(-b[0] * x) / (b[1] + b[2] * x))
SZ_NIST_MODEL(DanWood, 2, b[0] * pow(x, b[1]))
SZ_NIST_MODEL(Gauss1, 8,
              b[0] * exp(-b[1] * x) + b[2] * exp(-(x - b[3]) * (x - b[3]) / (b[4] * b[4])) +
                  b[5] * exp(-(x - b[6]) * (x - b[6]) / (b[7] * b[7])))
SZ_NIST_MODEL(ENSO, 9,
              b[0] + b[1] * std::cos(2 * pi * x / 12) + b[2] * std::sin(2 * pi * x / 12) +
                  b[4] * cos(2 * pi * x / b[3]) + b[5] * sin(2 * pi * x / b[3]) +
                  b[7] * cos(2 * pi * x / b[6]) + b[8] * sin(2 * pi * x / b[6]))
SZ_NIST_MODEL(Lanczos1, 6,
              b[0] * exp(-b[1] * x) + b[2] * exp(-b[3] * x) + b[4] * exp(-b[5] * x))
SZ_NIST_MODEL(MGH17, 5, b[0] + b[1] * exp(-x * b[3]) + b[2] * exp(-x * b[4]))
SZ_NIST_MODEL(Roszman1, 4, b[0] - b[1] * x - atan(b[2] / (x - b[3])) / pi)
SZ_NIST_MODEL(Bennett5, 3, b[0] * pow(b[1] + x, -1.0 / b[2]))
SZ_NIST_MODEL(BoxBOD, 2, b[0] * (1.0 - exp(-b[1] * x)))
SZ_NIST_MODEL(Eckerle4, 3, (b[0] / b[1]) * exp(-0.5 * ((x - b[2]) / b[1]) * ((x - b[2]) / b[1])))
SZ_NIST_MODEL(MGH09, 4, b[0] * (x * x + x * b[1]) / (x * x + x * b[2] + b[3]))
SZ_NIST_MODEL(MGH10, 3, b[0] * exp(b[1] / (x + b[2])))
SZ_NIST_MODEL(Rat42, 3, b[0] / (1.0 + exp(b[1] - b[2] * x)))
SZ_NIST_MODEL(Rat43, 4, b[0] / pow(1.0 + exp(b[1] - b[2] * x), 1.0 / b[3]))
SZ_NIST_MODEL(Thurber, 7,
              (b[0] + b[1] * x + b[2] * x * x + b[3] * x * x * x) /
                  (1.0 + b[4] * x + b[5] * x * x + b[6] * x * x * x))

/// Equivalent minima put in the certified form (sign symmetries, permutations).
void canonical(const std::string& name, std::vector<double>& v, std::vector<double>& se) {
  if (name == "Eckerle4" && v[1] < 0) {
    v[0] = -v[0];
    v[1] = -v[1];
  }
  if (name == "Gauss1") {
    v[4] = std::fabs(v[4]);
    v[7] = std::fabs(v[7]);
  }
  if (name == "MGH17" && v[3] > v[4]) {
    std::swap(v[1], v[2]);
    std::swap(v[3], v[4]);
    std::swap(se[1], se[2]);
    std::swap(se[3], se[4]);
  }
  if (name == "Lanczos1") {  // terms sorted by rate
    std::vector<std::array<double, 4>> t;
    for (int j = 0; j < 3; ++j) t.push_back({v[2 * j + 1], v[2 * j], se[2 * j], se[2 * j + 1]});
    std::sort(t.begin(), t.end());
    for (int j = 0; j < 3; ++j) {
      v[2 * j] = t[j][1];
      v[2 * j + 1] = t[j][0];
      se[2 * j] = t[j][2];
      se[2 * j + 1] = t[j][3];
    }
  }
}

struct Worst {
  double param = kLreCap, se = kLreCap;
  std::string param_case, se_case;
};

template <class Model>
void check_problem(const std::string& name, Worst& worst) {
  const NistData d = read_nist(name);
  REQUIRE(static_cast<int>(d.certified.size()) == Model::kParams);
  for (int s = 1; s <= 2; ++s) {
    const auto& start = s == 1 ? d.start1 : d.start2;
    const FitResult r = solve(curve_problem(Model{}, d.x, d.y, {}, {}), start);
    INFO(name << " start " << s << ": " << r.termination << " " << r.message << "\n"
              << fit_report(r, name));
    REQUIRE(r.usable);
    std::vector<double> v = r.values, se = r.std_errors;
    if (std::getenv("SZ_NIST_VERBOSE")) std::printf("%s s%d polish=%d it=%d cost=%.17g\n", name.c_str(), s, r.polish_steps, r.iterations, r.final_cost);
    canonical(name, v, se);
    for (std::size_t k = 0; k < v.size(); ++k) {
      const double lp = lre(v[k], d.certified[k]);
      const double ls = lre(se[k], d.certified_se[k]);
      INFO("b" << k + 1 << " = " << v[k] << " (certified " << d.certified[k] << ", LRE " << lp
               << "), SE " << se[k] << " (certified " << d.certified_se[k] << ", LRE " << ls << ")");
      CHECK(lp >= kMinParamLre);
      if (lp < worst.param) {
        worst.param = lp;
        worst.param_case = name + " start " + std::to_string(s);
      }
      if (name == "Lanczos1") continue;  // certified RSS 1.4e-25 is below round-off
      CHECK(ls >= kMinSeLre);
      if (ls < worst.se) {
        worst.se = ls;
        worst.se_case = name + " start " + std::to_string(s);
      }
    }
  }
}

}  // namespace

TEST_CASE("NIST StRD: certified parameters and standard errors from both starts", "[fit][nist]") {
  Worst w;
  check_problem<Misra1a>("Misra1a", w);
  check_problem<Chwirut2>("Chwirut2", w);
  check_problem<DanWood>("DanWood", w);
  check_problem<Gauss1>("Gauss1", w);
  check_problem<ENSO>("ENSO", w);
  check_problem<Lanczos1>("Lanczos1", w);
  check_problem<MGH17>("MGH17", w);
  check_problem<Roszman1>("Roszman1", w);
  check_problem<Bennett5>("Bennett5", w);
  check_problem<BoxBOD>("BoxBOD", w);
  check_problem<Eckerle4>("Eckerle4", w);
  check_problem<MGH09>("MGH09", w);
  check_problem<MGH10>("MGH10", w);
  check_problem<Rat42>("Rat42", w);
  check_problem<Rat43>("Rat43", w);
  check_problem<Thurber>("Thurber", w);
  std::printf("NIST StRD (16 problems x 2 starts): worst parameter LRE %.1f (%s), worst SE LRE "
              "%.1f (%s, Lanczos1 SEs excluded)\n",
              w.param, w.param_case.c_str(), w.se, w.se_case.c_str());
}
