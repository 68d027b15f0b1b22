// The study file -> the workflow's plan (study/study.hpp). The workflow itself runs in
// tests/study (run_local.sh, run_slurm.sh); here: tags, the grid, the generated scenes.
#include <catch2/catch.hpp>

#include <fstream>
#include <tuple>

#include "shearzone/core/error.hpp"
#include "shearzone/study/study.hpp"
#include "shearzone/sim/scene.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using shearzone::testing::TempDir;
using shearzone::testing::read_file;
using shearzone::testing::write_file;

namespace {
const auto any_option = [](const std::string&, const std::string&) { return true; };
}

TEST_CASE("clip tags come from the file name's pattern, the table fills the rest", "[study]") {
  TempDir t("study_tags");
  for (const char* f : {"N9_phi0.25.mp4", "N45_phi1e-1.mp4", "notes.txt"}) write_file(t / f, "x");
  write_file(t / "study.toml",
             "[lab]\nf_Hz = 0.1\n[lab.clip_glob]\nfiles = \"*.mp4\"\npattern = \"N{N}_phi{phi0_rad}\"\n"
             "[lab.clips.extra]\nvideo = \"notes.txt\"\nN = 1\nphi0_rad = 0.5\nf_Hz = 0.2\n"
             "[lab.clips.extra.piv]\ncentre = [10, 20]\n[lab.clips.extra.profile]\nradii-px = [5, 9]\n");
  const study::Study s = study::load_study(t / "study.toml", any_option);
  REQUIRE(s.clips.size() == 3);
  // named tables first (sorted), then the glob's files (sorted)
  CHECK(s.clips[0].name == "extra");
  CHECK(s.clips[0].f_Hz == 0.2);
  CHECK(s.clips[0].piv == study::StageArgs{"--centre", "10,20"});
  CHECK(s.clips[0].profile == study::StageArgs{"--radii-px", "5,9"});
  CHECK(s.clips[1].name == "N45_phi1e-1");
  CHECK(s.clips[1].N == 45);
  CHECK(s.clips[1].phi0_rad == 0.1);
  CHECK(s.clips[2].name == "N9_phi0.25");
  CHECK(s.clips[2].N == 9);
  CHECK(s.clips[2].phi0_rad == 0.25);
  CHECK(s.clips[2].f_Hz == 0.1);  // the lab's default frequency
}

TEST_CASE("a tag that is not a chain length is refused with its line", "[study]") {
  TempDir t("study_badtag");
  write_file(t / "N2.5_phi0.3.mp4", "x");
  write_file(t / "study.toml", "[lab.clip_glob]\nfiles = \"*.mp4\"\npattern = \"N{N}_phi{phi0_rad}\"\n");
  CHECK_THROWS_WITH(study::load_study(t / "study.toml", any_option),
                    Catch::Contains("study.toml:3: key \"lab.clip_glob.pattern\"") && Catch::Contains("N = 2.5"));
}

// Issue 34: a tag out of the range of numbers was an internal error (exit 4).
TEST_CASE("a tag beyond the range of numbers is refused with its file", "[study]") {
  for (const char* f : {"N1_phi1e999.mp4", "N1_phi1e-999.mp4", "N1e999_phi0.3.mp4"}) {
    TempDir t("study_tag_range");
    write_file(t / f, "x");
    write_file(t / "study.toml", "[lab.clip_glob]\nfiles = \"*.mp4\"\npattern = \"N{N}_phi{phi0_rad}\"\n");
    INFO(f);
    CHECK_THROWS_WITH(study::load_study(t / "study.toml", any_option),
                      Catch::Contains("study.toml:3: key \"lab.clip_glob.pattern\"") &&
                          Catch::Contains("is out of the range of numbers"));
  }
}

// Issue 34: several wildcards on a long stem took 17 s to over 60 s (a backtracking
// regex). The matcher is polynomial: this pattern and stem take milliseconds.
TEST_CASE("patterns with several wildcards match long stems, numbers longest first", "[study]") {
  TempDir t("study_wildcards");
  const std::string stem = "run_" + std::string(50, 'a') + "_N12_x_phi0.25_" + std::string(20, 'b');
  write_file(t / (stem + ".mp4"), "x");
  write_file(t / "N7_phi2.5e-1_take3.mp4", "x");
  write_file(t / "study.toml",
             "[lab.clip_glob]\nfiles = \"*.mp4\"\npattern = \"*N{N}*phi{phi0_rad}*\"\n");
  const study::Study s = study::load_study(t / "study.toml", any_option);
  REQUIRE(s.clips.size() == 2);
  CHECK(s.clips[0].N == 7);
  CHECK(s.clips[0].phi0_rad == 0.25);
  CHECK(s.clips[1].N == 12);
  CHECK(s.clips[1].phi0_rad == 0.25);
  // A stem that does not match, many wildcards: refused, not stuck.
  TempDir u("study_wildcards_miss");
  write_file(u / (std::string(240, 'a') + ".mp4"), "x");
  write_file(u / "study.toml",
             "[lab.clip_glob]\nfiles = \"*.mp4\"\npattern = \"*a*a*a*a*a*a*N{N}*b\"\n");
  CHECK_THROWS_WITH(study::load_study(u / "study.toml", any_option), Catch::Contains("does not match the file name"));
}

// Issue 34: duplicates weighed a branch 2-4x in the fits; a huge grid wrote 58 000 scenes.
TEST_CASE("a grid value given twice, or a grid beyond 1000 points, is refused", "[study]") {
  const std::string cup = read_file(std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "vane_cup.toml");
  const std::vector<std::pair<std::string, std::string>> cases{
      {"N = [1, 1]", "sim.N\": 1 appears twice"},
      {"seeds = [3, 3]", "sim.seeds\": 3 appears twice"},
      {"l_max_m = [0.0004, 4e-4]", "sim.l_max_m\": 4e-04 appears twice"},
      {"max_angle_deg = [60, 60.0]", "sim.max_angle_deg\": 60 appears twice"},
      {"seeds = [" + [] {
         std::string v;
         for (int i = 0; i < 1001; ++i) v += (i ? ", " : "") + std::to_string(i);
         return v;
       }() + "]",
       "a grid of 1001 points"}};
  for (const auto& [line, message] : cases) {
    TempDir t("study_grid_dup");
    write_file(t / "cup.toml", cup);
    write_file(t / "study.toml", "[sim]\nscene = \"cup.toml\"\n" + line + "\n");
    INFO(line);
    CHECK_THROWS_WITH(study::load_study(t / "study.toml", any_option), Catch::Contains(message));
    CHECK_FALSE(std::filesystem::exists(t / "out"));
  }
}

TEST_CASE("every branch's drive is checked as sim --phi0/--f-hz/--cycles checks it, before any job",
          "[study]") {
  const std::string cup = read_file(std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "vane_cup.toml");
  std::string quarter = cup;  // a periodic quarter of the cup: the blade stays within pi/4
  quarter.replace(quarter.find("[cylinder]\n"), 11, "[cylinder]\nsectors = 4\n");
  const std::vector<std::tuple<std::string, std::string, std::string>> cases{
      {cup, "f_Hz = 100", "study.toml:3: key \"sim.f_Hz\": the branch at phi0 = 0.02 rad: --f-hz 100: 10 time steps"},
      {cup, "f_Hz = 1e-9", "study.toml:3: key \"sim.f_Hz\": the branch at phi0 = 0.02 rad: --cycles 2 at --f-hz 1e-09"},
      {cup, "cycles = 1e6", "study.toml:3: key \"sim.cycles\": the branch at phi0 = 0.02 rad: --cycles 1e+06"},
      {quarter, "phi0_rad = [0.3, 0.9]",
       "study.toml:3: key \"sim.phi0_rad\": the branch at phi0 = 0.9 rad: --phi0 0.9 rad: the blade would leave"}};
  for (const auto& [scene, line, message] : cases) {
    TempDir t("study_branch_drive");
    write_file(t / "cup.toml", scene);
    write_file(t / "study.toml", "[sim]\nscene = \"cup.toml\"\n" + line + "\n");
    INFO(line);
    CHECK_THROWS_WITH(study::load_study(t / "study.toml", any_option), Catch::Contains(message));
  }
}

TEST_CASE("the simulation grid makes one scene per point, each loadable", "[study]") {
  TempDir t("study_grid");
  const std::string cup = read_file(std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "vane_cup.toml");
  write_file(t / "cup.toml", cup);
  write_file(t / "study.toml",
             "[sim]\nscene = \"cup.toml\"\nN = [1, 4]\nl_max_m = [0.0004]\nmax_angle_deg = [60, 120]\n"
             "seeds = [3]\nbeads = 150\nphi0_rad = [0.1]\nthreads = 2\n");
  const study::Study s = study::load_study(t / "study.toml", any_option);
  REQUIRE(s.groups.size() == 4);
  CHECK(s.groups[0].name == "N1_l0.0004_a60_s3");
  CHECK(s.groups[0].dataset == "sim_l0.0004_a60");
  CHECK(s.groups[3].name == "N4_l0.0004_a120_s3");
  CHECK(s.sim_phi0_rad == std::vector<double>{0.1});
  CHECK(s.sim_f_Hz == 0.5);   // the scene's protocol
  CHECK(s.sim_cycles == 2.0);
  study::write_study_plan(s, t / "out", "/bin/shearzone", "/usr/bin/python3", "/scripts");
  const auto scene = t / "out" / "sim" / "N4_l0.0004_a120_s3" / "scene.toml";
  const sim::LoadedScene loaded = sim::load_scene(scene, true);
  CHECK(loaded.beads_per_chain == 4);
  REQUIRE(loaded.protocol);
  const std::string text = read_file(scene);
  CHECK_THAT(text, Catch::Contains("count = 37"));  // 150 beads in chains of 4
  CHECK_THAT(text, Catch::Contains("seed = 3"));
  CHECK_THAT(text, Catch::Contains("max_angle_deg = 120"));
  CHECK_THAT(text, Catch::Contains("threads = 2"));
  // a second plan leaves an unchanged scene's time stamp alone (a rerun schedules nothing)
  const auto before = std::filesystem::last_write_time(scene);
  study::write_study_plan(s, t / "out", "/bin/shearzone", "/usr/bin/python3", "/scripts");
  CHECK(std::filesystem::last_write_time(scene) == before);
  const std::string plan = read_file(t / "out" / "study.json");
  CHECK_THAT(plan, Catch::Contains("\"sim/N4_l0.0004_a120_s3/phi0_0.100/width.csv\""));
  CHECK_THAT(plan, Catch::Contains("\"sim_l0.0004_a60\": {\"widths\""));
}

TEST_CASE("the r_c fits are unweighted unless [fits] weights = \"intervals\"", "[study]") {
  // The widths' intervals hold sampling noise only; weighing by them let the narrowest
  // (small amplitudes) pin the erf curve on the demo study (docs/study.md), so the fits
  // of r_c(phi0) and the collapse weigh each point alike unless the study file asks.
  TempDir t("study_weights");
  write_file(t / "N4_phi0.3.mp4", "x");
  const std::string clips = "[lab.clip_glob]\nfiles = \"*.mp4\"\npattern = \"N{N}_phi{phi0_rad}\"\n";
  write_file(t / "study.toml", clips);
  study::Study s = study::load_study(t / "study.toml", any_option);
  CHECK_FALSE(s.fit_weigh_intervals);
  study::write_study_plan(s, t / "out", "/bin/shearzone", "/usr/bin/python3", "/scripts");
  CHECK_THAT(read_file(t / "out" / "study.json"), Catch::Contains("\"rc_sigma\": []"));
  write_file(t / "study.toml", clips + "[fits]\nweights = \"intervals\"\n");
  s = study::load_study(t / "study.toml", any_option);
  CHECK(s.fit_weigh_intervals);
  study::write_study_plan(s, t / "out", "/bin/shearzone", "/usr/bin/python3", "/scripts");
  CHECK_THAT(read_file(t / "out" / "study.json"), Catch::Contains("\"rc_sigma\": [\"--sigma\", \"rc_se_m\"]"));
  write_file(t / "study.toml", clips + "[fits]\nweights = \"none\"\n");
  CHECK_FALSE(study::load_study(t / "study.toml", any_option).fit_weigh_intervals);
}
