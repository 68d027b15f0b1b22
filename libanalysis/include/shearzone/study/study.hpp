// shearzone/study/study.hpp: a study file (TOML) -> the plan of a Snakemake workflow.
//
// A study is a lab campaign (clips and torque logs tagged with N, phi0, f) and/or a
// simulation grid (N x l_max x theta_max x fill seeds x phi0 from a cup scene with
// [protocol]). load_study() reads and checks the whole file before any job exists:
// every key known, every clip and log present, every tag pattern valid and matching,
// the cup scene and each generated group scene loadable. write_study_plan() writes the
// workflow's config (OUT/study.json) and the generated scenes (OUT/sim/<group>/scene.toml,
// rewritten only when their text changes, so a rerun schedules nothing). The workflow
// itself (scripts/study/Snakefile) runs the existing `shearzone` subcommands; see
// docs/study.md for the keys and the outputs.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "shearzone/sim/scene.hpp"

namespace shearzone::study {

/// Extra options of one stage, as command-line words ("--vc", "5e-4", ...).
using StageArgs = std::vector<std::string>;

struct StudyClip {
  std::string name;               ///< output folder lab/clips/<name>
  std::filesystem::path video;    ///< absolute
  int N = 0;
  double phi0_rad = 0.0;
  double f_Hz = 0.0;              ///< 0: not given (piv then takes no --f-hz)
  StageArgs piv;                  ///< this clip's own piv options (after the lab's)
  StageArgs profile;              ///< this clip's own profile options (its geometry: radii, scale)
};

struct StudyLog {
  std::string name;               ///< output folder lab/logs/<name>
  std::filesystem::path file;     ///< absolute
  int N = 0;
};

/// One pre-shear: a point of the simulation grid.
struct StudySimGroup {
  std::string name;               ///< N4_l0.0004_a60_s1
  std::string dataset;            ///< sim_l0.0004_a60: the groups whose r_c(phi0) are fitted together
  int N = 1;
  double l_max_m = 0.0;
  double max_angle_deg = 180.0;
  long long seed = 1;
  sim::SceneSpec scene;           ///< the generated scene: the cup scene with this point's values
};

struct StudySlurm {
  std::string partition;          ///< empty: the cluster's default
  long long time_min = 60;
  long long mem_mb = 1000;
  struct Rule {
    std::string partition;
    long long time_min = 0, mem_mb = 0;  ///< 0: the default
  };
  std::map<std::string, Rule> rules;
};

struct Study {
  std::filesystem::path file;
  // lab
  std::vector<StudyClip> clips;
  std::vector<StudyLog> logs;
  StageArgs lab_piv, lab_profile, lab_width, lab_laos;
  // simulation
  std::filesystem::path scene;    ///< the cup scene (absolute); empty: no simulation part
  std::vector<StudySimGroup> groups;
  std::vector<double> sim_phi0_rad;  ///< one branch per amplitude and group
  double sim_f_Hz = 0.0, sim_cycles = 0.0;
  int sim_threads = 1;
  StageArgs sim_render, sim_piv, sim_profile, sim_width, sim_laos;
  // fits
  StageArgs fit_erf, fit_power, collapse_erf;
  /// `[fits] weights = "intervals"`: the r_c(phi0) fits and the collapse weigh each r_c by
  /// its interval (`--sigma rc_se_m`); the default "none" fits them unweighted (the
  /// intervals hold sampling noise only, not the PIV's bias: docs/study.md).
  bool fit_weigh_intervals = false;
  StudySlurm slurm;
};

/// Stages whose options a study file may set, as `[lab.<stage>]`, `[sim.<stage>]` or
/// `[fits.<stage>]` tables; `known_option(stage, key)` says whether `shearzone <stage>`
/// has the long option --key ("render" is `sim render`, "erf"/"power" are `fit erf|power`,
/// "collapse" is `collapse erf`).
using KnownOption = std::function<bool(const std::string& stage, const std::string& key)>;

/// The long options of `shearzone <stage>` (for a "did you mean" when a key is unknown).
using OptionNames = std::function<std::vector<std::string>(const std::string& stage)>;

/// Checks a stage's options as `shearzone <stage>` will take them (its own parsing and
/// validation, no file read): throws Error with the subcommand's message.
using CheckStage = std::function<void(const std::string& stage, const std::vector<std::string>& args)>;

/// Reads and checks a study file. ConfigError / InputError name the file, line and key;
/// an unknown stage option is refused with the nearest of `option_names` (when given),
/// and every stage table's options are checked by `check_stage` (when given) before any
/// job exists.
Study load_study(const std::filesystem::path& file, const KnownOption& known_option,
                 const OptionNames& option_names = {}, const CheckStage& check_stage = {});

/// The rules the [slurm] tables may name.
const std::vector<std::string>& study_rules();

/// Writes OUT/study.json (the workflow's config: every job's inputs and options) and the
/// generated scenes; `shearzone` and `python` are the programs the jobs call, `scripts`
/// the folder of the figure scripts.
void write_study_plan(const Study& study, const std::filesystem::path& out_dir,
                      const std::filesystem::path& shearzone, const std::filesystem::path& python,
                      const std::filesystem::path& scripts);

/// Branch folder name of an amplitude (sim::SceneProtocol::branch_folder).
std::string study_branch_name(double phi0_rad);

}  // namespace shearzone::study
