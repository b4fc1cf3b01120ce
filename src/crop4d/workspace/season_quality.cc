#include "crop4d/workspace/season_quality.h"

#include <filesystem>

#include "crop4d/workspace/json_file.h"

namespace crop4d::workspace {

using json = nlohmann::json;

namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

const char* PositioningName(Positioning p) {
  switch (p) {
    case Positioning::kRtk:
      return "rtk";
    case Positioning::kGps:
      return "gps";
    case Positioning::kNone:
      return "none";
  }
  return "none";
}

Positioning PositioningOf(const std::string& sensors) {
  if (EndsWith(sensors, "+rtk")) return Positioning::kRtk;
  if (EndsWith(sensors, "+gps")) return Positioning::kGps;
  return Positioning::kNone;
}

bool SeasonQuality::Protects(const std::string& session) const {
  if (!any_trusted) return true;
  for (const SessionGrade& g : sessions) {
    if (g.session == session) return g.trusted;
  }
  return true;
}

std::vector<const SessionGrade*> SeasonQuality::Degraded() const {
  std::vector<const SessionGrade*> out;
  for (const SessionGrade& g : sessions) {
    if (!g.trusted) out.push_back(&g);
  }
  return out;
}

json SeasonQualityToJson(const SeasonQuality& quality) {
  json sessions = json::array();
  for (const SessionGrade& g : quality.sessions) {
    sessions.push_back({{"session", g.session}, {"trusted", g.trusted}, {"reasons", g.reasons}});
  }
  return {{"standard", PositioningName(quality.standard)},
          {"any_trusted", quality.any_trusted},
          {"sessions", sessions}};
}

void WriteSeasonQuality(const std::string& path, const SeasonQuality& quality) {
  WriteJsonOfSchema(path, SeasonQualityToJson(quality), kSeasonQualitySchema);
}

SeasonQuality ReadSeasonQuality(const std::string& path) {
  SeasonQuality q;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return q;
  const std::string rerun = "crop4d fuse";
  const json j = ReadJsonOfSchema(path, kSeasonQualitySchema, rerun);
  ReadFields(path, rerun, [&] {
    const std::string standard = j.at("standard").get<std::string>();
    q.standard = standard == "rtk"   ? Positioning::kRtk
                 : standard == "gps" ? Positioning::kGps
                                     : Positioning::kNone;
    q.any_trusted = j.at("any_trusted").get<bool>();
    for (const json& s : j.at("sessions")) {
      q.sessions.push_back({s.at("session").get<std::string>(), s.at("trusted").get<bool>(),
                            s.at("reasons").get<std::vector<std::string>>()});
    }
  });
  return q;
}

}  // namespace crop4d::workspace
