// Rheometer log readers: every sample format of tests/data/logs (written by
// make_logs.py from the same waveforms) reads to the same numbers in SI units; the
// units, encodings and errors behave as documented in oscillation_log.hpp.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/io/oscillation_log.hpp"
#include "shearzone/io/units.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;

namespace {

const std::filesystem::path kLogs = std::filesystem::path(SHEARZONE_TEST_DATA_DIR) / "logs";
const std::filesystem::path kReptate =
    std::filesystem::path(SHEARZONE_TEST_DATA_DIR) / "laos-external" / "reptate";

// The waveforms of make_logs.py: phi = PHI0 sin(w t), torque = K phi + C dphi/dt.
constexpr double kF = 0.1;
constexpr double kW = 2 * std::numbers::pi * kF;
constexpr double kK = 4e-3;  // N m / rad
constexpr double kC = 2e-3;  // N m s / rad
constexpr double kAmplitudes[2] = {0.05, 0.2};
constexpr std::size_t kPoints = 75;
constexpr double kDt = 0.4;
constexpr double kStrainConstant = 1.5;     // 1/rad
constexpr double kStressConstant = 12000;   // Pa/(N m)
// The files hold 6 significant digits: a value is off by at most 5e-6 of itself, so
// by at most 5e-6 of the segment's amplitude; 1e-5 leaves room for unit conversions.
constexpr double kRoundingRel = 1e-5;
// Times are written exactly (0.1 s or 1 ms steps); only the decimal parse rounds.
constexpr double kTimeTol = 1e-9;

/// Checks that `log` holds the sample waveforms; `drive_scale`/`response_scale`
/// convert angle/torque to what the log holds (1 or the strain/stress constants).
void check_waveforms(const io::OscillationLog& log, std::size_t segments, bool has_time,
                     double drive_scale = 1.0, double response_scale = 1.0) {
  REQUIRE(log.segments.size() == segments);
  for (std::size_t s = 0; s < segments; ++s) {
    const io::LogSegment& seg = log.segments[s];
    INFO(log.source << " segment " << s + 1);
    REQUIRE(seg.drive.size() == kPoints);
    REQUIRE(seg.response.size() == kPoints);
    REQUIRE(seg.line.size() == kPoints);
    REQUIRE(seg.time_s.size() == (has_time ? kPoints : 0));
    const double phi0 = kAmplitudes[s];
    const double drive_amp = drive_scale * phi0;
    const double response_amp = response_scale * phi0 * std::hypot(kK, kC * kW);
    for (std::size_t i = 0; i < kPoints; ++i) {
      const double phase = kW * kDt * static_cast<double>(i);
      const double phi = phi0 * std::sin(phase);
      const double tau = kK * phi + kC * phi0 * kW * std::cos(phase);
      INFO("sample " << i << " line " << seg.line[i]);
      if (has_time)
        CHECK(seg.time_s[i] - seg.time_s[0] ==
              Approx(kDt * static_cast<double>(i)).margin(kTimeTol));
      CHECK(seg.drive[i] == Approx(drive_scale * phi).margin(kRoundingRel * drive_amp));
      CHECK(seg.response[i] == Approx(response_scale * tau).margin(kRoundingRel * response_amp));
    }
  }
}

/// Expects reading `path` to throw InputError containing each fragment.
void expect_input_error(const std::filesystem::path& path, const io::LogReadOptions& o,
                        const std::vector<std::string>& fragments) {
  try {
    (void)io::read_oscillation_log(path, o);
    FAIL("expected InputError reading " << path);
  } catch (const InputError& e) {
    INFO(e.what());
    for (const auto& f : fragments) CHECK_THAT(e.what(), Contains(f));
  }
}

}  // namespace

TEST_CASE("Every sample log format reads to the same waveforms in SI units", "[io][log]") {
  io::LogReadOptions o;
  SECTION("generic CSV, SI column names, interval column, metadata header") {
    o.interval_column = "interval";
    const auto log = io::read_oscillation_log(kLogs / "generic.csv", o);
    CHECK(log.format == io::LogFormat::kCsv);
    check_waveforms(log, 2, true);
    CHECK(log.segments[0].label == "1");
    CHECK(log.segments[1].time_s[0] == Approx(40.0).margin(kTimeTol));
    CHECK(core::metadata_value(log.parameters, "N") == "45");
    CHECK(log.omega_rad_per_s == Approx(kW).epsilon(1e-15));
    CHECK(log.segments[0].line[0] == 5);  // after three '#' lines and the header
  }
  SECTION("TSV with decimal commas, bracketed units ms, mrad, mN·m") {
    o.interval_column = "Interval";
    const auto log = io::read_oscillation_log(kLogs / "generic_mrad_mNm.tsv", o);
    check_waveforms(log, 2, true);
    CHECK(log.segments[1].time_s[0] == Approx(40.0).margin(kTimeTol));
  }
  SECTION("angle-sampled log: no time, deg and µN·m from the name suffixes") {
    o.interval_column = "segment";
    const auto log = io::read_oscillation_log(kLogs / "angle_sampled.csv", o);
    check_waveforms(log, 2, false);
  }
  SECTION("Anton Paar, English, UTF-16 LE, two name rows, mrad and µNm") {
    const auto log = io::read_oscillation_log(kLogs / "anton_paar_en_utf16.txt", o);
    CHECK(log.format == io::LogFormat::kAntonPaar);
    check_waveforms(log, 2, true);
    CHECK(log.segments[1].time_s[0] == Approx(40.0).margin(kTimeTol));
    CHECK(core::metadata_value(log.parameters, "Project") == "shearzone samples");
  }
  SECTION("Anton Paar, German, UTF-8, interval time, degrees and mN·m") {
    const auto log = io::read_oscillation_log(kLogs / "anton_paar_de_utf8.txt", o);
    CHECK(log.format == io::LogFormat::kAntonPaar);
    check_waveforms(log, 2, true);
    CHECK(log.segments[1].time_s[0] == 0.0);  // Intervallzeit restarts
    CHECK(core::metadata_value(log.parameters, "Projekt") == "shearzone Beispiele");
  }
  SECTION("Anton Paar, French, UTF-8 with BOM, rad and µN·m") {
    const auto log = io::read_oscillation_log(kLogs / "anton_paar_fr.txt", o);
    CHECK(log.format == io::LogFormat::kAntonPaar);
    check_waveforms(log, 2, true);
  }
  SECTION("TRIOS: steps, µN.m, stress and strain constants") {
    const auto log = io::read_oscillation_log(kLogs / "trios.txt", o);
    CHECK(log.format == io::LogFormat::kTrios);
    check_waveforms(log, 2, true);
    CHECK(log.segments[0].label == "Oscillation amplitude - 1");
    CHECK(log.stress_constant_Pa_per_N_m == kStressConstant);
    CHECK(log.strain_constant_per_rad == kStrainConstant);
  }
  SECTION("TRIOS CSV export: ',' cells, steps without a waveform skipped and listed") {
    const auto log = io::read_oscillation_log(kLogs / "trios_export.csv", o);
    CHECK(log.format == io::LogFormat::kTrios);
    check_waveforms(log, 2, true);
    CHECK(log.segments[0].label == "Oscillation amplitude - 2");
    CHECK(log.stress_constant_Pa_per_N_m == kStressConstant);
    REQUIRE(log.skipped.size() == 2);
    CHECK_THAT(log.skipped[0], Contains("Peak hold - 1 (line 9): no drive and response columns"));
    CHECK_THAT(log.skipped[1], Contains("Amplitude sweep - 4 (line 176): no raw waveform"));
  }
  SECTION("TRIOS LIMS export: key rows, a constant in Pa/g.cm, a summary step skipped") {
    const auto log = io::read_oscillation_log(kLogs / "trios_lims.txt", o);
    CHECK(log.format == io::LogFormat::kTrios);
    check_waveforms(log, 1, true);
    CHECK(log.segments[0].label == "Oscillation amplitude (raw)");
    // 1.17680 Pa/g.cm with 1 g.cm = 9.80665e-5 N m (6 printed digits).
    CHECK(log.stress_constant_Pa_per_N_m == Approx(kStressConstant).epsilon(kRoundingRel));
    REQUIRE(log.skipped.size() == 1);
    CHECK_THAT(log.skipped[0], Contains("Frequency sweep (25.0 \xC2\xB0" "C) (line 87): no raw waveform"));
  }
  SECTION("RepTate .laos: one amplitude, angle and torque from the units row") {
    const auto log = io::read_oscillation_log(kLogs / "sample.laos", o);
    CHECK(log.format == io::LogFormat::kRepTate);
    CHECK(log.quantity == io::LogQuantity::kAngleTorque);
    check_waveforms(log, 1, true);
    CHECK(log.omega_rad_per_s == Approx(kW).epsilon(1e-15));
    CHECK(core::metadata_value(log.parameters, "gamma0") == "0.05");
  }
}

TEST_CASE("Strain/stress logs: % strain and Pa stress", "[io][log]") {
  io::LogReadOptions o;
  o.quantity = io::LogQuantity::kStrainStress;
  SECTION("generic CSV with strain_pct and stress_Pa (default names in this mode)") {
    o.interval_column = "interval";
    const auto log = io::read_oscillation_log(kLogs / "generic_strain_stress.csv", o);
    CHECK(log.quantity == io::LogQuantity::kStrainStress);
    check_waveforms(log, 2, true, kStrainConstant, kStressConstant);
  }
  SECTION("TRIOS oscillation strain (%) and stress (Pa) columns") {
    const auto log = io::read_oscillation_log(kLogs / "trios.txt", o);
    check_waveforms(log, 2, true, kStrainConstant, kStressConstant);
  }
}

TEST_CASE("Units: spellings and factors to SI", "[io][log][units]") {
  using io::UnitKind;
  const double deg = std::numbers::pi / 180;
  CHECK(io::parse_unit("rad", UnitKind::kAngle, "w") == 1.0);
  CHECK(io::parse_unit("[mrad]", UnitKind::kAngle, "w") == 1e-3);
  CHECK(io::parse_unit("deg", UnitKind::kAngle, "w") == deg);
  CHECK(io::parse_unit("\xC2\xB0", UnitKind::kAngle, "w") == deg);  // °
  for (const char* u : {"N m", "N\xC2\xB7m", "Nm", "N.m", "N-m", "N_m", "[N\xC2\xB7m]"})
    CHECK(io::parse_unit(u, UnitKind::kTorque, "w") == 1.0);
  for (const char* u : {"mN m", "mN\xC2\xB7m", "mNm", "mN.m", "mN_m"})
    CHECK(io::parse_unit(u, UnitKind::kTorque, "w") == 1e-3);
  for (const char* u : {"uN m", "\xC2\xB5Nm", "\xC2\xB5N\xC2\xB7m", "\xCE\xBCN.m", "uN_m"})
    CHECK(io::parse_unit(u, UnitKind::kTorque, "w") == 1e-6);
  CHECK(io::parse_unit("ms", UnitKind::kTime, "w") == 1e-3);
  CHECK(io::parse_unit("s", UnitKind::kTime, "w") == 1.0);
  CHECK(io::parse_unit("%", UnitKind::kStrain, "w") == 1e-2);
  CHECK(io::parse_unit("-", UnitKind::kStrain, "w") == 1.0);
  CHECK(io::parse_unit("1", UnitKind::kStrain, "w") == 1.0);
  CHECK(io::parse_unit("Pa", UnitKind::kStress, "w") == 1.0);
  CHECK(io::parse_unit("kPa", UnitKind::kStress, "w") == 1e3);
  CHECK_FALSE(io::find_unit_scale("MN m", UnitKind::kTorque));  // case matters
  CHECK_FALSE(io::find_unit_scale("mrad", UnitKind::kTorque));
  try {
    io::parse_unit("lbf in", UnitKind::kTorque, "f.csv:3: column \"Torque\"");
    FAIL("expected InputError");
  } catch (const InputError& e) {
    CHECK_THAT(e.what(), Contains("f.csv:3") && Contains("\"lbf in\"") && Contains("mN"));
  }
}

TEST_CASE("Text decoding: UTF-16 LE/BE with BOM, UTF-8 BOM, invalid UTF-16", "[io][log]") {
  const std::string le("\xFF\xFE" "a\0\xB5\0\n\0", 8);  // "aµ\n"
  CHECK(io::decode_text(le, "x") == "a\xC2\xB5\n");
  const std::string be("\xFE\xFF\0a\0\xB5", 6);
  CHECK(io::decode_text(be, "x") == "a\xC2\xB5");
  CHECK(io::decode_text("\xEF\xBB\xBFok", "x") == "ok");
  CHECK(io::decode_text("\xB5Nm", "x") == "\xC2\xB5Nm");  // Latin-1 fallback
  const std::string lone("\xFF\xFE" "a\0\x00\xDC", 6);  // a lone low surrogate
  CHECK_THROWS_WITH(io::decode_text(lone, "bad.txt"),
                    Contains("bad.txt") && Contains("invalid UTF-16"));
  CHECK_THROWS_AS(io::decode_text(std::string("\xFF\xFE" "a", 3), "odd.txt"), InputError);
}

TEST_CASE("RepTate files of laos-external read with their units", "[io][log]") {
  SECTION("SlugSlime: angle q [rad] and torque [N m], 1401 rows, omega 3") {
    const auto log = io::read_oscillation_log(kReptate / "SlugSlime-omega03p00-Run31.laos");
    CHECK(log.format == io::LogFormat::kRepTate);
    CHECK(log.quantity == io::LogQuantity::kAngleTorque);
    REQUIRE(log.segments.size() == 1);
    const auto& s = log.segments[0];
    REQUIRE(s.drive.size() == 1401);
    CHECK(log.omega_rad_per_s == 3.0);
    CHECK(s.line[1] == 5);  // "0.02 0.00287 3.7046e-07"
    CHECK(s.time_s[1] == 0.02);
    CHECK(s.drive[1] == 0.00287);
    CHECK(s.response[1] == 3.7046e-07);
  }
  SECTION("CPyCL: strain (-) and stress (Pa), parenthesised units") {
    const auto log = io::read_oscillation_log(kReptate / "CPyCL-omega00p30-gam03p1600.laos");
    CHECK(log.quantity == io::LogQuantity::kStrainStress);
    REQUIRE(log.segments.size() == 1);
    CHECK(log.segments[0].drive.size() == 312);
    CHECK(log.omega_rad_per_s == 0.3);
    CHECK(log.segments[0].response[0] == 8.5946);
  }
  SECTION("Giesekus: Time(s), Strain(-), tau_yx(Pa) and an extra column ignored") {
    const auto log =
        io::read_oscillation_log(kReptate / "GiesekusSimulation-omega01p00-gam05p000.laos");
    CHECK(log.quantity == io::LogQuantity::kStrainStress);
    REQUIRE(log.segments.size() == 1);
    const auto& s = log.segments[0];
    REQUIRE(s.drive.size() == 4256);
    CHECK(s.time_s.back() == 62.832);
    CHECK(s.drive.back() == -1.2246e-14);
    CHECK(s.response.back() == 0.43375);
  }
}

TEST_CASE("Format names and detection", "[io][log]") {
  for (auto f : {io::LogFormat::kAuto, io::LogFormat::kCsv, io::LogFormat::kAntonPaar,
                 io::LogFormat::kTrios, io::LogFormat::kRepTate})
    CHECK(io::log_format_from_name(io::log_format_name(f)) == f);
  CHECK_THROWS_AS(io::log_format_from_name("excel"), ConfigError);
  // Forcing the format reads the same file the same way.
  io::LogReadOptions o;
  o.format = io::LogFormat::kTrios;
  CHECK(io::read_oscillation_log(kLogs / "trios.txt", o).segments.size() == 2);
  // interval_column does not apply to vendor exports.
  o.format = io::LogFormat::kAuto;
  o.interval_column = "interval";
  CHECK_THROWS_AS(io::read_oscillation_log(kLogs / "trios.txt", o), ConfigError);
}

TEST_CASE("Bad logs are InputErrors naming file, line and column", "[io][log]") {
  testing::TempDir dir("oscillation-log");
  const io::LogReadOptions o;
  const std::string header = "time_s,angle_rad,torque_N_m\n";
  SECTION("NaN cell") {
    const auto p = dir / "nan.csv";
    testing::write_file(p, header + "0,0,0\n0.1,nan,0.5\n");
    expect_input_error(p, o, {"nan.csv:3", "angle_rad", "\"nan\""});
  }
  SECTION("missing cell (empty)") {
    const auto p = dir / "empty.csv";
    testing::write_file(p, header + "0,0,0\n0.1,0.2,\n");
    expect_input_error(p, o, {"empty.csv:3", "torque_N_m", "missing"});
  }
  SECTION("missing cell in an Anton Paar interval (short row)") {
    const auto p = dir / "short.txt";
    testing::write_file(p,
                        "Interval data:\tTime\tDeflection Angle\tTorque\r\n"
                        "\t[s]\t[rad]\t[N\xC2\xB7m]\r\n"
                        "\t0\t0\t0\r\n"
                        "\t1\t0,5\r\n");
    expect_input_error(p, o, {"short.txt:4", "Torque", "missing"});
  }
  SECTION("time that does not increase") {
    const auto p = dir / "backwards.csv";
    testing::write_file(p, header + "0,0,0\n0.2,0,0\n0.1,0,0\n");
    expect_input_error(p, o, {"backwards.csv:4", "time_s", "does not increase"});
  }
  SECTION("repeated time in a RepTate file") {
    const auto p = dir / "same.laos";
    testing::write_file(p, "omega=1;gamma=1;\n0 0 0\n1 0 0\n1 0 0\n");
    expect_input_error(p, o, {"same.laos:4", "does not increase"});
  }
  SECTION("unknown unit in a units row") {
    const auto p = dir / "unit.txt";
    testing::write_file(p,
                        "Interval data:\tTime\tDeflection Angle\tTorque\r\n"
                        "\t[s]\t[rad]\t[lbf\xC2\xB7in]\r\n"
                        "\t0\t0\t0\r\n");
    expect_input_error(p, o, {"unit.txt:2", "Torque", "lbf", "accepted", "mN"});
  }
  SECTION("unknown unit suffix and no unit at all") {
    const auto p = dir / "nounit.csv";
    testing::write_file(p, "time_s,angle,torque_N_m\n0,0,0\n");
    expect_input_error(p, o, {"nounit.csv:1", "without a unit: \"angle\" (--angle-unit"});
  }
  SECTION("a column that is not there lists the columns") {
    const auto p = dir / "cols.csv";
    testing::write_file(p, "time_s,phi_rad,torque_N_m\n0,0,0\n");
    expect_input_error(p, o, {"cols.csv:1", "angle_rad", "phi_rad"});
  }
  SECTION("TRIOS stress constant that is not a number: kept as text, fatal only when used") {
    const auto p = dir / "const.txt";
    testing::write_file(p, "[Geometry]\nStress constant\tabc Pa/N.m\n[step]\nTime\tTorque\n");
    expect_input_error(p, o, {"const.txt:4", "no deflection angle column"});
    testing::write_file(p, "[Geometry]\nStress constant\tabc Pa/N.m\n[step]\n"
                           "Time\tOscillation displacement\tTorque\ns\trad\tN.m\n0\t0\t0\n1\t1\t1\n");
    const auto log = io::read_oscillation_log(p, o);
    CHECK(std::isnan(log.stress_constant_Pa_per_N_m));
    CHECK_THAT(core::metadata_value(log.parameters, "stress_constant_Pa_per_N_m_unparsed"),
               Contains("const.txt:2") && Contains("abc"));
  }
  SECTION("Malvern: tied times that are not evenly spaced, a missing torque column") {
    const auto p = dir / "malvern.csv";
    testing::write_file(p, "Action Name;Time (action)(s);Frequency(Hz);Torque(N m);Angular displacement(rad)\n"
                           "Osc;1,000;;1,0E-005;1,0E-004\nOsc;2,000;;2,0E-005;2,0E-004\n"
                           "Osc;3,000;;3,0E-005;3,0E-004\nOsc;3,000;;4,0E-005;4,0E-004\n"
                           "Osc;3,000;;5,0E-005;5,0E-004\nOsc;10,00;;6,0E-005;6,0E-004\n"
                           "Osc;1,000;0,1000;;\n");
    expect_input_error(p, o, {"malvern.csv:", "action \"Osc\"", "not evenly spaced"});
    testing::write_file(p, "Action Name;Time (action)(s);Angular displacement(rad)\nOsc;1,000;0,1\n");
    expect_input_error(p, o, {"malvern.csv:1", "no torque column", "\"Angular displacement\""});
  }
  SECTION("invalid UTF-16") {
    const auto p = dir / "bad16.txt";
    testing::write_file(p, std::string("\xFF\xFE" "a\0\x00\xDC", 6));
    expect_input_error(p, o, {"bad16.txt", "UTF-16"});
  }
}

TEST_CASE("Generic logs: unit options, units row, no time", "[io][log]") {
  testing::TempDir dir("oscillation-log-opt");
  SECTION("unit options override, a units row is read") {
    const auto p = dir / "units.csv";
    testing::write_file(p, "t;phi;M\ns;mrad;mN m\n0;1,5;2\n1;2,5;3\n");
    io::LogReadOptions o;
    o.time_column = "t";
    o.angle_column = "phi";
    o.torque_column = "M";
    auto log = io::read_oscillation_log(p, o);
    REQUIRE(log.segments.size() == 1);
    CHECK(log.segments[0].drive[1] == Approx(2.5e-3).epsilon(1e-15));
    CHECK(log.segments[0].response[0] == Approx(2e-3).epsilon(1e-15));
    CHECK(log.segments[0].line[0] == 3);
    o.torque_unit = "\xC2\xB5N\xC2\xB7m";
    o.time_unit = "ms";
    log = io::read_oscillation_log(p, o);
    CHECK(log.segments[0].response[0] == Approx(2e-6).epsilon(1e-15));
    CHECK(log.segments[0].time_s[1] == Approx(1e-3).epsilon(1e-15));
  }
  SECTION("empty time column name: no time even when a time column exists") {
    io::LogReadOptions o;
    o.time_column = "";
    o.interval_column = "interval";
    const auto log = io::read_oscillation_log(kLogs / "generic.csv", o);
    check_waveforms(log, 2, false);
  }
}

TEST_CASE("Anton Paar: an interval without data rows is noted, not a segment", "[io][log]") {
  testing::TempDir dir("oscillation-log-ap");
  const auto p = dir / "rest.txt";
  testing::write_file(p,
                      "Test:\tLAOS\r\n"
                      "Interval data:\tTime\tDeflection Angle\tTorque\r\n"
                      "\t[s]\t[rad]\t[N\xC2\xB7m]\r\n"
                      "Interval data:\tTime\tDeflection Angle\tTorque\r\n"
                      "\t[s]\t[mrad]\t[mNm]\r\n"
                      "\t0\t1,5\t2\r\n"
                      "\t0,5\t2,5\t3\r\n");
  const auto log = io::read_oscillation_log(p);
  REQUIRE(log.segments.size() == 1);
  CHECK(log.segments[0].label == "2");
  CHECK(log.segments[0].drive[1] == Approx(2.5e-3).epsilon(1e-15));
  CHECK(log.segments[0].response[0] == Approx(2e-3).epsilon(1e-15));
  CHECK(log.segments[0].time_s[1] == 0.5);
  CHECK(log.segments[0].line == std::vector<std::size_t>{6, 7});
  CHECK_THAT(core::metadata_value(log.parameters, "empty_interval"), Contains("line 2"));
  CHECK(core::metadata_value(log.parameters, "Test") == "LAOS");
}

TEST_CASE("Anton Paar points: one closed period per point, strain/stress found without options",
          "[io][log]") {
  // make_logs.py: a French UTF-16 RheoCompass export whose "Flow Curve 1" table has one
  // row per point (no waveform) and whose "LAOS 1" interval 3 stores 3 points of 65
  // samples each (strain [1], stress [Pa]) with the point values on the first row.
  const auto log = io::read_oscillation_log(kLogs / "anton_paar_fr_points_utf16.txt");
  CHECK(log.format == io::LogFormat::kAntonPaar);
  CHECK(log.quantity == io::LogQuantity::kStrainStress);
  REQUIRE(log.segments.size() == 3);
  const double amplitudes[3] = {0.01, 0.1, 1.0};
  const double g_prime[3] = {50.0, 40.0, 20.0}, g_dprime[3] = {9.0, 10.0, 12.0};
  for (std::size_t p = 0; p < 3; ++p) {
    const auto& s = log.segments[p];
    INFO("point " << p + 1);
    CHECK(s.label == "LAOS 1 / interval 3 / point " + std::to_string(p + 1));
    CHECK(s.closed_cycle);
    REQUIRE(s.drive.size() == 65);
    CHECK(s.time_s.empty());  // one period: no time needed
    CHECK(s.drive.back() == s.drive.front());
    const double amp = *std::max_element(s.drive.begin(), s.drive.end());
    CHECK(amp == Approx(amplitudes[p]).epsilon(0.01));  // samples miss the crest by < 1 %
    CHECK(s.instrument_frequency_Hz == Approx(0.3));
    // The file's instrument moduli are 1.003 G' and 0.997 G'' (make_logs.py).
    CHECK(s.instrument_G_prime_Pa == Approx(1.003 * g_prime[p]).epsilon(kRoundingRel));
    CHECK(s.instrument_G_dprime_Pa == Approx(0.997 * g_dprime[p]).epsilon(kRoundingRel));
    CHECK(s.instrument_torque_N_m > 0);
  }
  REQUIRE(log.skipped.size() == 1);
  CHECK_THAT(log.skipped[0], Contains("Flow Curve 1 / interval 1 (line 8): no raw waveform"));
}

TEST_CASE("Anton Paar points: summary-only exports are refused naming what they hold", "[io][log]") {
  shearzone::testing::TempDir dir("ap-summary");
  const auto path = dir / "summary.txt";
  shearzone::testing::write_file(
      path,
      "Result:\tAmplitude Sweep 1\n\nInterval and data points:\t1\t2\n"
      "Interval data:\tPoint No.\tTime\tStrain\tStorage Modulus\tLoss Modulus\tTorque\n"
      "\t\t[s]\t[%]\t[Pa]\t[Pa]\t[mN\xC2\xB7m]\n"
      "\t1\t10\t1\t100\t10\t0,1\n\t2\t20\t2\t90\t12\t0,2\n"
      "Result:\tFlow Curve 1\n\nInterval data:\tPoint No.\tTime\tShear Rate\tShear Stress\tViscosity\n"
      "\t\t[s]\t[1/s]\t[Pa]\t[Pa\xC2\xB7s]\n\t1\t1\t1\t5\t5\n");
  try {
    io::read_oscillation_log(path);
    FAIL("expected an InputError");
  } catch (const InputError& e) {
    const std::string m = e.what();
    CHECK_THAT(m, Contains("no raw waveform in 2 tables"));
    CHECK_THAT(m, Contains("Amplitude Sweep 1 / interval 1 (line 4)"));
    CHECK_THAT(m, Contains("\"Storage Modulus\""));  // the columns found
    CHECK(m.find('\n') == std::string::npos);
  }
}

TEST_CASE("Malvern rSpace: actions, summary rows skipped, tied 4-digit times rebuilt", "[io][log]") {
  // make_logs.py malvern(): a pre-shear (no frequency), an amplitude table (summary rows
  // only) and one oscillation action of 1440 raw samples at dt = 0.078125 s whose times,
  // printed with 4 significant digits, tie above 100 s; 5 summary rows follow it.
  const auto log = io::read_oscillation_log(kLogs / "malvern_rspace.csv");
  CHECK(log.format == io::LogFormat::kMalvern);
  REQUIRE(log.segments.size() == 1);
  const auto& s = log.segments[0];
  CHECK(s.label == "Oscillation Single Frequency");
  REQUIRE(s.time_s.size() == 1440);
  // Rebuilt t_k = (k + 1) dt; the fit to printed times leaves < 1e-5 s (1e-4 of dt).
  constexpr double kRebuiltTime = 1e-5;
  for (std::size_t k = 0; k < s.time_s.size(); ++k)
    REQUIRE(s.time_s[k] == Approx(0.078125 * static_cast<double>(k + 1)).margin(kRebuiltTime));
  CHECK_THAT(core::metadata_value(log.parameters, "time_rebuilt"), Contains("Oscillation Single Frequency"));
  CHECK(s.instrument_frequency_Hz == Approx(0.04));
  CHECK(s.instrument_G_prime_Pa == Approx(60.6));
  REQUIRE(log.skipped.size() == 2);
  CHECK_THAT(log.skipped[0], Contains("Pre Shear (line 2): not an oscillation"));
  CHECK_THAT(log.skipped[1], Contains("Oscillation Amplitude Table (line 22): no raw waveform"));
}
