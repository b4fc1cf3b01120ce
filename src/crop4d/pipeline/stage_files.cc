#include "crop4d/pipeline/stage_files.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "crop4d/core/hash.h"

namespace crop4d::pipeline {

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

}  // namespace crop4d::pipeline
