#include "crop4d/workspace/association_summary.h"

#include <algorithm>

#include "crop4d/workspace/json_file.h"

namespace crop4d::workspace {

namespace fs = std::filesystem;
using json = nlohmann::json;

fs::path AssociationSummaryPath(const fs::path& association_file) {
  return fs::path(association_file).replace_extension(".json");
}

namespace {

// The entries of `dir` that are folders (`folders`) or files, in name order.
std::vector<fs::path> Entries(const fs::path& dir, bool folders) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (folders ? it->is_directory(type_ec) : it->is_regular_file(type_ec)) {
      out.push_back(it->path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

association::PassRef PassRefFrom(const json& j) {
  return {j.at("session").get<std::string>(), j.at("pass").get<std::string>()};
}

}  // namespace

std::vector<fs::path> AssociationSummaries(const Layout& layout) {
  std::vector<fs::path> files = Entries(layout.AssociationsRoot(), false);
  for (const fs::path& method : Entries(layout.AssociationsRoot(), true)) {
    for (const fs::path& f : Entries(method, false)) files.push_back(f);
  }
  files.erase(std::remove_if(files.begin(), files.end(),
                             [](const fs::path& f) {
                               return f.extension() != ".json" || f.filename() == "summary.json";
                             }),
              files.end());
  return files;
}

void WriteAssociationSummary(const std::string& path, const json& summary) {
  WriteJsonOfSchema(path, summary, kAssociationSummarySchema);
}

AssociationSummary ReadAssociationSummary(const std::string& path) {
  const std::string rerun = "crop4d associate";
  AssociationSummary s;
  s.json = ReadJsonOfSchema(path, kAssociationSummarySchema, rerun);
  ReadFields(path, rerun, [&] {
    const json& j = s.json;
    s.a = PassRefFrom(j.at("a"));
    s.b = PassRefFrom(j.at("b"));
    s.type = j.at("type").get<std::string>();
    s.method = j.at("method").get<std::string>();
    s.fingerprint = j.at("fingerprint").get<std::string>();
    s.image_pairs = j.at("image_pairs").get<int>();
    s.landmarks = j.at("landmarks").get<std::int64_t>();
    s.surface_points = j.at("surface_points").get<std::int64_t>();
    s.projected = j.at("projected").get<std::int64_t>();
    s.candidates = j.at("candidates").get<std::int64_t>();
    s.warped = j.at("warped").get<std::int64_t>();
    s.upright_b = j.at("upright_b").get<std::int64_t>();
    s.putative = j.at("putative").get<std::int64_t>();
    s.matches = j.at("matches").get<std::int64_t>();
    s.prealigned = j.at("prealigned").get<bool>();
    s.alignment_inliers = j.at("alignment_inliers").get<int>();
    s.alignment_shift_m = j.at("alignment_shift_m").get<double>();
    s.seconds = j.at("seconds").get<double>();
  });
  return s;
}

}  // namespace crop4d::workspace
