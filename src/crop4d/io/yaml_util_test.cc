#include "crop4d/io/yaml_util.h"

#include <gtest/gtest.h>

#include "crop4d/core/error.h"

namespace crop4d::io {
namespace {

std::vector<std::string> Messages(const Diagnostics& diag) {
  std::vector<std::string> out;
  for (const Diagnostic& d : diag.items()) out.push_back(d.ToString());
  return out;
}

TEST(YamlUtilTest, SyntaxErrorThrowsWithLine) {
  Diagnostics diag;
  try {
    YamlFile file("x.yaml", "a: 1\nb: [1, 2\nc: 3\n", &diag);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "x.yaml");
    EXPECT_GE(e.line(), 2);
    EXPECT_EQ(e.message().rfind("malformed YAML: ", 0), 0u) << e.message();
  }
  ASSERT_EQ(diag.error_count(), 1u);
}

TEST(YamlUtilTest, ReportsEveryMissingKeyWrongTypeAndUnknownKeyWithLines) {
  Diagnostics diag;
  YamlFile file("s.yaml",
                "rate_hz: abc\n"
                "resolution: [640]\n"
                "typo_key: 3\n"
                "nested:\n"
                "  lat: .nan\n",
                &diag);
  YamlMap root = file.Root();
  double rate = 7.5;
  EXPECT_FALSE(root.Get("rate_hz", &rate, YamlMap::kRequired));
  EXPECT_EQ(rate, 7.5);
  std::vector<double> resolution;
  EXPECT_FALSE(root.Get("resolution", &resolution, 2, 2, YamlMap::kRequired));
  std::vector<double> intrinsics;
  EXPECT_FALSE(root.Get("intrinsics", &intrinsics, 4, 4, YamlMap::kRequired));
  std::optional<YamlMap> nested = root.GetMap("nested", YamlMap::kRequired);
  ASSERT_TRUE(nested.has_value());
  double lat = 0;
  EXPECT_FALSE(nested->Get("lat", &lat, YamlMap::kRequired));
  EXPECT_FALSE(nested->Get("lon", &lat, YamlMap::kRequired));
  root.WarnUnknownKeys();
  EXPECT_EQ(Messages(diag), (std::vector<std::string>{
                                "error: s.yaml:1: key 'rate_hz': expected a number, found 'abc'",
                                "error: s.yaml:2: key 'resolution': expected 2 numbers, found 1",
                                "error: s.yaml:1: missing required key 'intrinsics'",
                                "error: s.yaml:5: key 'nested.lat': value is not finite (.nan)",
                                "error: s.yaml:5: missing required key 'nested.lon'",
                                "warning: s.yaml:3: unknown key 'typo_key' (ignored)"}));
  try {
    file.Finish();
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "s.yaml:1: key 'rate_hz': expected a number, found 'abc'");
  }
}

TEST(YamlUtilTest, ReadsValuesOfEveryType) {
  Diagnostics diag;
  YamlFile file("ok.yaml",
                "n: 3\nx: -1.5e-3\ns: hello world\nb: true\nv: [1, 2.5, -3]\nm: {k: 1}\n"
                "empty:\n",
                &diag);
  YamlMap root = file.Root();
  int n = 0;
  double x = 0;
  std::string s;
  bool b = false;
  std::vector<double> v;
  EXPECT_TRUE(root.Get("n", &n, YamlMap::kRequired));
  EXPECT_TRUE(root.Get("x", &x, YamlMap::kRequired));
  EXPECT_TRUE(root.Get("s", &s, YamlMap::kRequired));
  EXPECT_TRUE(root.Get("b", &b, YamlMap::kRequired));
  EXPECT_TRUE(root.Get("v", &v, 1, 5, YamlMap::kRequired));
  EXPECT_FALSE(root.Get("missing", &x, YamlMap::kOptional));
  EXPECT_FALSE(root.Get("empty", &x, YamlMap::kOptional));
  std::optional<YamlMap> m = root.GetMap("m", YamlMap::kRequired);
  ASSERT_TRUE(m.has_value());
  int k = 0;
  EXPECT_TRUE(m->Get("k", &k, YamlMap::kRequired));
  m->WarnUnknownKeys();
  root.WarnUnknownKeys();
  EXPECT_EQ(n, 3);
  EXPECT_EQ(x, -1.5e-3);
  EXPECT_EQ(s, "hello world");
  EXPECT_TRUE(b);
  EXPECT_EQ(v, (std::vector<double>{1, 2.5, -3}));
  EXPECT_EQ(k, 1);
  EXPECT_TRUE(Messages(diag).empty()) << Messages(diag)[0];
  EXPECT_NO_THROW(file.Finish());
}

TEST(YamlUtilTest, EmptyDocumentAndNonMapRootAreErrors) {
  Diagnostics diag;
  YamlFile empty("e.yaml", "", &diag);
  empty.Root();
  YamlFile list("l.yaml", "- 1\n- 2\n", &diag);
  list.Root();
  EXPECT_EQ(Messages(diag),
            (std::vector<std::string>{"error: e.yaml: the file: expected a map of keys, found "
                                      "nothing",
                                      "error: l.yaml:1: the file: expected a map of keys, found "
                                      "a list"}));
  EXPECT_THROW(empty.Finish(), InputError);
}

TEST(YamlUtilTest, MissingFileAndFolderThrow) {
  EXPECT_THROW(YamlFile("/nonexistent/crop4d/x.yaml", nullptr), InputError);
  try {
    YamlFile file("/tmp", nullptr);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "/tmp: is a folder, expected a file");
  }
}

}  // namespace
}  // namespace crop4d::io
