#include "crop4d/io/validator.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "crop4d/io/sample_field.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

const std::string kS = "sessions/2016-05-25/";

class ValidatorTest : public ::testing::Test {
 protected:
  void SetUp() override { WriteSampleField(dir_.path()); }

  std::string Path(const std::string& relative) const { return dir_ / relative; }

  ValidationReport Validate(ValidateOptions options = ValidateOptions()) {
    options.progress = false;
    return ValidateField(dir_.path(), options);
  }

  // The diagnostics of a report as "error: file:line: message" strings.
  static std::vector<std::string> Messages(const ValidationReport& report) {
    std::vector<std::string> out;
    for (const Diagnostic& d : report.diagnostics) out.push_back(d.ToString());
    return out;
  }

  static bool Contains(const ValidationReport& report, const std::string& text) {
    for (const std::string& m : Messages(report)) {
      if (m == text) return true;
    }
    return false;
  }

  static std::string Dump(const ValidationReport& report) {
    std::string out;
    for (const std::string& m : Messages(report)) out += m + "\n";
    return out;
  }

  // The name of the image listed on `line` of cam0/data.csv.
  std::string ImageOnLine(int line) const {
    const std::string text = testing::ReadLines(Path(kS + "cam0/data.csv")).at(line - 1);
    return text.substr(text.find(',') + 1);
  }

  TempDir dir_;
};

TEST_F(ValidatorTest, ValidFieldHasNoProblemsAndAFullSummary) {
  const ValidationReport report = Validate();
  EXPECT_TRUE(report.ok());
  EXPECT_EQ(report.errors, 0u);
  EXPECT_EQ(report.warnings, 0u) << Dump(report);
  EXPECT_EQ(report.field_name, "sample field");
  ASSERT_EQ(report.sessions.size(), 1u);
  const SessionReport& session = report.sessions[0];
  EXPECT_EQ(session.date, FromDate(2016, 5, 25));
  ASSERT_EQ(session.sensors.size(), 4u);
  const SensorReport& cam = session.sensors[0];
  EXPECT_EQ(cam.name, "cam0");
  EXPECT_EQ(cam.samples, 16);
  EXPECT_EQ(cam.images_listed, 16);
  EXPECT_EQ(cam.images_missing + cam.images_unreadable + cam.images_unlisted, 0);
  EXPECT_NEAR(cam.mean_rate_hz, 7.5, 1e-6);
  EXPECT_NEAR(cam.span_s(), 2.0, 1e-6);
  const SensorReport& gps = session.sensors[1];
  EXPECT_EQ(gps.name, "gps0");
  EXPECT_EQ(gps.stats.fix_counts.at(4), 10);
  EXPECT_EQ(gps.stats.fix_counts.at(5), 1);
  const SensorReport& imu = session.sensors[2];
  EXPECT_EQ(imu.name, "imu0");
  EXPECT_EQ(imu.samples, 335);
  EXPECT_NEAR(imu.mean_rate_hz, 167.0, 0.01);
  EXPECT_EQ(imu.gaps, 0);
  EXPECT_EQ(session.sensors[3].name, "mag0");

  const std::string summary = FormatValidationSummary(report);
  EXPECT_NE(summary.find("session 2016-05-25 (date 2016-05-25)"), std::string::npos) << summary;
  EXPECT_NE(summary.find("fix: rtk-fixed 10 (91%), rtk-float 1 (9%)"), std::string::npos)
      << summary;
  EXPECT_NE(summary.find("0 errors, 0 warnings"), std::string::npos) << summary;
}

TEST_F(ValidatorTest, WrongColumnCountNamesFileAndLine) {
  testing::ReplaceLine(Path(kS + "imu0/data.csv"), 17, "1464184800095808383,0,0,0,1");
  const ValidationReport report = Validate();
  EXPECT_FALSE(report.ok());
  EXPECT_EQ(report.errors, 1u) << Dump(report);
  EXPECT_TRUE(Contains(report, "error: " + kS + "imu0/data.csv:17: expected 7 columns, found 5"))
      << Dump(report);
  EXPECT_EQ(report.sessions[0].sensors[2].stats.bad_lines, 1);
}

TEST_F(ValidatorTest, NanInMagnetometerIsAnError) {
  std::vector<std::string> lines = testing::ReadLines(Path(kS + "mag0/data.csv"));
  lines[5] = lines[5].substr(0, lines[5].find(',')) + ",nan,1,2";
  testing::WriteLines(Path(kS + "mag0/data.csv"), lines);
  const ValidationReport report = Validate();
  EXPECT_EQ(Messages(report), std::vector<std::string>{"error: " + kS +
                                                       "mag0/data.csv:6: column 2 (m_x): value "
                                                       "is not finite (nan)"});
}

TEST_F(ValidatorTest, DuplicateAndUnsortedTimestampsAreErrors) {
  std::vector<std::string> lines = testing::ReadLines(Path(kS + "gps0/data.csv"));
  lines[4] = lines[3];            // line 5 repeats line 4
  std::swap(lines[7], lines[8]);  // lines 8 and 9 swapped
  testing::WriteLines(Path(kS + "gps0/data.csv"), lines);
  const ValidationReport report = Validate();
  EXPECT_EQ(report.errors, 2u) << Dump(report);
  EXPECT_EQ(report.sessions[0].sensors[1].stats.duplicates, 1);
  EXPECT_EQ(report.sessions[0].sensors[1].stats.out_of_order, 1);
  const std::vector<std::string> messages = Messages(report);
  ASSERT_EQ(messages.size(), 3u) << Dump(report);
  // 9 good samples left in 2 s: the mean rate is off too.
  EXPECT_EQ(messages[0], "warning: " + kS +
                             "gps0/data.csv: mean rate 4 Hz is -20% off the "
                             "nominal rate_hz 5 of " +
                             kS + "gps0/sensor.yaml");
  EXPECT_EQ(messages[1], "error: " + kS +
                             "gps0/data.csv:5: duplicate timestamp "
                             "1464184800400000000 (same as line 4)");
  EXPECT_EQ(messages[2], "error: " + kS +
                             "gps0/data.csv:9: timestamp 1464184801200000000 is "
                             "200 ms before the previous sample's (line 8); "
                             "timestamps must be strictly increasing");
}

TEST_F(ValidatorTest, EmptySensorFileIsAnError) {
  testing::WriteText(Path(kS + "imu0/data.csv"), "");
  const ValidationReport report = Validate();
  EXPECT_TRUE(Contains(report, "error: " + kS +
                                   "imu0/data.csv: empty file: no header and no "
                                   "samples"))
      << Dump(report);
}

TEST_F(ValidatorTest, ListedImagesMissingEmptyOrNotImagesAreErrorsAtTheirLine) {
  fs::remove(Path(kS + "cam0/data/" + ImageOnLine(3)));
  testing::WriteText(Path(kS + "cam0/data/" + ImageOnLine(5)), "");
  testing::WriteText(Path(kS + "cam0/data/" + ImageOnLine(7)), "<html>not a png</html>");
  const ValidationReport report = Validate();
  EXPECT_EQ(
      Messages(report),
      (std::vector<std::string>{
          "error: " + kS + "cam0/data.csv:3: listed image data/" + ImageOnLine(3) + " is missing",
          "error: " + kS + "cam0/data.csv:5: listed image data/" + ImageOnLine(5) +
              " is not readable: empty file (0 bytes)",
          "error: " + kS + "cam0/data.csv:7: listed image data/" + ImageOnLine(7) +
              " is not readable: not an image (unknown file signature)"}));
  EXPECT_EQ(report.sessions[0].sensors[0].images_missing, 1);
  EXPECT_EQ(report.sessions[0].sensors[0].images_unreadable, 2);
}

TEST_F(ValidatorTest, TruncatedImageFoundWithoutDecodingAndDamagedOneWhenDecoding) {
  // Cut short: its end marker is missing, which the cheap check sees (crop4d run's validate).
  const std::string cut = Path(kS + "cam0/data/" + ImageOnLine(4));
  testing::WriteText(cut, testing::ReadText(cut).substr(0, 60));
  EXPECT_EQ(Messages(Validate()),
            std::vector<std::string>{"error: " + kS + "cam0/data.csv:4: listed image data/" +
                                     ImageOnLine(4) +
                                     " is not readable: truncated PNG (no IEND chunk at the "
                                     "end)"});
  // Damaged inside but whole: only decoding finds it.
  fs::copy_file(Path(kS + "cam0/data/" + ImageOnLine(5)), cut,
                fs::copy_options::overwrite_existing);
  const std::string damaged = Path(kS + "cam0/data/" + ImageOnLine(6));
  std::string bytes = testing::ReadText(damaged);
  for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 4; ++i) bytes[i] ^= 0x5A;
  testing::WriteText(damaged, bytes);
  EXPECT_TRUE(Validate().ok());
  ValidateOptions options;
  options.decode_images = true;
  EXPECT_EQ(Messages(Validate(options)),
            std::vector<std::string>{"error: " + kS + "cam0/data.csv:6: listed image data/" +
                                     ImageOnLine(6) +
                                     " is not readable: cannot be decoded (truncated or corrupt "
                                     "png)"});
}

TEST_F(ValidatorTest, UnlistedImageAndUnknownKeyAreWarnings) {
  fs::copy_file(Path(kS + "cam0/data/" + ImageOnLine(2)), Path(kS + "cam0/data/extra.png"));
  testing::ReplaceInFile(Path(kS + "imu0/sensor.yaml"), "rate_hz:", "temperature_c: 25\nrate_hz:");
  const ValidationReport report = Validate();
  EXPECT_TRUE(report.ok());
  EXPECT_EQ(Messages(report),
            (std::vector<std::string>{
                "warning: " + kS + "cam0/data/extra.png: image present but not listed in " + kS +
                    "cam0/data.csv",
                "warning: " + kS + "imu0/sensor.yaml:14: unknown key 'temperature_c' (ignored)"}));
  EXPECT_EQ(report.sessions[0].sensors[0].images_unlisted, 1);
}

TEST_F(ValidatorTest, MissingRequiredKeyAndMalformedYamlAreErrors) {
  testing::ReplaceInFile(Path(kS + "gps0/sensor.yaml"), "p_B_antenna", "# p_B_antenna");
  testing::ReplaceInFile(Path(kS + "cam0/sensor.yaml"), "resolution: [", "resolution: [[");
  const ValidationReport report = Validate();
  EXPECT_EQ(report.errors, 2u) << Dump(report);
  const std::vector<std::string> messages = Messages(report);
  EXPECT_EQ(messages[0].rfind("error: " + kS + "cam0/sensor.yaml:", 0), 0u) << Dump(report);
  EXPECT_NE(messages[0].find("malformed YAML"), std::string::npos) << Dump(report);
  EXPECT_EQ(messages[1], "error: " + kS +
                             "gps0/sensor.yaml:2: missing required key "
                             "'p_B_antenna'");
}

TEST_F(ValidatorTest, GapsAndRateOffNominalAreWarnings) {
  std::vector<std::string> lines = testing::ReadLines(Path(kS + "imu0/data.csv"));
  lines.erase(lines.begin() + 100, lines.begin() + 150);  // 50 samples, 0.3 s
  testing::WriteLines(Path(kS + "imu0/data.csv"), lines);
  const ValidationReport report = Validate();
  EXPECT_TRUE(report.ok());
  const std::vector<std::string> messages = Messages(report);
  ASSERT_EQ(messages.size(), 2u) << Dump(report);
  EXPECT_EQ(messages[0].rfind("warning: " + kS + "imu0/data.csv: mean rate 142", 0), 0u)
      << messages[0];
  EXPECT_EQ(messages[1], "warning: " + kS +
                             "imu0/data.csv:101: gap of 305 ms (51.0 sample periods at 167 Hz) "
                             "after line 100");
  EXPECT_EQ(report.sessions[0].sensors[2].gaps, 1);
}

TEST_F(ValidatorTest, FolderWhereAFileIsExpectedIsAnError) {
  fs::remove(Path(kS + "mag0/data.csv"));
  fs::create_directories(Path(kS + "mag0/data.csv"));
  const ValidationReport report = Validate();
  EXPECT_EQ(Messages(report), std::vector<std::string>{"error: " + kS +
                                                       "mag0/data.csv: is a folder, expected a "
                                                       "file"});
}

TEST_F(ValidatorTest, ReportsEveryProblemNotOnlyTheFirst) {
  testing::ReplaceLine(Path(kS + "imu0/data.csv"), 10, "x,0,0,0,0,0,0");
  testing::ReplaceLine(Path(kS + "imu0/data.csv"), 20, "1,2,3");
  testing::ReplaceInFile(Path(kS + "imu0/sensor.yaml"), "gyroscope_random_walk", "gyro_rw");
  fs::remove(Path(kS + "cam0/data/" + ImageOnLine(9)));
  testing::WriteText(Path("field.yaml"), "name: [unclosed\n");
  const ValidationReport report = Validate();
  EXPECT_EQ(report.errors, 5u) << Dump(report);
  EXPECT_EQ(report.warnings, 1u) << Dump(report);  // the unknown key gyro_rw
}

TEST_F(ValidatorTest, MissingFolderAndSessionWithoutCamera) {
  const ValidationReport missing = ValidateField(dir_ / "nope");
  EXPECT_EQ(Messages(missing),
            std::vector<std::string>{"error: " + (dir_ / "nope") + ": field folder not found"});
  fs::remove_all(Path(kS + "cam0"));
  const ValidationReport report = Validate();
  EXPECT_EQ(Messages(report),
            std::vector<std::string>{"warning: sessions/2016-05-25: session has no camera "
                                     "(cam0/): no images to reconstruct from"});
  EXPECT_TRUE(report.ok());  // an IMU + GNSS session is legitimate (crop4d import)
}

TEST_F(ValidatorTest, JsonReportHoldsSummaryAndDiagnostics) {
  testing::ReplaceLine(Path(kS + "imu0/data.csv"), 17, "1464184800095808383,0,0,0,1");
  const nlohmann::json json = nlohmann::json::parse(ValidationReportJson(Validate()));
  EXPECT_FALSE(json["ok"].get<bool>());
  EXPECT_EQ(json["errors"].get<int>(), 1);
  EXPECT_EQ(json["sessions"][0]["sensors"][2]["samples"].get<int>(), 334);
  EXPECT_EQ(json["sessions"][0]["sensors"][1]["fix_counts"]["rtk-fixed"].get<int>(), 10);
  EXPECT_EQ(json["diagnostics"][0]["file"].get<std::string>(), kS + "imu0/data.csv");
  EXPECT_EQ(json["diagnostics"][0]["line"].get<int>(), 17);
  EXPECT_EQ(json["diagnostics"][0]["message"].get<std::string>(), "expected 7 columns, found 5");
}

TEST_F(ValidatorTest, AReceiverWithoutASingleFixDegradesTheSession) {
  // gps0's fix column all 0: the file is well formed, but the receiver gives no position.
  std::vector<std::string> lines = testing::ReadLines(Path(kS + "gps0/data.csv"));
  for (std::string& line : lines) {
    if (!line.empty() && line[0] != '#') line = line.substr(0, line.rfind(',')) + ",0";
  }
  testing::WriteLines(Path(kS + "gps0/data.csv"), lines);
  const ValidationReport report = Validate();
  EXPECT_TRUE(report.ok());
  EXPECT_TRUE(Contains(report, "warning: " + kS +
                                   "gps0/data.csv: gps0 has no fix in any of its 11 samples (fix "
                                   "column 0): it gives no position"))
      << Dump(report);
  ASSERT_EQ(report.sessions[0].degradations.size(), 1u);
  EXPECT_NE(FormatValidationSummary(report).find("  degraded: gps0 has no fix"), std::string::npos);
  const nlohmann::json json = nlohmann::json::parse(ValidationReportJson(report));
  EXPECT_EQ(json["sessions"][0]["degradations"][0], report.sessions[0].degradations[0]);
}

TEST(ValidatorFieldTest, ASensorThatTheOtherSessionsHaveIsMissing) {
  TempDir dir;
  SampleFieldOptions options;
  options.sessions = {"2016-05-25", "2016-06-01", "2016-06-08"};
  WriteSampleField(dir.path(), options);
  fs::remove_all(dir / "sessions/2016-06-01/gps0");
  ValidateOptions vo;
  vo.progress = false;
  const ValidationReport report = ValidateField(dir.path(), vo);
  EXPECT_TRUE(report.ok());
  ASSERT_EQ(report.sessions.size(), 3u);
  EXPECT_TRUE(report.sessions[0].degradations.empty());
  EXPECT_TRUE(report.sessions[2].degradations.empty());
  EXPECT_EQ(report.sessions[1].degradations,
            std::vector<std::string>{"no gps0/ (gps), which 2 of the other 2 sessions have: "
                                     "processed without it"});
  bool warned = false;
  for (const Diagnostic& d : report.diagnostics) {
    warned = warned || (d.severity == Severity::kWarning && d.file == "sessions/2016-06-01" &&
                        d.message.find("no gps0/") == 0);
  }
  EXPECT_TRUE(warned);
  // A sensor that only one of the three sessions has is an extra: nobody lacks it.
  fs::remove_all(dir / "sessions/2016-05-25/mag0");
  fs::remove_all(dir / "sessions/2016-06-08/mag0");
  const ValidationReport extra = ValidateField(dir.path(), vo);
  EXPECT_TRUE(extra.sessions[0].degradations.empty());
  EXPECT_EQ(extra.sessions[1].degradations.size(), 1u);
}

TEST(ValidatorNameTest, NamesThatAnOutputCannotHold) {
  EXPECT_EQ(NameProblem("2016-06-10"), "");
  EXPECT_EQ(NameProblem("2016-06-10 fr\xc3\xbch"), "");  // spaces and Unicode are fine
  EXPECT_EQ(NameProblem("a,b"), "the name contains ',', which the CSV outputs cannot hold");
  EXPECT_NE(NameProblem("say \"hi\""), "");
  EXPECT_NE(NameProblem("a/b"), "");
  EXPECT_NE(NameProblem("a\\b"), "");
  EXPECT_EQ(NameProblem("line\nbreak"), "the name contains the control character 0x0a");
  EXPECT_EQ(NameProblem(""), "the name is empty");
}

TEST(ValidatorFieldTest, ASessionNamedWithACommaIsAnError) {
  TempDir dir;
  SampleFieldOptions options;
  options.sessions = {"2016-05-25", "2016-06-01, evening"};
  WriteSampleField(dir.path(), options);
  ValidateOptions vo;
  vo.progress = false;
  const ValidationReport report = ValidateField(dir.path(), vo);
  EXPECT_FALSE(report.ok());
  ASSERT_EQ(report.sessions.size(), 2u);
  EXPECT_EQ(report.sessions[0].name_problem, "");
  EXPECT_EQ(report.sessions[1].name_problem,
            "the name contains ',', which the CSV outputs cannot hold");
  bool named = false;
  for (const Diagnostic& d : report.diagnostics) {
    named = named || (d.severity == Severity::kError &&
                      d.message.find("session '2016-06-01, evening'") == 0);
  }
  EXPECT_TRUE(named);
}

}  // namespace
}  // namespace crop4d::io
