// shearzone/pipeline/synth_job.hpp: render synthetic inputs to an output folder.
//
// What `shearzone synth particles|beads` writes into DIR:
//   frames = 2, format png|tiff : A.<ext>, B.<ext>
//   frames = K, format png|tiff : frame_000000.<ext> ... frame_<K-1>.<ext>
//   format mp4|avi              : video.<ext> (8-bit only)
//   always                      : truth.csv  (x_px,y_px,u_px,v_px on a grid)
//                                 frames.csv (frame,t_s,phi_rad,disp_scale)
// truth.csv holds the exact displacement from frame A to frame B for a pair; for a
// sequence it holds the displacement per frame at disp_scale = 1, and the pair
// (k, k+1) moves by disp_scale_k times that (frames.csv, row k).
// Every file appears together or not at all (io::AtomicOutputSet); existing files
// are refused unless force is set.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"
#include "shearzone/synth/generator.hpp"

namespace shearzone::pipeline {

struct SynthJobOptions {
  synth::SynthOptions synth;
  std::filesystem::path out_dir;    ///< output folder (created if missing)
  std::string format = "png";       ///< png | tiff | mp4 | avi
  std::string video_codec = "mp4v"; ///< FourCC for mp4 (mp4v, avc1); avi uses MJPG
  double truth_spacing_px = 16.0;   ///< grid spacing of truth.csv, px (>= 1)
  bool force = false;               ///< replace existing files

  /// Throws ConfigError on a bad combination (e.g. 16-bit video).
  void validate() const;
};

struct SynthJobSummary {
  std::vector<std::filesystem::path> files;  ///< everything written, in order
  std::size_t tracers = 0;                   ///< particles or beads placed
  int frames = 0;
  core::Metadata resolved_options;           ///< what the file headers record
};

/// Renders and writes everything; `header` (tool, version, command line,
/// conventions) opens every CSV. Nothing is written if anything fails.
SynthJobSummary run_synth_job(const SynthJobOptions& options, const core::Metadata& header,
                              const core::ProgressCallback& progress = {});

/// The displacement field named on the command line ("uniform", "rotation",
/// "shear-zone"); ConfigError lists the valid names.
synth::FieldKind synth_field_kind(const std::string& name);

}  // namespace shearzone::pipeline
