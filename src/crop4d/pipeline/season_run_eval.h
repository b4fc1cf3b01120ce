#pragma once

// The fingerprint of what `crop4d run`'s evaluation step (season_run.h) consumes, kept in
// WS/eval/inputs.fingerprint: the evaluation is redone only when it changes. Internal to
// season_run.cc.

#include <string>

#include "crop4d/pipeline/run_config.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline {

// A hash of crop4d's version, the `eval` section of `config`, the fingerprints of every stage
// summary (*.json) under WS/sessions, associations, fused, dense and analysis, and the content
// of every file under FIELD/ground_truth/.
std::string EvalInputsFingerprint(const std::string& field_folder, const workspace::Layout& layout,
                                  const RunConfig& config);

}  // namespace crop4d::pipeline
