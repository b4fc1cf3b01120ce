#pragma once

// The configuration of `crop4d run` (docs/run.md): one YAML file with a section per stage. Every
// key is optional; a missing key keeps the stage's default, an unknown key or a bad value is an
// error naming the file, line and key. The effective configuration (defaults filled in) is
// written to WS/crop4d.yaml by every run, in the same format, so it can be edited and passed
// back with --config.
//
//   threads: 0                 # worker threads for every stage (0: all cores)
//   stages: {densify: true, eval: auto, report: true}
//   slam:      {sensors: auto, neighbors: 4, min_track_length: 7, ...}
//   associate: {method: robust, session_gap: 1, ...}
//   fuse:      {matches_per_image_pair: 30, max_iterations: 30, linear_solver: iterative}
//   densify:   {cell_m: 0.005, max_views: 7, min_score: 0.5, margin_m: 0.6, ...}
//   analyze:   {sites: "", cloud: auto, greenness: exg, canopy_top: plant-tops, ...}
//   eval:      {canopy_max_error_m: 0.04, depth_cache: ""}
//
// Which options matter to a stage is recorded by the stage itself in its fingerprint: changing
// a key reruns that stage and what depends on its outputs, nothing else.

#include <string>
#include <vector>

#include "crop4d/eval/workspace_eval.h"
#include "crop4d/pipeline/analyze_stage.h"
#include "crop4d/pipeline/associate_stage.h"
#include "crop4d/pipeline/densify_stage.h"
#include "crop4d/pipeline/fuse_stage.h"
#include "crop4d/pipeline/slam_stage.h"

namespace crop4d::pipeline {

struct RunConfig {
  static constexpr int kMaxThreads = 1024;
  // Worker threads for every stage (0: all cores; at most kMaxThreads).
  int threads = 0;
  // Dense clouds (`crop4d densify`) before the analysis; without them the analysis uses the
  // fused sparse clouds (much less accurate canopy heights).
  bool densify = true;
  // The evaluation against ground truth: "auto" (when FIELD/ground_truth/ exists), "always"
  // (an error without it), "never".
  std::string eval = "auto";
  // WS/report.html at the end of the run.
  bool report = true;

  SlamStageOptions slam;
  AssociateStageOptions associate;
  FuseStageOptions fuse;
  DensifyStageOptions densify_options;
  AnalyzeStageOptions analyze;
  eval::WorkspaceEvalOptions eval_options;

  // Valid values in every section; `message` says what is wrong.
  bool Check(std::string* message) const;
};

// A key of the file and the option it sets: the option's dotted path in RunConfig's field lists
// (stage_option_fields.h), e.g. {"slam", "neighbors", "slam.front_end.num_neighbors"}.
struct RunConfigKey {
  std::string section;  // "" for the top level
  std::string name;
  std::string field;
};
std::vector<RunConfigKey> RunConfigKeys();

// Reads a configuration file over the defaults. Throws InputError naming the file, line and key
// for a syntax error, an unknown key or a bad value.
RunConfig ReadRunConfig(const std::string& path);
// The same from text (tests); `name` stands for the file in messages.
RunConfig ParseRunConfig(const std::string& name, const std::string& text);

// The configuration as YAML with a comment for every key (ReadRunConfig reads it back to the
// same configuration).
std::string FormatRunConfig(const RunConfig& config);

}  // namespace crop4d::pipeline
