#pragma once

// WS/associations/<method>/<a>__<b>.json: the summary the associate stage writes beside each
// association file (association/association_file.h): the pass pair, the matcher's counts, the
// pre-alignment, the options, the fingerprint and the recorded outputs (stage_files.h). Schema 1
// carries no "schema" field (workspace/json_file.h); a summary of another schema, one that is not
// JSON or lacks a field of AssociationSummary throws InputError naming the file and saying to
// rerun `crop4d associate --force`.

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "crop4d/association/association_file.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::workspace {

// Bumped whenever a field that a reader relies on changes its meaning or goes (a version above 1
// is stamped into the file).
inline constexpr int kAssociationSummarySchema = 1;

// What the association of one pass pair found and cost: association::AssociationStats summed
// over its image pairs, and the pre-alignment. The associate stage's report of a pair carries
// the same counts (pipeline/associate_stage.h).
struct AssociationCounts {
  int image_pairs = 0;
  std::int64_t landmarks = 0;
  std::int64_t projected = 0;
  // Surface points among the landmarks (association/surface_points.h).
  std::int64_t surface_points = 0;
  std::int64_t candidates = 0;
  std::int64_t warped = 0;
  // Keypoints of pass b described upright for the comparison with warped ones.
  std::int64_t upright_b = 0;
  std::int64_t putative = 0;
  std::int64_t matches = 0;
  // The pre-alignment: whether it ran and succeeded, its inliers and how far it moved pass b.
  bool prealigned = false;
  int alignment_inliers = 0;
  double alignment_shift_m = 0;
  double seconds = 0;
};

struct AssociationSummary : AssociationCounts {
  association::PassRef a, b;  // a: the pass whose landmarks were projected; b: the one searched
  std::string type;           // the pair's type (pipeline::ToString(PassPairType))
  std::string method;         // "robust" or "naive"
  std::string fingerprint;    // of the inputs and options that gave the association file
  nlohmann::json json;        // the whole summary (options, outputs)
};

// The summary beside the association file `association_file` (the same name, ".json").
std::filesystem::path AssociationSummaryPath(const std::filesystem::path& association_file);

// Every association summary of the workspace: the "*.json" files of each method's folder (and,
// from workspaces written before the methods had folders, of the associations folder itself),
// folders and files in name order (a "summary.json" there is not a pair's).
std::vector<std::filesystem::path> AssociationSummaries(const Layout& layout);

// Writes `summary` atomically (2-space indented, final newline), as the associate stage does.
void WriteAssociationSummary(const std::string& path, const nlohmann::json& summary);
AssociationSummary ReadAssociationSummary(const std::string& path);

}  // namespace crop4d::workspace
