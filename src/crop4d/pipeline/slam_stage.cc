// The row SLAM stage (slam_stage.h): for every session, open it
// (slam_session.h), cut it into passes, and solve each selected pass that is
// not up to date (slam_pass.h); a pass that fails is reported and the others go
// on.

#include "crop4d/pipeline/slam_stage.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>

#include "crop4d/core/error.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/pipeline/slam_pass.h"
#include "crop4d/pipeline/slam_session.h"
#include "crop4d/pipeline/slam_summary.h"
#include "crop4d/pipeline/stage_option_fields.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_list.h"

namespace crop4d::pipeline {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// The fewest states a pass is solved with: one state has no motion to estimate.
constexpr std::size_t kMinPassStates = 2;

bool PassSelected(const SlamStageOptions& options, const slam::RowPass& pass) {
  if (options.pass.empty()) return true;
  if (options.pass == pass.id) return true;
  try {
    std::size_t used = 0;
    const int row = std::stoi(options.pass, &used);
    return used == options.pass.size() && row == pass.row;
  } catch (const std::exception&) {
    return false;
  }
}

// One pass of an open session: its state times, skipped when up to date (unless
// `force`), else solved; a pass that fails (fewer than two states, a solve that
// gives up) is reported as such.
PassReport SolveOrSkipPass(const SlamStageOptions& options, const SessionContext& ctx,
                           const slam::RowPass& pass, const workspace::Layout& layout,
                           const json& options_json) {
  const std::string& id = ctx.session->id();
  PassReport report;
  report.session = id;
  report.pass = pass;
  report.sensors = slam::ToString(ctx.sensors);
  report.folder = layout.PassDir(id, pass.id).string();
  const auto start = Clock::now();
  const std::vector<Timestamp> times = PassStateTimes(options, ctx, pass);
  if (times.size() < kMinPassStates) {
    report.failed = true;
    report.message = "fewer than 2 states in the pass";
    spdlog::warn("{}/{}: {}", id, pass.id, report.message);
    return report;
  }
  const std::string fingerprint = PassFingerprint(options_json, pass, times.size(), ctx.data_stamp);
  const bool needs_cloud = slam::Describe(ctx.sensors).camera;
  if (!options.force && PassUpToDate(layout, id, pass.id, fingerprint, needs_cloud)) {
    report.skipped = true;
    report.num_states = static_cast<int>(times.size());
    report.message = "up to date";
    spdlog::info("{}/{}: up to date, skipped", id, pass.id);
    return report;
  }
  try {
    const PassJob job{options, ctx, pass, layout, times, StreamsOfPass(ctx)};
    const PassOutcome outcome = RunPass(job, fingerprint, options_json);
    report.num_states = outcome.num_states;
    report.num_images = outcome.num_images;
    report.num_landmarks = outcome.num_landmarks;
    report.num_cloud_points = outcome.num_cloud_points;
  } catch (const InputError&) {
    throw;  // bad input stops the stage with its file and line
  } catch (const std::runtime_error& e) {
    // An expected failure of this pass's solve (no GPS course to start from, a
    // solver that gives up): the pass fails, the others go on. Programmer
    // errors (std::logic_error, std::invalid_argument of a violated
    // precondition) are not caught.
    report.failed = true;
    report.message = e.what();
    spdlog::error("{}/{}: {}", id, pass.id, e.what());
  }
  report.seconds = SecondsSince(start);
  if (!report.failed) {
    spdlog::info("{}/{}: {} states, {} landmarks, {} cloud points, {:.1f} s", id, pass.id,
                 report.num_states, report.num_landmarks, report.num_cloud_points, report.seconds);
  }
  return report;
}

// The sessions to run: `options.session`, else every session of the field.
std::vector<std::string> SelectedSessions(const io::Field& field, const std::string& field_folder,
                                          const SlamStageOptions& options) {
  std::vector<std::string> sessions = field.session_ids();
  if (options.session.empty()) return sessions;
  if (std::find(sessions.begin(), sessions.end(), options.session) == sessions.end()) {
    throw InputError(field_folder, 0, "no session '" + options.session + "' in this field");
  }
  return {options.session};
}

}  // namespace

std::vector<slam::GpsFixWorld> ApplyGpsOutages(const std::vector<slam::GpsFixWorld>& fixes,
                                               const std::vector<GpsOutage>& outages) {
  if (outages.empty() || fixes.empty()) return fixes;
  std::vector<slam::GpsFixWorld> kept;
  const Timestamp t0 = fixes.front().t;
  for (const slam::GpsFixWorld& fix : fixes) {
    const double s = DurationSeconds(t0, fix.t);
    bool dropped = false;
    for (const GpsOutage& g : outages) dropped |= s >= g.start_s && s < g.start_s + g.duration_s;
    if (!dropped) kept.push_back(fix);
  }
  return kept;
}

std::string SlamStageOptions::Check() const {
  for (const GpsOutage& g : gps_outages) {
    if (!(g.duration_s > 0)) return "gps_outages: a duration must be > 0";
    if (!std::isfinite(g.start_s)) return "gps_outages: a start must be a finite time";
  }
  if (!(state_rate_hz > 0)) return "state_rate_hz: must be > 0";
  if (!(session_state_rate_hz >= 0)) return "session_state_rate_hz: must be >= 0 (0: off)";
  if (!(session_solve_max_sigma_m >= 0)) return "session_solve_max_sigma_m: must be >= 0";
  if (!(session_bias_sigma_gyro > 0)) return "session_bias_sigma_gyro: must be > 0";
  if (!(session_bias_sigma_accel > 0)) return "session_bias_sigma_accel: must be > 0";
  if (!(camera_height_m >= 0) || !std::isfinite(camera_height_m)) {
    return "camera_height_m: must be >= 0 and finite (0: from sensor.yaml)";
  }
  if (!(window_overlap_s >= 0)) return "window_overlap_s: must be >= 0";
  if (!(max_window_s > window_overlap_s)) return "max_window_s: must be > window_overlap_s";
  // The nested options of the modules (their fields are documented in
  // docs/slam.md).
  if (const std::string why = front_end.Check(); !why.empty()) return "front_end." + why;
  if (const std::string why = passes.Check(); !why.empty()) return "passes." + why;
  if (const std::string why = initialisation.Check(); !why.empty()) return "initialisation." + why;
  if (const std::string why = visual_initialisation.Check(); !why.empty()) {
    return "visual_initialisation." + why;
  }
  if (const std::string why = optimiser.Check(); !why.empty()) return "optimiser." + why;
  if (const std::string why = cloud.Check(); !why.empty()) return "cloud." + why;
  return {};
}

const char* ToString(PassMode mode) {
  switch (mode) {
    case PassMode::kAuto:
      return "auto";
    case PassMode::kRows:
      return "rows";
    case PassMode::kWhole:
      return "whole";
  }
  return "?";
}

std::optional<PassMode> ParsePassMode(const std::string& text) {
  for (PassMode mode : {PassMode::kAuto, PassMode::kRows, PassMode::kWhole}) {
    if (text == ToString(mode)) return mode;
  }
  return std::nullopt;
}

std::string PassFolder(const std::string& workspace, const std::string& session,
                       const std::string& pass_id) {
  return workspace::Layout(workspace).PassDir(session, pass_id).string();
}

std::vector<PassReport> RunSlamStage(const std::string& field_folder, const std::string& workspace,
                                     const SlamStageOptions& options) {
  if (const std::string why = options.Check(); !why.empty()) throw InputError("slam." + why);
  const io::Field field(field_folder);
  const workspace::Layout layout(workspace);
  std::vector<PassReport> reports;
  for (const std::string& id : SelectedSessions(field, field_folder, options)) {
    const io::Session session = field.OpenSession(id);
    SessionContext ctx;
    OpenSlamSession(field, session, options, &ctx);
    const std::vector<slam::RowPass> passes = SessionPasses(field, options, ctx);
    workspace::WritePassList(layout.PassList(id).string(), passes);
    spdlog::info("session {}: {} passes, sensors {}", id, passes.size(),
                 slam::ToString(ctx.sensors));
    if (options.passes_only) continue;
    json options_json = SlamOptionsJson(options, ctx.sensors);
    // The height in effect, so that a change of the option or of sensor.yaml
    // solves again.
    options_json["camera_height_m"] = CameraHeight(options, ctx.streams);
    for (const slam::RowPass& pass : passes) {
      if (!PassSelected(options, pass)) continue;
      reports.push_back(SolveOrSkipPass(options, ctx, pass, layout, options_json));
    }
  }
  return reports;
}

}  // namespace crop4d::pipeline
