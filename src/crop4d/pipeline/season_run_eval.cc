// The fingerprint of the evaluation's inputs (season_run_eval.h).

#include "crop4d/pipeline/season_run_eval.h"

#include <algorithm>
#include <filesystem>
#include <vector>

#include "crop4d/core/hash.h"
#include "crop4d/core/version.h"
#include "crop4d/workspace/stage_files.h"

namespace crop4d::pipeline {

namespace fs = std::filesystem;

std::string EvalInputsFingerprint(const std::string& field_folder, const workspace::Layout& layout,
                                  const RunConfig& config) {
  // The evaluation's inputs are the outputs of the other stages, and each of those records the
  // fingerprint of its own inputs: their fingerprints (not the large files) stand for them.
  Fnv1aHasher hasher;
  auto add = [&hasher](const std::string& s) {
    hasher.AddBytes(s.data(), s.size());
    hasher.AddBytes("\n", 1);
  };
  add(kVersion);
  const std::string text = FormatRunConfig(config);
  add(text.substr(text.find("\neval:")));
  for (const fs::path& path : layout.StageRecordFiles()) {
    add(fs::relative(path, layout.root()).string());
    add(workspace::SummaryFingerprint(path));
  }
  std::error_code ec;
  std::vector<std::string> truth;
  for (fs::recursive_directory_iterator it(fs::path(field_folder) / "ground_truth", ec), end;
       !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file()) truth.push_back(it->path().string());
  }
  std::sort(truth.begin(), truth.end());
  for (const std::string& path : truth) {
    add(fs::relative(path, field_folder).string());
    add(workspace::FileHash(path));
  }
  return std::to_string(hasher.hash());
}

}  // namespace crop4d::pipeline
