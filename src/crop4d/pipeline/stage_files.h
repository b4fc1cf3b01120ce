#pragma once

// What the stages share to decide whether their outputs are up to date: content hashes of
// input files and the fingerprint recorded in a stage's summary.json.

#include <filesystem>
#include <string>

namespace crop4d::pipeline {

// FNV-1a hash of a file's bytes, as decimal text ("" when the file cannot be read).
std::string FileHash(const std::filesystem::path& path);

// The "fingerprint" of a stage's summary.json, or "" when the file is missing or unreadable.
std::string SummaryFingerprint(const std::filesystem::path& summary_json);

}  // namespace crop4d::pipeline
