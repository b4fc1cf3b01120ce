#pragma once

// What the stages share to decide whether their outputs are up to date: content hashes of
// input files, the fingerprint recorded in a stage's summary.json, and the size and content hash
// of every output it recorded there ("output_files"), checked before "up to date" is believed: a
// truncated, edited or deleted output is redone, and what depends on it follows (its inputs'
// hashes change).

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace crop4d::workspace {

// FNV-1a hash of a file's bytes, as decimal text ("" when the file cannot be read).
std::string FileHash(const std::filesystem::path& path);

// The "fingerprint" of a stage's summary.json, or "" when the file is missing or unreadable.
std::string SummaryFingerprint(const std::filesystem::path& summary_json);

// Records the outputs of a unit in its summary as "output_files": for each file, named relative
// to `folder` (the summary's folder), {"bytes": size, "hash": FileHash}. Throws InputError when a
// file cannot be read (the stage has just written it).
void RecordOutputs(nlohmann::json* summary, const std::filesystem::path& folder,
                   const std::vector<std::string>& relative_paths);

// Every regular file below `folder` except `summary_name`, as paths relative to `folder` in
// sorted order: the outputs of a stage that owns the folder.
std::vector<std::string> FilesBelow(const std::filesystem::path& folder,
                                    const std::string& summary_name = "summary.json");

// Whether the summary records `fingerprint` and every output it records is still there with
// its size and hash. A summary without "output_files" (from an older crop4d) is not believed. When
// not, `why` (if given) says what differs, for the log.
bool SummaryUpToDate(const std::filesystem::path& summary_json, const std::string& fingerprint,
                     std::string* why = nullptr);

// Whether every output that the parsed `summary` (in `folder`) records is intact (see above).
bool OutputsIntact(const std::filesystem::path& folder, const nlohmann::json& summary,
                   std::string* why = nullptr);

}  // namespace crop4d::workspace
