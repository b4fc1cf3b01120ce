// The analysis tables: exact bytes of the writers, read back to the same bytes, and every kind
// of bad file (another schema, another header, truncated, malformed rows) an InputError naming
// the file and line.

#include "crop4d/workspace/analysis_tables.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "crop4d/core/error.h"

namespace crop4d::workspace {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<SiteHeight> Heights(const std::string& text) {
  std::istringstream in(text);
  return ReadSiteHeights(in, "WS/site_heights.csv");
}
std::vector<SitePlantRow> Plants(const std::string& text) {
  std::istringstream in(text);
  return ReadSitePlants(in, "WS/site_plants.csv");
}
GrowthTable Growth(const std::string& text) {
  std::istringstream in(text);
  return ReadGrowth(in, "WS/growth.csv");
}

// The InputError of `read`; fails when there is none.
template <typename Read>
InputError ErrorOf(Read&& read) {
  try {
    read();
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError";
  return InputError("none");
}

constexpr char kHeights[] =
    "site_id,session,date,height_m,cover,volume_m3,n_points\n"
    "a,s1,2016-06-01,0.1235,0.250,0.00120,120\n"
    "a,s2,2016-06-15,,,,0\n";

TEST(AnalysisTablesTest, SiteHeightsAreWrittenAsAnalyzeWritesThemAndReadBackToTheSameBytes) {
  SiteHeight a{"a", "s1", "2016-06-01", 0.12351, 0.25, 0.0012, 120};
  SiteHeight b{"a", "s2", "2016-06-15", kNaN, kNaN, kNaN, 0};
  EXPECT_EQ(SiteHeightsText({a, b}), kHeights);
  const std::vector<SiteHeight> rows = Heights(kHeights);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].site_id, "a");
  EXPECT_EQ(rows[0].date, "2016-06-01");
  EXPECT_DOUBLE_EQ(rows[0].height_m, 0.1235);
  EXPECT_DOUBLE_EQ(rows[0].cover, 0.25);
  EXPECT_EQ(rows[0].n_points, 120);
  EXPECT_EQ(rows[0].line, 2);
  EXPECT_TRUE(std::isnan(rows[1].height_m));
  EXPECT_EQ(SiteHeightsText(rows), kHeights);
  EXPECT_EQ(SiteHeightsText({}), "site_id,session,date,height_m,cover,volume_m3,n_points\n");
  EXPECT_TRUE(Heights(SiteHeightsText({})).empty());
}

TEST(AnalysisTablesTest, SitePlantsAndGrowthRoundTrip) {
  const std::string plants =
      "site_id,plant,x_m,y_m,session,date,top_m\n"
      "a,1,1.234,-5.000,s1,2016-06-01,0.1000\n"
      "a,1,1.234,-5.000,s2,2016-06-15,\n";
  const std::vector<SitePlantRow> rows = Plants(plants);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].plant, 1);
  EXPECT_DOUBLE_EQ(rows[0].x_m, 1.234);
  EXPECT_TRUE(std::isnan(rows[1].top_m));
  EXPECT_EQ(SitePlantsText(rows), plants);

  GrowthTable g;
  g.intervals = {GrowthIntervalName("2016-06-01", "2016-06-15"),
                 GrowthIntervalName("2016-06-15", "s_3")};
  GrowthRow fitted{"a", "fitted", 0.5, 0.12, "2016-06-20", 0.015, 0.0021, 3, {0.01, kNaN}};
  GrowthRow few{"b", "too_few_points", kNaN, kNaN, "", kNaN, kNaN, 1, {kNaN, kNaN}};
  g.rows = {fitted, few};
  const std::string text = GrowthText(g);
  EXPECT_EQ(text,
            "site_id,status,asymptote_m,rate_per_day,midpoint_date,max_growth_m_per_day,rmse_m,n,"
            "growth_2016-06-01_2016-06-15_m_per_day,growth_2016-06-15_s_3_m_per_day\n"
            "a,fitted,0.5000,0.12000,2016-06-20,0.01500,0.0021,3,0.01000,\n"
            "b,too_few_points,,,,,,1,,\n");
  const GrowthTable back = Growth(text);
  EXPECT_EQ(back.intervals, g.intervals);
  ASSERT_EQ(back.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(back.rows[0].asymptote_m, 0.5);
  EXPECT_EQ(back.rows[0].midpoint_date, "2016-06-20");
  EXPECT_TRUE(std::isnan(back.rows[0].interval_rates[1]));
  EXPECT_EQ(GrowthText(back), text);
}

TEST(AnalysisTablesTest, AnotherSchemaOrHeaderAsksToRerunAnalyze) {
  const std::string v2 =
      "# crop4d schema 2\n"
      "site_id,session,date,height_m,cover,volume_m3,n_points,extra\n";
  for (const InputError& e : {ErrorOf([&] { Heights(v2); }), ErrorOf([&] { Plants(v2); }),
                              ErrorOf([&] { Growth(v2); })}) {
    EXPECT_NE(std::string(e.what()).find("schema 2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("crop4d analyze"), std::string::npos) << e.what();
    EXPECT_EQ(e.line(), 1);
  }
  // This schema's comment is accepted.
  EXPECT_EQ(Heights(std::string("# crop4d schema 1\n") + kHeights).size(), 2u);
  // A header of another version (or not crop4d's table).
  const InputError e = ErrorOf([] { Heights("site_id,session,height_m\na,s1,0.1\n"); });
  EXPECT_EQ(e.file(), "WS/site_heights.csv");
  EXPECT_EQ(e.line(), 1);
  EXPECT_NE(std::string(e.what()).find("crop4d analyze"), std::string::npos) << e.what();
  EXPECT_NE(std::string(ErrorOf([] { Growth("site_id,status\n"); }).what()).find("header"),
            std::string::npos);
  EXPECT_NE(std::string(
                ErrorOf([] {
                  Growth(
                      "site_id,status,asymptote_m,rate_per_day,midpoint_date,max_growth_m_per_day,"
                      "rmse_m,n,rate_a_b\n");
                }).what())
                .find("header"),
            std::string::npos);
  EXPECT_NE(std::string(ErrorOf([] { Heights(""); }).what()).find("empty file"), std::string::npos);
}

TEST(AnalysisTablesTest, TruncatedAndMalformedRowsNameTheLine) {
  const std::string head = "site_id,session,date,height_m,cover,volume_m3,n_points\n";
  const auto line_of = [&](const std::string& rows, const std::string& what) {
    const InputError e = ErrorOf([&] { Heights(head + rows); });
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    return e.line();
  };
  // Cut short in the middle of a row (an interrupted copy).
  EXPECT_EQ(line_of("a,s1,2016-06-01,0.1,0.2,0.001,1\na,s2,2016-06-", "truncated"), 3);
  EXPECT_EQ(line_of("a,s1,2016-06-01,0.1,0.2\n", "expected 7 fields, found 5"), 2);
  EXPECT_EQ(line_of("a,s1,2016-06-01,tall,0.2,0.001,1\n", "height_m 'tall'"), 2);
  EXPECT_EQ(line_of("a,s1,2016-06-01,nan,0.2,0.001,1\n", "not a finite number"), 2);
  EXPECT_EQ(line_of("a,s1,June,0.1,0.2,0.001,1\n", "YYYY-MM-DD"), 2);
  EXPECT_EQ(line_of("a,,2016-06-01,0.1,0.2,0.001,1\n", "empty session"), 2);
  EXPECT_EQ(line_of("a,s1,2016-06-01,0.1,0.2,0.001,-4\n", "not a count"), 2);
  EXPECT_EQ(line_of("a,s1,,0.1,0.2,0.001,1\na,s1,,0.2,0.2,0.001,1\n", "repeated (first on line 2)"),
            3);

  const std::string plants = "site_id,plant,x_m,y_m,session,date,top_m\n";
  const InputError moved =
      ErrorOf([&] { Plants(plants + "a,1,1.000,2.000,s1,,0.1\na,1,1.500,2.000,s2,,0.2\n"); });
  EXPECT_EQ(moved.line(), 3);
  EXPECT_NE(std::string(moved.what()).find("moved"), std::string::npos) << moved.what();
  EXPECT_EQ(ErrorOf([&] { Plants(plants + "a,0,1,2,s1,,\n"); }).line(), 2);
  EXPECT_EQ(ErrorOf([&] { Plants(plants + "a,1,1,,s1,,\n"); }).line(), 2);
  EXPECT_EQ(ErrorOf([&] { Plants(plants + "a,1,1,2,s1,,\na,1,1,2,s1,,\n"); }).line(), 3);

  const std::string growth =
      "site_id,status,asymptote_m,rate_per_day,midpoint_date,max_growth_m_per_day,rmse_m,n\n";
  EXPECT_EQ(ErrorOf([&] {
              Growth(growth +
                     "a,fitted,0.5,0.1,2016-06-01,0.01,0.001,3\na,fitted,"
                     "0.5,0.1,2016-06-01,0.01,0.001,3\n");
            }).line(),
            3);
  EXPECT_EQ(ErrorOf([&] { Growth(growth + ",fitted,,,,,,0\n"); }).line(), 2);
}

TEST(AnalysisTablesTest, AMissingFileIsNamed) {
  const InputError e =
      ErrorOf([] { ReadSiteHeights(std::filesystem::path("/nonexistent/x.csv")); });
  EXPECT_EQ(e.file(), "/nonexistent/x.csv");
}

}  // namespace
}  // namespace crop4d::workspace
