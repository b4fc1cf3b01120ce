// End-to-end tests of the crop4d binary (`crop4d validate`, the command table and exit codes):
// run the real binary on fields in temp folders and check the exit code and what it prints.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

#include "crop4d/io/sample_field.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::cli {
namespace {

namespace fs = std::filesystem;
using io::testing::Crop4dBinary;
using io::testing::ReadLines;
using io::testing::ReadText;
using io::testing::ReplaceInFile;
using io::testing::ReplaceLine;
using io::testing::RunCommand;
using io::testing::ShellQuote;
using io::testing::TempDir;
using io::testing::WriteText;

const std::string kS = "sessions/2016-05-25/";

using RunResult = io::testing::CommandResult;

RunResult RunCrop4d(const TempDir& dir, const std::string& args) {
  return RunCommand(dir, Crop4dBinary(), args);
}

class ValidateCommandTest : public ::testing::Test {
 public:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(Crop4dBinary())) << Crop4dBinary();
    io::WriteSampleField(field());
  }
  std::string field() const { return dir_ / "field"; }
  std::string Path(const std::string& relative) const { return field() + "/" + relative; }
  RunResult Validate(const std::string& extra = "") {
    return RunCrop4d(dir_, "validate " + ShellQuote(field()) + " " + extra);
  }
  std::string ImageOnLine(int line) const {
    const std::string text = ReadLines(Path(kS + "cam0/data.csv")).at(line - 1);
    return text.substr(text.find(',') + 1);
  }

 protected:
  TempDir dir_;
};

TEST_F(ValidateCommandTest, ValidFieldExitsZeroWithSummary) {
  const RunResult r = Validate();
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("field 'sample field'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("imu0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("0 errors, 0 warnings"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("validate: 0 errors, 0 warnings"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("error:"), std::string::npos) << r.err;
}

struct BadCase {
  const char* name;
  std::function<void(ValidateCommandTest*)> breakit;
  std::string expected;  // in stderr
};

TEST_F(ValidateCommandTest, EachMalformedInputExitsTwoNamingFileAndLine) {
  const std::vector<BadCase> cases = {
      {"wrong column count",
       [](ValidateCommandTest* t) {
         ReplaceLine(t->Path(kS + "imu0/data.csv"), 17, "1464184800095808383,0,0,0,1");
       },
       "error: " + kS + "imu0/data.csv:17: expected 7 columns, found 5"},
      {"non-numeric field",
       [](ValidateCommandTest* t) {
         ReplaceLine(t->Path(kS + "mag0/data.csv"), 4, "1464184800027272727,abc,1,2");
       },
       "error: " + kS + "mag0/data.csv:4: column 2 (m_x): 'abc' is not a number"},
      {"NaN",
       [](ValidateCommandTest* t) {
         ReplaceLine(t->Path(kS + "imu0/data.csv"), 3, "1464184800005988024,0,0,NaN,0,0,9.8");
       },
       "error: " + kS + "imu0/data.csv:3: column 4 (w_z): value is not finite (NaN)"},
      {"unsorted timestamps",
       [](ValidateCommandTest* t) {
         ReplaceLine(t->Path(kS + "imu0/data.csv"), 5, "1,0,0,0,0,0,9.8");
       },
       "error: " + kS + "imu0/data.csv:5: timestamp 1 is"},
      {"empty sensor file",
       [](ValidateCommandTest* t) { WriteText(t->Path(kS + "gps0/data.csv"), ""); },
       "error: " + kS + "gps0/data.csv: empty file"},
      {"missing required key",
       [](ValidateCommandTest* t) {
         ReplaceInFile(t->Path(kS + "imu0/sensor.yaml"), "rate_hz:", "rate:");
       },
       "error: " + kS + "imu0/sensor.yaml:2: missing required key 'rate_hz'"},
      {"malformed yaml",
       [](ValidateCommandTest* t) { WriteText(t->Path("field.yaml"), "name: {oops\n"); },
       "error: field.yaml:"},
      {"missing image",
       [](ValidateCommandTest* t) { fs::remove(t->Path(kS + "cam0/data/" + t->ImageOnLine(6))); },
       "error: " + kS + "cam0/data.csv:6: listed image data/"},
      {"zero-byte png",
       [](ValidateCommandTest* t) {
         WriteText(t->Path(kS + "cam0/data/" + t->ImageOnLine(2)), "");
       },
       "error: " + kS + "cam0/data.csv:2: listed image data/"},
      {"folder instead of file",
       [](ValidateCommandTest* t) {
         fs::remove(t->Path(kS + "imu0/data.csv"));
         fs::create_directories(t->Path(kS + "imu0/data.csv"));
       },
       "error: " + kS + "imu0/data.csv: is a folder, expected a file"},
      {"missing field.yaml", [](ValidateCommandTest* t) { fs::remove(t->Path("field.yaml")); },
       "error: field.yaml: file not found"},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.name);
    fs::remove_all(field());
    io::WriteSampleField(field());
    c.breakit(this);
    const RunResult r = Validate();
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << "expected: " << c.expected << "\n"
                                                         << r.err;
  }
}

TEST_F(ValidateCommandTest, WarningsAloneExitZero) {
  fs::copy_file(Path(kS + "cam0/data/" + ImageOnLine(2)), Path(kS + "cam0/data/stray.png"));
  const RunResult r = Validate();
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: " + kS + "cam0/data/stray.png: image present but not listed"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("validate: 0 errors, 1 warning"), std::string::npos) << r.err;
}

TEST_F(ValidateCommandTest, MissingFolderExitsTwo) {
  const RunResult r = RunCrop4d(dir_, "validate " + ShellQuote(dir_ / "nope"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("error: " + (dir_ / "nope") + ": field folder not found"), std::string::npos)
      << r.err;
}

TEST_F(ValidateCommandTest, JsonReportAndMessageLimit) {
  for (int line : {3, 50, 100}) ReplaceLine(Path(kS + "imu0/data.csv"), line, "bad");
  const RunResult r = Validate("--json " + ShellQuote(dir_ / "report.json") + " --max-messages 2");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("imu0/data.csv:50: expected 7 columns, found 1"), std::string::npos);
  EXPECT_EQ(r.err.find("imu0/data.csv:100:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("note: " + kS + "imu0/data.csv: 1 more problem not shown"),
            std::string::npos)
      << r.err;
  const nlohmann::json json = nlohmann::json::parse(ReadText(dir_ / "report.json"));
  EXPECT_EQ(json["errors"].get<int>(), 3);
  EXPECT_EQ(json["diagnostics"].size(), 3u);
  EXPECT_EQ(json["diagnostics"][2]["line"].get<int>(), 100);
}

TEST_F(ValidateCommandTest, HelpListsTheOptions) {
  const RunResult r = RunCrop4d(dir_, "validate --help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* option : {"FIELD", "--json", "--session", "--decode-images", "--gap-periods",
                             "--rate-tolerance", "--max-messages", "Exit code"}) {
    EXPECT_NE(r.out.find(option), std::string::npos) << option << "\n" << r.out;
  }
}

// The command table and the exit codes of main.cc.
TEST(MainTest, VersionHelpAndUsageErrors) {
  TempDir dir;
  RunResult version = RunCrop4d(dir, "--version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_EQ(version.out.rfind("crop4d ", 0), 0u) << version.out;
  // The version, the commit the binary was built from and the build type (core/build_info.h):
  // "crop4d 0.1.0 (commit 83319cf, Release)", "-dirty" after the hash when the checkout had
  // changes, "unknown" outside a git checkout.
  const std::string build_type =
      std::string(CROP4D_BUILD_TYPE).empty() ? "unspecified" : CROP4D_BUILD_TYPE;
  const std::regex line(R"(crop4d \d+\.\d+\.\d+ \(commit ([0-9a-f]{7,}(-dirty)?|unknown), )" +
                        build_type + R"(\)\n)");
  std::smatch match;
  ASSERT_TRUE(std::regex_match(version.out, match, line)) << version.out;
  // Built from a git checkout (with git at hand): the commit is one of the checkout's.
  const std::string source = CROP4D_SOURCE_DIR;
  if (fs::exists(fs::path(source) / ".git") && std::system("git --version >/dev/null 2>&1") == 0) {
    const std::string commit = match[1].str();
    ASSERT_NE(commit, "unknown") << version.out;
    const std::string hash = commit.substr(0, commit.find('-'));
    EXPECT_EQ(std::system(("git -C " + ShellQuote(source) + " cat-file -e " + hash +
                           "^{commit} 2>/dev/null")
                              .c_str()),
              0)
        << hash << " is not a commit of " << source;
  }

  RunResult help = RunCrop4d(dir, "--help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* command : {"validate", "simulate", "import"}) {
    EXPECT_NE(help.out.find(command), std::string::npos) << command;
    EXPECT_EQ(RunCrop4d(dir, std::string(command) + " --help").exit_code, 0) << command;
  }

  // Usage errors are bad input: exit code 2 with CLI11's message.
  const RunResult no_command = RunCrop4d(dir, "");
  EXPECT_EQ(no_command.exit_code, 2);
  EXPECT_NE(no_command.err.find("subcommand is required"), std::string::npos) << no_command.err;
  EXPECT_EQ(RunCrop4d(dir, "no-such-command").exit_code, 2);
  EXPECT_EQ(RunCrop4d(dir, "validate --no-such-flag x").exit_code, 2);
}

}  // namespace
}  // namespace crop4d::cli
