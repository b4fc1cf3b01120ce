#pragma once

// WS/fused/quality.json: the grade of every session of the season (pipeline/season_quality.h
// says how they are made and what a degraded session changes), written by the fuse stage and
// read by analyze, `crop4d run` and the report. Schema 1 carries no "schema" field
// (workspace/json_file.h); a file of another schema, one that is not JSON or lacks a field
// throws InputError naming the file and saying to rerun `crop4d fuse --force`.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace crop4d::workspace {

// Bumped whenever a field that a reader relies on changes its meaning or goes (a version above 1
// is stamped into the file).
inline constexpr int kSeasonQualitySchema = 1;

// How a pass was positioned, from its sensor set: worst to best.
enum class Positioning { kNone = 0, kGps = 1, kRtk = 2 };

// "none", "gps" or "rtk".
const char* PositioningName(Positioning p);
// The positioning of a sensor set name ("cam+imu+rtk" → kRtk, "cam+imu+gps" → kGps, else kNone).
Positioning PositioningOf(const std::string& sensors);

struct SessionGrade {
  std::string session;
  bool trusted = true;
  std::vector<std::string> reasons;  // why it is degraded (empty when trusted)
};

struct SeasonQuality {
  // The positioning that at least half of the sessions have.
  Positioning standard = Positioning::kNone;
  // Every session with passes, in the order of the facts.
  std::vector<SessionGrade> sessions;
  // False when no session is trusted: every session is then used (see above).
  bool any_trusted = true;

  // Whether `session` may set the frame, the terrain and the bounds of the others: a trusted
  // session, any session when none is trusted, and a session without grade.
  bool Protects(const std::string& session) const;
  // The degraded sessions.
  std::vector<const SessionGrade*> Degraded() const;
};

// The file's JSON ({"standard", "any_trusted", "sessions": [{"session", "trusted", "reasons"}]}).
nlohmann::json SeasonQualityToJson(const SeasonQuality& quality);
// Writes SeasonQualityToJson atomically (2-space indented, final newline).
void WriteSeasonQuality(const std::string& path, const SeasonQuality& quality);
// Reads the file; a missing file gives an empty SeasonQuality (every session protects).
SeasonQuality ReadSeasonQuality(const std::string& path);

}  // namespace crop4d::workspace
