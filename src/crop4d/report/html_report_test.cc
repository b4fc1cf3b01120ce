#include "crop4d/report/html_report.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/test_helpers.h"
#include "crop4d/io/tum.h"
#include "crop4d/workspace/analysis_summary.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_summary.h"
#include "crop4d/workspace/season_quality.h"
#include "crop4d/workspace/stage_summary.h"

namespace crop4d::report {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using io::testing::ReadText;
using io::testing::TempDir;
using io::testing::WriteText;

const char* kSessions[] = {"2016-06-01", "2016-06-15"};

// A pass along row `row` (x = 0.9 row) with poses every 0.2 m.
void WritePoses(const std::string& path, int row, Timestamp t0) {
  std::vector<io::StampedPose> poses;
  for (int i = 0; i <= 40; ++i) {
    io::StampedPose p;
    p.t = t0 + i * 100'000'000LL;
    p.pose =
        geometry::Rigid3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.9 * row, 0.2 * i, 1.5));
    poses.push_back(p);
  }
  io::WriteTum(path, poses, "test poses");
}

// A ridge of points across row 0 (x = 0) that grows with the session.
void WriteCloud(const std::string& path, double height) {
  io::PlyPointCloud cloud;
  for (int i = -50; i <= 50; ++i) {
    for (int k = 0; k < 5; ++k) {
      const double x = 0.02 * i;
      cloud.points.emplace_back(x, 4.0 + 0.01 * k, height * std::exp(-x * x / 0.02));
    }
  }
  fs::create_directories(fs::path(path).parent_path());
  io::WritePly(path, cloud);
}

// A small hand-written field and workspace of two sessions with every stage's outputs, a
// run.json that skipped one item, and one broken file (WS/dense/2016-06-15.json).
void MakeWorkspace(const TempDir& dir) {
  WriteText(dir / "field/field.yaml",
            "name: \"handmade\"\n"
            "origin: {lat: 31.47, lon: -83.53, alt: 100}\n"
            "rows:\n"
            "  - {index: 0, start: [0, 0], end: [0, 8]}\n"
            "  - {index: 1, start: [0.9, 0], end: [0.9, 8]}\n"
            "sites:\n"
            "  - {id: \"r00s1\", x: 0, y: 4, radius: 0.4}\n"
            "  - {id: \"r01s1\", x: 0.9, y: 4, radius: 0.4}\n"
            "sessions:\n  - \"2016-06-01\"\n  - \"2016-06-15\"\n");
  WriteText(dir / "field/ground_truth/site_measurements.csv",
            "site_id,date,height_m\nr00s1,2016-06-01,0.15\nr01s1,2016-06-15,0.25\n");
  const std::string ws = dir / "ws";
  Timestamp t0 = 1464739200LL * 1'000'000'000LL;
  int s = 0;
  for (const char* session : kSessions) {
    const std::string sd = ws + "/sessions/" + session;
    slam::RowPass pass0, pass1;
    pass0.id = "row00";
    pass0.row = 0;
    pass0.direction = 1;
    pass1.id = "row01";
    pass1.row = 1;
    pass1.direction = -1;
    fs::create_directories(sd);
    workspace::WritePassList(sd + "/passes.csv", {pass0, pass1});
    for (int row = 0; row < 2; ++row) {
      const std::string pd = sd + "/rows/row0" + std::to_string(row);
      fs::create_directories(pd);
      WritePoses(pd + "/poses.tum", row, t0 + row * 10'000'000'000LL);
      json summary = json::parse(
          R"({"session": ")" + std::string(session) + R"(", "pass": "row0)" + std::to_string(row) +
          R"(", "row": )" + std::to_string(row) +
          R"(, "direction": 1, "sensors": "cam+imu+rtk", "images": 41, "fingerprint": "1",
              "back_end": {"converged": true, "landmarks": 500,
              "reprojection_rms_px": 0.45, "rejected_observations": 3,
              "gps_factors": 40}, "cloud": {"points": 900},
              "trust": )" +
          (s == 1 && row == 1 ? R"(["gps_gap", "noise_misfit"])" : "[]") +
          R"(, "seconds": {"total": 12.5}})");
      workspace::PassPriors problem;
      problem.camera = "cam0";
      summary["problem"] = workspace::ToJson(problem);
      workspace::WritePassSummary(pd + "/summary.json", summary);
    }
    WriteCloud(ws + "/fused/" + session + "/sparse.ply", 0.1 + 0.2 * s);
    WritePoses(ws + "/fused/" + session + "/poses.tum", 0, t0);
    t0 += 14LL * 86400 * 1'000'000'000LL;
    ++s;
  }
  WriteText(ws + "/associations/robust/2016-06-01_row00__2016-06-15_row00.json",
            R"({"a": {"session": "2016-06-01", "pass": "row00"},
                "b": {"session": "2016-06-15", "pass": "row00"}, "method": "robust",
                "type": "cross-session same direction", "matches": 321, "image_pairs": 40,
                "landmarks": 900, "surface_points": 800, "projected": 700, "candidates": 600,
                "warped": 500, "upright_b": 0, "alignment_inliers": 0, "alignment_shift_m": 0.0,
                "putative": 400, "prealigned": false, "seconds": 3.25, "fingerprint": "2"})");
  {
    workspace::SeasonQuality quality;
    quality.standard = workspace::Positioning::kRtk;
    quality.sessions = {{"2016-06-01", true, {}},
                        {"2016-06-15",
                         false,
                         {"positioned with a metre-level GPS (cam+imu+gps) while 1 of 2 sessions "
                          "have RTK"}}};
    workspace::WriteSeasonQuality(ws + "/fused/quality.json", quality);
  }
  workspace::WriteFusedSummary(
      ws + "/fused/summary.json",
      json::parse(R"({"sessions": ["2016-06-01", "2016-06-15"], "joint": {"passes": 4,
                "converged": true, "landmarks": 2000, "shared_landmarks": 300,
                "observations": 9000, "cross_observations": 800, "iterations": 12,
                "reprojection_rms_px": 0.41, "initial_cost": 100.0, "final_cost": 50.0,
                "ground_ties": 73, "ground_tie_rms_across_m": 0.1045,
                "ground_tie_rms_vertical_m": 0.0261}, "fingerprint": "3",
                "seconds": {"solve": 4.0, "final_solve": 1.0, "total": 6.5},
                "passes": [{"session": "2016-06-01", "pass": "row00", "images": 41,
                "mean_shift_m": [0.001, 0.002, 0.0], "rotation_change_deg": 0.05}]})"));
  workspace::WriteDenseSummary(ws + "/dense/2016-06-01.json",
                               json::parse(R"({"session": "2016-06-01", "points": 123456,
                "tiles": 80, "poses": 41, "views": 82, "fingerprint": "4",
                "images": {"used": 82, "mean_views_per_tile": 6.5},
                "seconds": {"total": 20.0}})"));
  WriteText(ws + "/dense/2016-06-15.json", "{ this is not json");
  {
    workspace::AnalysisSummary summary;
    summary.seconds = 3.5;
    workspace::AnalysisSessionRecord session;
    session.session = session.date = "2016-06-01";
    session.cloud = "dense/2016-06-01.ply";
    session.points = 123456;
    session.plants = 40;
    session.vegetation_fraction = 0.01;
    summary.sessions = {session};
    summary.site_notes = {{"r01s1", "2016-06-01", "few points on 2016-06-01"}};
    WriteText(ws + "/analysis/summary.json", workspace::AnalysisSummaryJson(summary).dump(2));
  }
  WriteText(ws + "/analysis/site_heights.csv",
            "site_id,session,date,height_m,cover,volume_m3,n_points\n"
            "r00s1,2016-06-01,2016-06-01,0.1234,0.02,0.0006,78\n"
            "r00s1,2016-06-15,2016-06-15,0.2345,0.05,0.002,260\n"
            "r01s1,2016-06-15,2016-06-15,0.2222,0.05,0.002,250\n");
  WriteText(ws + "/analysis/growth.csv",
            "site_id,status,asymptote_m,rate_per_day,midpoint_date,max_growth_m_per_day,rmse_m,n,"
            "growth_2016-06-01_2016-06-15_m_per_day\n"
            "r00s1,fitted,0.45,0.06,2016-06-27,0.0066,0.0013,2,0.00505\n");
  cv::Mat plot(120, 200, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::line(plot, {10, 110}, {190, 10}, cv::Scalar(180, 119, 31), 2);
  fs::create_directories(ws + "/analysis/plots");
  ASSERT_TRUE(cv::imwrite(ws + "/analysis/plots/heights.png", plot));
  WriteText(
      ws + "/eval/metrics.json",
      R"({"crop4d_version": "0.1.0", "overall": {"num_passes": 4, "num_evaluated": 4, "num_poses": 164,
                "ate_raw_m": {"rmse": 0.0087}, "ate_aligned_m": {"rmse": 0.0048},
                "rotation_deg": {"rmse": 0.068}},
                "passes": [{"session": "2016-06-01", "pass": "row00", "sensors": "cam+imu+rtk",
                "error": null, "metrics": {"num_poses": 41, "ate_raw_m": {"rmse": 0.0065}}}],
                "canopy": {"options": {"max_error_m": 0.04}, "ours": {"file":
                "analysis/site_heights.csv", "error": null, "num_pairs": 3, "rmse_m": 0.0213,
                "rmse_interval_m": {"low": 0.0153, "high": 0.0243},
                "bias_m": -0.011, "mae_m": 0.0157, "max_abs_error_m": 0.0508,
                "num_failures": 1}, "plants": {"true": 44, "found": 45, "matched": 42,
                "recall": 0.9545, "precision": 0.9333, "median_stem_offset_m": 0.0177,
                "tops": 168, "top_rmse_m": 0.0224, "top_bias_m": -0.0014, "top_failures": 13}}})");
  WriteText(ws + "/run.json",
            R"({"crop4d_version": "0.1.0", "field": "field", "workspace": "ws",
                "started": "2016-07-20T10:00:00Z", "finished": "2016-07-20T10:30:00Z",
                "complete": false, "threads": 8,
                "stages": [{"name": "validate", "status": "done", "seconds": 1.5, "done": 2,
                "skipped": 0, "failed": 0, "messages": []},
                {"name": "slam", "status": "partial", "seconds": 600.25, "done": 3,
                "skipped": 0, "failed": 1, "messages": ["pass row02 of 2016-06-15 failed"]},
                {"name": "eval", "status": "not run", "seconds": 0, "done": 0, "skipped": 0,
                "failed": 0, "messages": []}],
                "skipped": [{"stage": "slam", "session": "2016-06-15", "item": "row02",
                "reason": "too few images <7>"}]})");
}

bool HasSection(const HtmlReportResult& r, const std::string& id, bool with_data) {
  for (const HtmlReportSection& s : r.sections) {
    if (s.id == id) return s.has_data == with_data;
  }
  return false;
}

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// Every src= and href= of the page: embedded data or an anchor of the page itself.
void ExpectSelfContained(const std::string& html) {
  for (const std::string attr : {"src=\"", "href=\"", "src='", "href='", "url("}) {
    for (std::size_t p = html.find(attr); p != std::string::npos; p = html.find(attr, p + 1)) {
      const std::string value = html.substr(p + attr.size(), 16);
      if (attr.rfind("href", 0) == 0) {
        // The one link out: back to the 4D viewer that serves the report (docs/viewer.md).
        if (value.rfind("../index.html\"", 0) == 0) continue;
        EXPECT_EQ(value[0], '#') << "link out of the page: " << html.substr(p, 80);
      } else {
        EXPECT_EQ(value.rfind("data:", 0), 0u) << "external resource: " << html.substr(p, 80);
      }
    }
  }
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find("@import"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
}

TEST(HtmlReportTest, ReportOfAHandWrittenWorkspace) {
  TempDir dir;
  MakeWorkspace(dir);
  const HtmlReportResult r = WriteHtmlReport(dir / "ws", dir / "field", "", {});
  EXPECT_EQ(r.path, (fs::path(dir / "ws") / "report.html").string());
  const std::string html = ReadText(r.path);
  EXPECT_EQ(html.size(), r.bytes);
  ASSERT_GT(html.size(), 1000u);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("</html>"), std::string::npos);

  for (const char* id : {"run", "skipped", "field-map", "slam", "associations", "fusion", "dense",
                         "cross-section", "heights", "growth", "evaluation"}) {
    EXPECT_TRUE(HasSection(r, id, true)) << id;
    EXPECT_NE(html.find(std::string("<section id=\"") + id + "\">"), std::string::npos) << id;
  }
  // Images embedded: the cross-section figure and the heights plot.
  EXPECT_EQ(Count(html, "src=\"data:image/png;base64,"), 2);
  ExpectSelfContained(html);
  // The map: rows, sites, one trajectory per session, legend and scale bar.
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_EQ(Count(html, "class=\"row\""), 2);
  EXPECT_EQ(Count(html, "class=\"site\""), 2);
  EXPECT_EQ(Count(html, "<g class=\"track\""), 2);
  EXPECT_NE(html.find("class=\"scale\""), std::string::npos);
  EXPECT_NE(html.find("2016-06-15 (fused)"), std::string::npos);
  EXPECT_NE(html.find("73 (10.4 / 2.6)"), std::string::npos);  // the ground ties
  // Run record: stage table, messages, timings; what was skipped, escaped.
  EXPECT_NE(html.find("pass row02 of 2016-06-15 failed"), std::string::npos);
  EXPECT_NE(html.find("10 min 00 s"), std::string::npos);  // 600.25 s of slam
  EXPECT_NE(html.find("too few images &lt;7&gt;"), std::string::npos);
  EXPECT_EQ(html.find("too few images <7>"), std::string::npos);
  // The degraded session, from fused/quality.json.
  EXPECT_NE(html.find("Degraded sessions (WS/fused/quality.json)"), std::string::npos);
  EXPECT_NE(html.find("positioned with a metre-level GPS (cam+imu+gps) while 1 of 2"),
            std::string::npos);
  // The pass whose summary.json has trust flags, with what they mean; no other pass.
  EXPECT_NE(html.find("What row SLAM could not observe"), std::string::npos);
  EXPECT_NE(html.find("gps_gap, noise_misfit"), std::string::npos);
  EXPECT_NE(html.find("misses the GPS fixes by more than 1.5 sigmas"), std::string::npos);
  EXPECT_EQ(Count(html, "gps_gap"), 1);
  // The broken dense summary is named in the page and in the result.
  EXPECT_NE(html.find("WS/dense/2016-06-15.json: not valid JSON"), std::string::npos);
  bool named = false;
  for (const std::string& line : r.skipped) {
    named = named || line.find("dense/2016-06-15.json") != std::string::npos;
  }
  EXPECT_TRUE(named);
  // Statistics of each stage.
  EXPECT_NE(html.find("cross-session same direction"), std::string::npos);
  EXPECT_NE(html.find(">321<"), std::string::npos);
  EXPECT_NE(html.find("123&#8201;456"), std::string::npos);
  // Heights with the measurements, growth, evaluation.
  EXPECT_NE(html.find("0.123"), std::string::npos);
  EXPECT_NE(html.find("meas. 0.150"), std::string::npos);
  EXPECT_NE(html.find("meas. 0.250"), std::string::npos);
  EXPECT_NE(html.find("2016-06-01 &rarr; 2016-06-15 [m/day]"), std::string::npos);
  EXPECT_NE(html.find("few points on 2016-06-01"), std::string::npos);
  EXPECT_NE(html.find(">21.3<"), std::string::npos);             // canopy RMSE in mm
  EXPECT_NE(html.find(">15.3&ndash;24.3<"), std::string::npos);  // its interval over the sites
  EXPECT_NE(html.find("Plants of the sites"), std::string::npos);
  EXPECT_NE(html.find(">95.5 %<"), std::string::npos) << "recall";
  EXPECT_NE(html.find(">22.4<"), std::string::npos);  // plant top RMSE in mm
  // The load/error marker script.
  EXPECT_NE(html.find("data-report-loaded"), std::string::npos);
  EXPECT_NE(html.find("data-js-errors"), std::string::npos);

  // Another output path; the workspace's report.html is left as it was.
  const HtmlReportResult other = WriteHtmlReport(dir / "ws", "", dir / "out/season.html", {});
  EXPECT_TRUE(fs::is_regular_file(dir / "out/season.html"));
  EXPECT_TRUE(HasSection(other, "cross-section", false));  // no field: no rows
  EXPECT_NE(ReadText(dir / "out/season.html").find("no field folder given"), std::string::npos);
}

TEST(HtmlReportTest, EmptyWorkspaceSaysWhatIsMissing) {
  TempDir dir;
  fs::create_directories(dir / "ws");
  const HtmlReportResult r = WriteHtmlReport(dir / "ws", "", "", {});
  const std::string html = ReadText(r.path);
  for (const HtmlReportSection& s : r.sections) {
    EXPECT_FALSE(s.has_data) << s.id;
  }
  EXPECT_NE(html.find("WS/run.json not found"), std::string::npos);
  EXPECT_NE(html.find("Row SLAM has not run"), std::string::npos);
  EXPECT_NE(html.find("No evaluation"), std::string::npos);
  EXPECT_NE(html.find("Nothing to draw"), std::string::npos);
  ExpectSelfContained(html);
  EXPECT_THROW(WriteHtmlReport(dir / "missing", "", "", {}), InputError);
}

TEST(HtmlReportTest, BadInputIsNamedNotFatal) {
  TempDir dir;
  const std::string ws = dir / "ws";
  WritePoses(ws + "/fused/2016-06-01/poses.tum", 0, 1'000'000'000LL);
  WriteText(ws + "/fused/2016-06-01/poses.tum",
            ReadText(ws + "/fused/2016-06-01/poses.tum") + "1.0 not a pose\n");
  WriteText(ws + "/run.json", "[1, 2]");
  WriteText(ws + "/analysis/site_heights.csv",
            "site_id,session,date,height_m,cover,volume_m3,n_points\n"
            "r00s1,2016-06-01,2016-06-01,0.1,,,\nr00s1,oops\n");
  WriteText(ws + "/analysis/plots/heights.png", "not a png");
  WriteText(ws + "/fused/summary.json", "");
  HtmlReportResult r;
  ASSERT_NO_THROW(r = WriteHtmlReport(ws, dir / "no_field_here", "", {}));
  const std::string html = ReadText(r.path);
  const std::string all = [&] {
    std::string text;
    for (const std::string& line : r.skipped) text += line + "\n";
    return text;
  }();
  EXPECT_NE(all.find("WS/fused/2016-06-01/poses.tum:"), std::string::npos) << all;
  EXPECT_NE(all.find("WS/run.json: not a JSON object"), std::string::npos) << all;
  EXPECT_NE(all.find("WS/analysis/site_heights.csv:3: expected 7 fields, found 2"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("heights.png: not a readable PNG"), std::string::npos) << all;
  EXPECT_NE(all.find("WS/fused/summary.json: not valid JSON"), std::string::npos) << all;
  EXPECT_NE(all.find("FIELD/field.yaml"), std::string::npos) << all;
  // Each is listed once in the page.
  EXPECT_EQ(Count(html, "WS/run.json: not a JSON object"), 1);
  EXPECT_TRUE(HasSection(r, "heights", true));  // the valid line is still shown
  EXPECT_TRUE(HasSection(r, "skipped", true));
  ExpectSelfContained(html);
}

TEST(HtmlReportTest, Base64AndEscape) {
  EXPECT_EQ(Base64Encode(""), "");
  EXPECT_EQ(Base64Encode("f"), "Zg==");
  EXPECT_EQ(Base64Encode("fo"), "Zm8=");
  EXPECT_EQ(Base64Encode("foo"), "Zm9v");
  EXPECT_EQ(Base64Encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(Base64Encode(std::string("\xff\x00\x80", 3)), "/wCA");
  EXPECT_EQ(HtmlEscape("a<b>&\"'"), "a&lt;b&gt;&amp;&quot;&#39;");
}

bool HaveChromium() {
  return std::system(
             "command -v chromium >/dev/null 2>&1 || "
             "command -v chromium-browser >/dev/null 2>&1") == 0;
}

int RunCheck(const std::string& args) {
  const std::string command = "REPORT_SCREENSHOT_SIZE=1200,900 " + std::string(CROP4D_SOURCE_DIR) +
                              "/scripts/check-report.sh " + args + " >/dev/null 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The report in a real headless browser (scripts/check-report.sh): it loads, runs its script
// without error and a screenshot is written. A page with a JavaScript error fails the check.
TEST(HtmlReportTest, LoadsInHeadlessChromium) {
  if (!HaveChromium()) {
    GTEST_SKIP() << "chromium is not installed (scripts/install-deps.sh installs it)";
  }
  TempDir dir;
  MakeWorkspace(dir);
  const HtmlReportResult r = WriteHtmlReport(dir / "ws", dir / "field", dir / "report.html", {});
  const std::string shot = dir / "report.png";
  ASSERT_EQ(RunCheck("'" + r.path + "' '" + shot + "'"), 0);
  const cv::Mat image = cv::imread(shot);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 1200);

  // The checker catches a JavaScript error: the report's page with a broken script added.
  std::string broken = ReadText(r.path);
  broken.insert(broken.find("</body>"), "<script>not_a_function();</script>");
  WriteText(dir / "broken.html", broken);
  EXPECT_EQ(RunCheck("'" + (dir / "broken.html") + "'"), 1);
  // And a page that is not a report (no load marker).
  WriteText(dir / "plain.html", "<!DOCTYPE html><html><body>hello</body></html>");
  EXPECT_EQ(RunCheck("'" + (dir / "plain.html") + "'"), 1);
}

}  // namespace
}  // namespace crop4d::report
