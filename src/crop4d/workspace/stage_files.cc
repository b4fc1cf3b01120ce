#include "crop4d/workspace/stage_files.h"

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"

namespace crop4d::workspace {

std::string FileHash(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  Fnv1aHasher hasher;
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    hasher.AddBytes(buffer.data(), static_cast<std::size_t>(in.gcount()));
  }
  return std::to_string(hasher.hash());
}

std::string SummaryFingerprint(const std::filesystem::path& summary_json) {
  std::ifstream in(summary_json);
  if (!in) return "";
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    return j.is_object() ? j.value("fingerprint", std::string()) : std::string();
  } catch (const nlohmann::json::exception&) {
    return "";
  }
}

namespace {
constexpr const char* kOutputFiles = "output_files";
}  // namespace

void RecordOutputs(nlohmann::json* summary, const std::filesystem::path& folder,
                   const std::vector<std::string>& relative_paths) {
  nlohmann::json outputs = nlohmann::json::object();
  for (const std::string& name : relative_paths) {
    const std::filesystem::path path = folder / name;
    std::error_code ec;
    const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
    const std::string hash = ec ? "" : FileHash(path);
    if (hash.empty()) throw InputError(path.string(), 0, "cannot read an output just written");
    outputs[name] = {{"bytes", bytes}, {"hash", hash}};
  }
  (*summary)[kOutputFiles] = std::move(outputs);
}

std::vector<std::string> FilesBelow(const std::filesystem::path& folder,
                                    const std::string& summary_name) {
  std::vector<std::string> out;
  std::error_code ec;
  for (std::filesystem::recursive_directory_iterator it(folder, ec), end; !ec && it != end;
       it.increment(ec)) {
    if (!it->is_regular_file()) continue;
    const std::string name = std::filesystem::relative(it->path(), folder).generic_string();
    if (name != summary_name) out.push_back(name);
  }
  std::sort(out.begin(), out.end());
  return out;
}

bool OutputsIntact(const std::filesystem::path& folder, const nlohmann::json& summary,
                   std::string* why) {
  auto fail = [why](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  const auto outputs = summary.find(kOutputFiles);
  if (outputs == summary.end() || !outputs->is_object()) {
    return fail("the summary records no outputs");
  }
  for (const auto& [name, record] : outputs->items()) {
    const std::filesystem::path path = folder / name;
    std::error_code ec;
    const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
    if (ec) return fail(name + " is missing");
    if (!record.is_object() || record.value("bytes", std::uintmax_t{0}) != bytes) {
      return fail(name + " changed size since it was written");
    }
    if (record.value("hash", std::string()) != FileHash(path)) {
      return fail(name + " changed since it was written");
    }
  }
  return true;
}

bool SummaryUpToDate(const std::filesystem::path& summary_json, const std::string& fingerprint,
                     std::string* why) {
  std::ifstream in(summary_json);
  if (!in) {
    if (why != nullptr) *why = "no summary";
    return false;
  }
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    if (!j.is_object() || j.value("fingerprint", std::string()) != fingerprint) {
      if (why != nullptr) *why = "inputs or options changed";
      return false;
    }
    return OutputsIntact(summary_json.parent_path(), j, why);
  } catch (const nlohmann::json::exception&) {
    if (why != nullptr) *why = "damaged summary";
    return false;
  }
}

}  // namespace crop4d::workspace
