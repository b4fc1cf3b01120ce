// The configuration file of `crop4d run` (pipeline/run_config.h) and the run records
// (pipeline/run_log.h).

#include "crop4d/pipeline/run_config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <type_traits>

#include "crop4d/core/error.h"
#include "crop4d/pipeline/run_log.h"
#include "crop4d/pipeline/season_run.h"
#include "crop4d/pipeline/stage_option_fields.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string ErrorOf(const std::string& text) {
  try {
    ParseRunConfig("season.yaml", text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(RunConfigTest, EmptyFileGivesTheStageDefaults) {
  const RunConfig config = ParseRunConfig("season.yaml", "");
  const RunConfig defaults;
  EXPECT_EQ(config.threads, 0);
  EXPECT_TRUE(config.densify);
  EXPECT_EQ(config.eval, "auto");
  EXPECT_EQ(config.associate.method, defaults.associate.method);
  EXPECT_EQ(config.fuse.max_matches_per_image_pair, defaults.fuse.max_matches_per_image_pair);
  EXPECT_DOUBLE_EQ(config.densify_options.stereo.cell_m, defaults.densify_options.stereo.cell_m);
  EXPECT_FALSE(config.slam.sensors.has_value());
}

TEST(RunConfigTest, KeysSetTheStageOptions) {
  const RunConfig c = ParseRunConfig("season.yaml",
                                     "threads: 2\n"
                                     "stages: {densify: false, eval: never, report: false}\n"
                                     "slam:\n"
                                     "  sensors: cam+imu+gps\n"
                                     "  neighbors: 6\n"
                                     "  max_reprojection_error_px: 4.5\n"
                                     "associate: {method: both, session_gap: 2}\n"
                                     "fuse: {linear_solver: iterative, matches_per_image_pair: 0}\n"
                                     "densify: {cell_m: 0.01, max_views: 5}\n"
                                     "analyze: {canopy_top: crown-peaks, greenness: exgr, "
                                     "sites: my_sites.csv, max_shrink_m: -1, "
                                     "plant_min_prominence_m: 0.02}\n"
                                     "eval: {canopy_max_error_m: 0.03, associations: false}\n");
  EXPECT_EQ(c.threads, 2);
  EXPECT_FALSE(c.densify);
  EXPECT_EQ(c.eval, "never");
  EXPECT_FALSE(c.report);
  ASSERT_TRUE(c.slam.sensors.has_value());
  EXPECT_EQ(*c.slam.sensors, *slam::ParseSensorSet("cam+imu+gps"));
  EXPECT_EQ(c.slam.front_end.num_neighbors, 6);
  EXPECT_DOUBLE_EQ(c.slam.optimiser.max_reprojection_error_px, 4.5);
  EXPECT_EQ(c.associate.method, "both");
  EXPECT_EQ(c.associate.session_gap, 2);
  EXPECT_TRUE(c.fuse.optimiser.row.iterative_schur);
  EXPECT_EQ(c.fuse.max_matches_per_image_pair, 0);
  EXPECT_DOUBLE_EQ(c.densify_options.stereo.cell_m, 0.01);
  EXPECT_EQ(c.densify_options.stereo.max_views, 5);
  EXPECT_EQ(c.analyze.canopy.top, analysis::CanopyTop::kCrownPeaks);
  EXPECT_EQ(c.analyze.vegetation.index, analysis::GreennessIndex::kExGR);
  EXPECT_EQ(c.analyze.sites_file, "my_sites.csv");
  EXPECT_DOUBLE_EQ(c.analyze.canopy.max_shrink_m, -1.0);
  EXPECT_DOUBLE_EQ(c.analyze.plants.min_prominence_m, 0.02);
  EXPECT_DOUBLE_EQ(c.eval_options.canopy_options.max_error_m, 0.03);
  EXPECT_FALSE(c.eval_options.associations);
}

TEST(RunConfigTest, FormattedConfigurationReadsBackToItself) {
  RunConfig c;
  c.threads = 3;
  c.eval = "always";
  c.slam.sensors = slam::ParseSensorSet("cam+imu");
  c.associate.method = "naive";
  c.fuse.method = "naive";
  c.densify_options.stereo.min_score = 0.35;
  c.analyze.sites_file = "a \"quoted\" path.csv";
  c.analyze.canopy.top = analysis::CanopyTop::kQuantile;
  const std::string text = FormatRunConfig(c);
  const RunConfig back = ParseRunConfig("crop4d.yaml", text);
  EXPECT_EQ(FormatRunConfig(back), text);
  EXPECT_EQ(back.analyze.sites_file, "a \"quoted\" path.csv");
  EXPECT_DOUBLE_EQ(back.densify_options.stereo.min_score, 0.35);
  // Every key carries a comment.
  EXPECT_THAT(text, HasSubstr("# sensor set"));
  // The defaults too.
  EXPECT_EQ(FormatRunConfig(ParseRunConfig("d.yaml", FormatRunConfig(RunConfig{}))),
            FormatRunConfig(RunConfig{}));
}

// Another value of an option that its key accepts: numbers halved (0: 0.5), integers + 1, bools
// flipped, enums the next value, optionals set, strings extended.
template <typename T>
void Change(T& value) {
  if constexpr (std::is_floating_point_v<T>) {
    value = value != 0 ? value / 2 : 0.5;
  } else {
    fields::Perturb(value);
  }
}

TEST(RunConfigTest, EveryKeyReadsAndWritesItsField) {
  RunConfig defaults;
  std::set<std::string> leaves;
  fields::VisitLeaves(defaults,
                      [&](const std::string& path, auto&, fields::Role) { leaves.insert(path); });
  const std::string base = FormatRunConfig(defaults);
  const nlohmann::json base_json = fields::OptionsToJson(defaults, /*with_control=*/true);
  std::set<std::string> bound;
  int round_trips = 0;
  for (const RunConfigKey& key : RunConfigKeys()) {
    const std::string name = key.section + "." + key.name;
    EXPECT_EQ(leaves.count(key.field), 1u)
        << name << " is bound to '" << key.field << "', which is no field of RunConfig";
    EXPECT_TRUE(bound.insert(key.field).second) << name << ": a second key for " << key.field;
    RunConfig changed = defaults;
    bool free_string = false;
    fields::VisitLeaves(changed, [&](const std::string& path, auto& field, fields::Role) {
      if (path != key.field) return;
      Change(field);
      free_string = std::is_same_v<std::remove_cvref_t<decltype(field)>, std::string>;
    });
    ASSERT_NE(fields::OptionsToJson(changed, true), base_json) << name;
    // The file shows the field...
    const std::string text = FormatRunConfig(changed);
    EXPECT_NE(text, base) << name << " does not write " << key.field;
    // ... and reading it back sets that field, and nothing else. A string key that takes one of
    // a few words refuses the extended string (its errors: BadFilesAreErrorsNamingTheLineAndKey).
    try {
      const RunConfig back = ParseRunConfig("crop4d.yaml", text);
      EXPECT_EQ(fields::OptionsToJson(back, true), fields::OptionsToJson(changed, true)) << name;
      ++round_trips;
    } catch (const InputError& e) {
      EXPECT_TRUE(free_string) << name << ": " << e.what();
    }
  }
  EXPECT_GT(round_trips, 60);
}

TEST(RunConfigTest, BadFilesAreErrorsNamingTheLineAndKey) {
  EXPECT_THAT(ErrorOf("slam:\n  neighbours: 4\n"),
              HasSubstr("season.yaml:2: unknown key 'slam.neighbours'"));
  EXPECT_THAT(ErrorOf("thread: 2\n"), HasSubstr("unknown key 'thread'"));
  EXPECT_THAT(ErrorOf("densify:\n  cell_m: -1\n"), HasSubstr("'densify.cell_m': expected a value"));
  EXPECT_THAT(ErrorOf("slam: {neighbors: 2.5}\n"), HasSubstr("expected an integer"));
  EXPECT_THAT(ErrorOf("stages: {densify: yes please}\n"), HasSubstr("expected true or false"));
  EXPECT_THAT(ErrorOf("associate: {method: fancy}\n"),
              HasSubstr("expected one of robust, naive, both"));
  EXPECT_THAT(ErrorOf("fuse: [1, 2]\n"), HasSubstr("'fuse' must be a map"));
  EXPECT_THAT(ErrorOf("slam: {neighbors: [1]}\n"), HasSubstr("must be a single value"));
  EXPECT_THAT(ErrorOf("- a\n- b\n"), HasSubstr("expected a map"));
  EXPECT_THAT(ErrorOf("slam: {neighbors: 4\n"), HasSubstr("season.yaml"));  // syntax error
  // Fusion needs the associations it uses.
  EXPECT_THAT(ErrorOf("associate: {method: naive}\n"), HasSubstr("fuse.method 'robust'"));
  EXPECT_EQ(ErrorOf("associate: {method: naive}\nfuse: {method: naive}\n"), "");
}

TEST(RunLogTest, RecordRoundTripsAndLogSurvivesACutLastLine) {
  const fs::path dir =
      fs::path(::testing::TempDir()) / ("crop4d_run_log_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  RunRecord r;
  r.crop4d_version = "0.1.0";
  r.field = "f";
  r.workspace = "w";
  r.started = "2026-11-22T12:00:00Z";
  r.threads = 2;
  StageRecord slam, fuse;
  slam.name = "slam";
  slam.status = "partial";
  slam.seconds = 12.5;
  slam.done = 3;
  slam.skipped = 1;
  slam.failed = 1;
  slam.messages = {"a warning"};
  fuse.name = "fuse";
  r.stages = {slam, fuse};
  r.skipped = {{"slam", "2016-06-10", "row01", "no GPS"}};
  WriteRunRecord((dir / "run.json").string(), r);
  const RunRecord back = ReadRunRecord((dir / "run.json").string());
  EXPECT_EQ(back.started, r.started);
  EXPECT_TRUE(back.finished.empty());
  EXPECT_FALSE(back.complete);
  ASSERT_EQ(back.stages.size(), 2u);
  EXPECT_EQ(back.stages[0].status, "partial");
  EXPECT_DOUBLE_EQ(back.stages[0].seconds, 12.5);
  EXPECT_EQ(back.stages[0].done, 3);
  EXPECT_EQ(back.stages[0].messages, std::vector<std::string>{"a warning"});
  EXPECT_EQ(back.stages[1].status, "not run");
  ASSERT_EQ(back.skipped.size(), 1u);
  EXPECT_EQ(back.skipped[0].reason, "no GPS");
  std::ofstream(dir / "bad.json") << "{\"stages\": 3";
  EXPECT_THROW(ReadRunRecord((dir / "bad.json").string()), InputError);

  const std::string log_path = (dir / "run_log.jsonl").string();
  std::string run_id;
  {
    RunLog log(log_path);
    run_id = log.run_id();
    log.Add("slam", "2016-06-10/row00", kActionDone, 1.5);
    log.Add("slam", "2016-06-10/row01", kActionFailed, 0, "no GPS");
  }
  std::ofstream(log_path, std::ios::app) << "{\"run\":\"x\",\"stage\":\"fu";  // killed mid-line
  const std::vector<RunEvent> events = ReadRunLog(log_path);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].run, run_id);
  EXPECT_EQ(events[0].item, "2016-06-10/row00");
  EXPECT_DOUBLE_EQ(events[0].seconds, 1.5);
  EXPECT_EQ(events[1].action, kActionFailed);
  EXPECT_EQ(events[1].message, "no GPS");
  EXPECT_TRUE(ReadRunLog((dir / "missing.jsonl").string()).empty());
  fs::remove_all(dir);
}

TEST(RunConfigTest, ThreadsFromTheCommandLineAreCheckedBeforeAnythingIsWritten) {
  // `crop4d run --threads -1` sets the value past the file's range check.
  RunOptions options;
  options.config.threads = -1;
  std::string message;
  EXPECT_FALSE(options.config.Check(&message));
  EXPECT_THAT(message, HasSubstr("threads must be 0 (all cores) to 1024 (got -1)"));
  const fs::path ws =
      fs::path(::testing::TempDir()) / ("crop4d_threads_" + std::to_string(::getpid()));
  fs::remove_all(ws);
  EXPECT_THROW(RunSeason("no-such-field", ws.string(), options), InputError);
  EXPECT_FALSE(fs::exists(ws / "crop4d.yaml"));
  fs::remove_all(ws);
}

}  // namespace
}  // namespace crop4d::pipeline
