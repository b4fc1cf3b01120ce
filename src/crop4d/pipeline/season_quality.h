#pragma once

// Quality gates of a season: every session is graded from what its row passes actually had and
// what row SLAM made of them (the passes' summary.json), so that a session below the season's
// standard cannot spoil the others.
//
// A session is **degraded** when
//   - its positioning is below the season's standard: the passes ran with a metre-level
//     receiver (`+gps`) or none while at least half of the sessions had RTK (`+rtk`), or without
//     any GPS while at least half had one (a receiver without a fix, a missing receiver folder);
//   - one of its passes went longer than `max_imu_gap_s` without an IMU sample (the pass is
//     named): the motion there is bridged by the camera and a smoothness prior only;
//   - row SLAM's GPS outlier gate rejected more than `max_gps_rejected_share` of a pass's fixes
//     (the pass is named): its solve left the GPS track (a wrong initial heading, a receiver far
//     off), and its poses cannot be trusted to move the other sessions or their calibration.
// A degraded session is still fused, densified and analysed, but it never moves a trusted one:
// the joint problem is solved on the trusted passes first, then the degraded passes are
// registered onto them held fixed (fuse_stage.h); the terrain, the plant stems and the growth
// bounds come from the trusted sessions only (analyze_stage.h). When no session is trusted, the
// grades are reported and every session is used as before: there is nothing better to protect.
//
// `crop4d fuse` writes the grades to WS/fused/quality.json (its owner); analyze, run and report
// read them from there. The grades' types and the file's typed reader and writer are in
// workspace/season_quality.h; this header holds the grading.

#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/workspace/pass_summary.h"
#include "crop4d/workspace/season_quality.h"

namespace crop4d::pipeline {

using workspace::Positioning;
using workspace::PositioningName;
using workspace::PositioningOf;
using workspace::SeasonQuality;
using workspace::SeasonQualityToJson;
using workspace::SessionGrade;

// What grading needs of one row pass.
struct PassFacts {
  std::string session;
  std::string pass;
  Positioning positioning = Positioning::kNone;
  std::string sensors;
  // The longest time inside the pass without an IMU sample, s (0 without an IMU).
  double longest_imu_gap_s = 0.0;
  // The GPS fixes of the pass's solve, and those its outlier gate rejected.
  int gps_fixes = 0;
  int gps_rejected = 0;
};

// Whether a pass's solve has left the GPS track: its outlier gate rejected more than `max_share`
// of its `fixes` (row SLAM flags such a pass, GradeSeason degrades its session).
inline bool LeftGpsTrack(int fixes, int rejected, double max_share) {
  return fixes > 0 && rejected > max_share * fixes;
}

// The facts of a pass from its row-SLAM summary (workspace/pass_summary.h).
PassFacts PassFactsOf(const std::string& session, const std::string& pass,
                      const workspace::PassSummary& summary);

struct QualityOptions {
  // A pass without IMU samples for longer than this degrades its session, s.
  double max_imu_gap_s = 1.0;
  // A pass whose row SLAM rejected more than this share of its GPS fixes as outliers degrades
  // its session (a receiver's multipath outliers are a few percent).
  double max_gps_rejected_share = 0.5;

  OptionCheck Check() const;
};

// Grades the sessions of `passes` (grouped by session, in order of first appearance).
SeasonQuality GradeSeason(const std::vector<PassFacts>& passes, const QualityOptions& options);

// WS/fused/quality.json of `workspace` read with workspace::ReadSeasonQuality: a missing file
// gives an empty SeasonQuality (every session protects); a damaged one throws InputError naming
// the file.
SeasonQuality ReadSeasonQuality(const std::string& workspace);
// The path of the file (workspace::Layout::FusedQuality()).
std::string SeasonQualityPath(const std::string& workspace);

}  // namespace crop4d::pipeline
