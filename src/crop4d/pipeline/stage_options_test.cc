// The options of the stages. Their checks: an invalid option is an InputError that names the
// option (with its configuration section) and why, raised before the stage reads anything. Their
// field lists (stage_option_fields.h): every data member of every option struct is listed, and
// every option that changes a stage's results changes the options the stage records and hashes
// into its fingerprint, so that the stage reruns.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/pipeline/associate_stage.h"
#include "crop4d/pipeline/densify_stage.h"
#include "crop4d/pipeline/fuse_stage.h"
#include "crop4d/pipeline/run_config.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/pipeline/stage_option_fields.h"

namespace crop4d::pipeline {
namespace {

// The message of the InputError `run` throws ("" when it throws none).
std::string InputErrorOf(const std::function<void()>& run) {
  try {
    run();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

constexpr const char* kNoField = "/nonexistent/crop4d_field";
constexpr const char* kNoWorkspace = "/nonexistent/crop4d_workspace";

TEST(StageOptionsTest, DefaultsAreValid) {
  EXPECT_EQ(SlamStageOptions().Check(), "");
  EXPECT_EQ(AssociateStageOptions().Check(), "");
  EXPECT_EQ(FuseStageOptions().Check(), "");
  EXPECT_EQ(DensifyStageOptions().Check(), "");
}

TEST(StageOptionsTest, SlamNamesTheOptionAndWhy) {
  SlamStageOptions o;
  o.state_rate_hz = 0;
  EXPECT_EQ(o.Check(), "state_rate_hz: must be > 0");
  EXPECT_EQ(InputErrorOf([&] { RunSlamStage(kNoField, kNoWorkspace, o); }),
            "slam.state_rate_hz: must be > 0");
  o = SlamStageOptions();
  o.max_window_s = o.window_overlap_s;
  EXPECT_EQ(o.Check(), "max_window_s: must be > window_overlap_s");
  o = SlamStageOptions();
  o.gps_outages.push_back({10.0, -1.0});
  EXPECT_EQ(o.Check(), "gps_outages: a duration must be > 0");
  o = SlamStageOptions();
  o.optimiser.max_iterations = 0;
  EXPECT_EQ(o.Check(), "optimiser.max_iterations: must be > 0 (got 0)");
}

TEST(StageOptionsTest, AssociateNamesTheOptionAndWhy) {
  AssociateStageOptions o;
  o.prealign = "sometimes";
  EXPECT_EQ(o.Check(), "prealign: must be auto, always or never (got 'sometimes')");
  EXPECT_EQ(InputErrorOf([&] { RunAssociateStage(kNoField, kNoWorkspace, o); }),
            "associate.prealign: must be auto, always or never (got 'sometimes')");
  o = AssociateStageOptions();
  o.min_track_length = 1;
  EXPECT_EQ(o.Check(), "min_track_length: must be >= 2");
}

TEST(StageOptionsTest, FuseNamesTheOptionAndWhy) {
  FuseStageOptions o;
  o.max_matches_per_image_pair = -1;
  EXPECT_EQ(o.Check(), "max_matches_per_image_pair: must be >= 0 (0: all)");
  EXPECT_EQ(InputErrorOf([&] { RunFuseStage(kNoField, kNoWorkspace, o); }),
            "fuse.max_matches_per_image_pair: must be >= 0 (0: all)");
}

TEST(StageOptionsTest, DensifyNamesTheOptionAndWhy) {
  DensifyStageOptions o;
  o.radius_m = 0;
  EXPECT_EQ(o.Check(), "radius_m: must be > 0");
  EXPECT_EQ(InputErrorOf([&] { RunDensifyStage(kNoField, kNoWorkspace, o); }),
            "densify.radius_m: must be > 0");
}

TEST(StageOptionsTest, RunConfigNamesTheSectionAndOption) {
  RunConfig config;
  config.fuse.ground_tie_max_matches = -2;
  std::string message;
  EXPECT_FALSE(config.Check(&message));
  EXPECT_EQ(message, "fuse.ground_tie_max_matches: must be >= 0");
}

template <class S>
std::vector<std::string> Unlisted() {
  S options;
  return fields::UnlistedFields(options, "options");
}

TEST(StageOptionsTest, EveryMemberIsListed) {
  for (const auto& problems : {Unlisted<SlamStageOptions>(), Unlisted<AssociateStageOptions>(),
                               Unlisted<FuseStageOptions>(), Unlisted<DensifyStageOptions>(),
                               Unlisted<AnalyzeStageOptions>(), Unlisted<RunConfig>()}) {
    for (const std::string& p : problems) ADD_FAILURE() << p;
  }
}

// A struct whose member is left out of its list is caught, with the struct's path.
struct TwoMembers {
  int a = 0;
  double b = 0;
};
template <class V>
void VisitFields(TwoMembers& o, V&& visit) {
  visit("a", o.a);
}
struct Outer {
  TwoMembers inner;
};
template <class V>
void VisitFields(Outer& o, V&& visit) {
  visit("inner", o.inner);
}

TEST(StageOptionsTest, AMemberLeftOutIsFound) {
  EXPECT_EQ(fields::MemberCount<TwoMembers>(), 2u);
  Outer outer;
  const std::vector<std::string> problems = fields::UnlistedFields(outer, "outer");
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].rfind("outer.inner: 2 data members but 1 listed", 0), 0u) << problems[0];
}

// One stage: its default options, and the text it hashes into its fingerprint for given options.
template <class S>
struct StageUnderTest {
  std::string name;
  std::function<std::string(const S&)> fingerprint_text;
  // Leaves the stage replaces by a value it resolves itself (checked separately).
  std::set<std::string> resolved = {};
};

// Every leaf of the default options perturbed alone: a kResult leaf changes the fingerprint
// text, a kControl leaf does not. Returns the number of leaves.
template <class S>
int CheckEveryLeaf(const StageUnderTest<S>& stage) {
  S defaults;
  const std::string base = stage.fingerprint_text(defaults);
  EXPECT_EQ(stage.fingerprint_text(defaults), base) << stage.name << ": not deterministic";
  std::vector<std::pair<std::string, fields::Role>> leaves;
  fields::VisitLeaves(defaults, [&](const std::string& path, auto&, fields::Role role) {
    leaves.emplace_back(path, role);
  });
  for (const auto& leaf : leaves) {
    const std::string& path = leaf.first;
    const fields::Role role = leaf.second;
    S changed = defaults;
    int hits = 0;
    fields::VisitLeaves(changed, [&](const std::string& p, auto& field, fields::Role) {
      if (p != path) return;
      fields::Perturb(field);
      ++hits;
    });
    EXPECT_EQ(hits, 1) << stage.name << "." << path;
    const bool differs = stage.fingerprint_text(changed) != base;
    if (stage.resolved.count(path) != 0 || role == fields::Role::kControl) {
      EXPECT_FALSE(differs) << stage.name << "." << path
                            << " is kControl or resolved by the stage, yet changes the fingerprint";
    } else {
      EXPECT_TRUE(differs) << stage.name << "." << path
                           << " changes results but not the fingerprint: the stage would not rerun";
    }
  }
  return static_cast<int>(leaves.size());
}

TEST(StageOptionsTest, EveryOptionChangesTheFingerprint) {
  // The slam stage records the sensor set it resolved for the session (`sensors` unset: from
  // the session's receivers); the associate stage runs once per method ("both": robust, then
  // naive); the densify stage adds the field's sites to the centres.
  const int slam = CheckEveryLeaf<SlamStageOptions>(
      {"slam",
       [](const SlamStageOptions& o) {
         return SlamOptionsJson(o, slam::SensorSet::kCamImuRtk).dump();
       },
       {"sensors"}});
  const int associate =
      CheckEveryLeaf<AssociateStageOptions>({"associate", [](const AssociateStageOptions& o) {
                                               return AssociateOptionsJson(o, o.method).dump();
                                             }});
  const int fuse = CheckEveryLeaf<FuseStageOptions>(
      {"fuse", [](const FuseStageOptions& o) { return FuseOptionsJson(o).dump(); }});
  const int densify =
      CheckEveryLeaf<DensifyStageOptions>({"densify", [](const DensifyStageOptions& o) {
                                             return DensifyOptionsJson(o, o.centers).dump();
                                           }});
  const int analyze = CheckEveryLeaf<AnalyzeStageOptions>(
      {"analyze", [](const AnalyzeStageOptions& o) { return AnalyzeOptionsJson(o).dump(); }});
  std::printf("leaves: slam %d, associate %d, fuse %d, densify %d, analyze %d\n", slam, associate,
              fuse, densify, analyze);
  // Every nested struct is reached (the optimiser alone has 26 members, 8 of them structs).
  EXPECT_GT(slam, 100);
  EXPECT_GT(associate, 60);
  EXPECT_GT(fuse, 50);
  EXPECT_GT(densify, 40);
  EXPECT_GT(analyze, 50);

  const SlamStageOptions o;
  EXPECT_NE(SlamOptionsJson(o, slam::SensorSet::kCamImuRtk).dump(),
            SlamOptionsJson(o, slam::SensorSet::kCamImuGps).dump());
  EXPECT_EQ(SlamOptionsJson(o, slam::SensorSet::kCamImuGps)["sensors"], "cam+imu+gps");
  const AssociateStageOptions a;
  EXPECT_NE(AssociateOptionsJson(a, "robust").dump(), AssociateOptionsJson(a, "naive").dump());
  const DensifyStageOptions d;
  EXPECT_NE(DensifyOptionsJson(d, {}).dump(), DensifyOptionsJson(d, {{1.0, 2.0}}).dump());
}

TEST(StageOptionsTest, OptionsJsonWritesEveryValueExactly) {
  SlamStageOptions o;
  const std::string base = SlamOptionsJson(o, slam::SensorSet::kCamImu).dump();
  // One unit in the last place of a double changes the text.
  o.optimiser.gp.qc_rotation = std::nextafter(o.optimiser.gp.qc_rotation, 1.0);
  EXPECT_NE(SlamOptionsJson(o, slam::SensorSet::kCamImu).dump(), base);
  // Nested structs as objects, enums by name, non-finite numbers and optionals as text / null.
  const nlohmann::json j = SlamOptionsJson(SlamStageOptions(), slam::SensorSet::kCamImu);
  EXPECT_EQ(j["front_end"]["matching"]["descriptors"]["method"], "exhaustive");
  EXPECT_EQ(j["front_end"]["extraction"]["max_num_features"], 1024);
  EXPECT_EQ(j["passes"]["row_axis_rad"], "nan");
  EXPECT_EQ(j["pass_mode"], "auto");
  EXPECT_EQ(j["gps_outages"], nlohmann::json::array());
  EXPECT_FALSE(j.contains("force"));
  EXPECT_FALSE(j.contains("show_progress"));
  EXPECT_FALSE(j["front_end"].contains("num_threads"));
  // With the control fields (the report, the configuration).
  const nlohmann::json all = fields::OptionsToJson(SlamStageOptions(), /*with_control=*/true);
  EXPECT_EQ(all["force"], false);
  EXPECT_EQ(all["sensors"], nullptr);
  // What `crop4d export` reads back from the analysis summary's options.
  const nlohmann::json analyze = AnalyzeOptionsJson(AnalyzeStageOptions());
  EXPECT_EQ(analyze["vegetation"]["index"], "ExG");
  EXPECT_EQ(analyze["canopy"]["min_height_m"], AnalyzeStageOptions().canopy.min_height_m);
  EXPECT_EQ(analyze["lone_point_radius_m"], AnalyzeStageOptions().lone_point_radius_m);
  o = SlamStageOptions();
  o.gps_outages.push_back({10.0, 5.0});
  EXPECT_EQ(SlamOptionsJson(o, slam::SensorSet::kCamImu)["gps_outages"],
            nlohmann::json::parse(R"([{"start_s": 10.0, "duration_s": 5.0}])"));
}

}  // namespace
}  // namespace crop4d::pipeline
