#include "crop4d/io/csv.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

TEST(CsvTest, SplitTrimsBlanksAndCarriageReturn) {
  std::vector<std::string_view> fields;
  SplitCsvLine(" 1, 2 ,\t3\r", ',', &fields);
  ASSERT_EQ(fields.size(), 3u);
  EXPECT_EQ(fields[0], "1");
  EXPECT_EQ(fields[1], "2");
  EXPECT_EQ(fields[2], "3");
  SplitCsvLine("a,,", ',', &fields);
  ASSERT_EQ(fields.size(), 3u);
  EXPECT_EQ(fields[1], "");
  EXPECT_EQ(fields[2], "");
}

TEST(CsvTest, ParseNumbersStrictly) {
  std::int64_t i = 0;
  EXPECT_TRUE(ParseInt64("1464184800000000000", &i));
  EXPECT_EQ(i, 1464184800000000000);
  EXPECT_TRUE(ParseInt64("-5", &i));
  EXPECT_EQ(i, -5);
  EXPECT_TRUE(ParseInt64("+7", &i));
  EXPECT_EQ(i, 7);
  for (const char* bad : {"", "+", "1.0", "12a", "0x10", "1e9", "99999999999999999999", "++1"}) {
    EXPECT_FALSE(ParseInt64(bad, &i)) << bad;
  }
  double d = 0;
  EXPECT_TRUE(ParseDouble("-1.5e-3", &d));
  EXPECT_EQ(d, -1.5e-3);
  EXPECT_TRUE(ParseDouble("+2", &d));
  EXPECT_EQ(d, 2.0);
  EXPECT_TRUE(ParseDouble("nan", &d));
  EXPECT_TRUE(std::isnan(d));
  EXPECT_TRUE(ParseDouble("-inf", &d));
  EXPECT_TRUE(std::isinf(d) && d < 0);
  EXPECT_TRUE(ParseDouble("1e999", &d));
  EXPECT_TRUE(std::isinf(d));
  EXPECT_TRUE(ParseDouble("1e-999", &d));
  EXPECT_EQ(d, 0.0);
  for (const char* bad : {"", "+", "abc", "1.0.0", "1,5", "--1", "+-1", "0x1p3", "1e"}) {
    EXPECT_FALSE(ParseDouble(bad, &d)) << bad;
  }
}

TEST(CsvTest, ReaderKeepsHeaderSkipsCommentsAndBlankLinesAndCountsLines) {
  std::istringstream in("#timestamp [ns],x\n1,2\n\n# a comment\n3,4\r\n5,6");
  CsvReader reader(in, "mem.csv");
  CsvRecord record;
  ASSERT_TRUE(reader.Next(&record));
  ASSERT_TRUE(reader.header().has_value());
  EXPECT_EQ(*reader.header(), "timestamp [ns],x");
  EXPECT_EQ(reader.header_line(), 1);
  EXPECT_EQ(record.line, 2);
  EXPECT_EQ(record.fields[1], "2");
  EXPECT_FALSE(record.unterminated);
  ASSERT_TRUE(reader.Next(&record));
  EXPECT_EQ(record.line, 5);
  EXPECT_EQ(record.fields[1], "4");
  ASSERT_TRUE(reader.Next(&record));
  EXPECT_EQ(record.line, 6);
  EXPECT_TRUE(record.unterminated);
  EXPECT_FALSE(reader.Next(&record));
  EXPECT_EQ(reader.lines_read(), 6);
}

TEST(CsvTest, OverlongLineIsFlaggedNotStored) {
  std::string text = "1,2\n" + std::string(200, 'x') + "\n3,4\n";
  std::istringstream in(text);
  CsvReader::Options options;
  options.max_line_length = 50;
  CsvReader reader(in, "mem.csv", options);
  CsvRecord record;
  ASSERT_TRUE(reader.Next(&record));
  EXPECT_FALSE(reader.too_long());
  ASSERT_TRUE(reader.Next(&record));
  EXPECT_TRUE(reader.too_long());
  EXPECT_TRUE(record.fields.empty());
  EXPECT_EQ(record.line, 2);
  ASSERT_TRUE(reader.Next(&record));
  EXPECT_EQ(record.line, 3);
  EXPECT_EQ(record.fields[0], "3");
}

TEST(CsvTest, MissingFileAndFolderThrowWithTheFileName) {
  testing::TempDir dir;
  try {
    CsvReader reader(dir / "nope.csv");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir / "nope.csv");
    EXPECT_EQ(e.message(), "file not found");
  }
  try {
    CsvReader reader(dir.path());
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.message(), "is a folder, expected a file");
  }
}

}  // namespace
}  // namespace crop4d::io
