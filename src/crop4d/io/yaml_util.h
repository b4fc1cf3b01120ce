#pragma once

// A thin layer over yaml-cpp that reports problems with the file, the line (from yaml-cpp's
// Mark) and the key name, and that notices keys nobody asked for (a typo in a key name is a
// warning, not a silently ignored setting).
//
//   YamlFile file(path, diag);             // throws InputError on a syntax error
//   YamlMap root = file.Root();
//   double rate = 0;
//   root.Get("rate_hz", &rate, YamlMap::kRequired);
//   root.WarnUnknownKeys();
//   file.Finish();                         // throws the first error, if there was one
//
// Every problem goes to the Diagnostics given (with nullptr, warnings are logged); Finish()
// then throws InputError for the first error, so that a caller never gets a half-filled
// struct, and a caller with a collector has every problem listed in it.

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "crop4d/io/diagnostics.h"

namespace crop4d::io {

class YamlMap;

class YamlFile {
 public:
  // Reads and parses `path`. A missing file, a folder, or a syntax error is reported and
  // thrown as InputError right away.
  YamlFile(std::string path, Diagnostics* diag);
  // Parses `text` (tests, fuzzing); `name` stands for the file in messages.
  YamlFile(std::string name, const std::string& text, Diagnostics* diag);

  const std::string& path() const { return path_; }
  const YAML::Node& root() const { return root_; }
  // The top-level map ("expected a map" is reported when the document is something else).
  YamlMap Root();

  void Error(std::int64_t line, const std::string& message);
  void Warning(std::int64_t line, const std::string& message);
  int error_count() const { return error_count_; }

  // Throws InputError with the first error reported, if any.
  void Finish();

 private:
  void Parse(const std::string& text);

  std::string path_;
  Diagnostics* diag_;  // may be null: warnings are logged, errors kept for Finish()
  YAML::Node root_;
  int error_count_ = 0;
  std::vector<std::pair<std::int64_t, std::string>> errors_;  // not yet thrown
};

// 1-based line of a node, or 0 when yaml-cpp has no position for it.
std::int64_t YamlLine(const YAML::Node& node);

// A map node with key tracking. `context` prefixes key names in messages ("origin.lat").
class YamlMap {
 public:
  enum Need { kOptional, kRequired };

  // A non-map `node` is reported ("expected a map") and behaves as an empty map.
  YamlMap(YamlFile* file, YAML::Node node, std::string context, std::int64_t parent_line = 0);

  bool Has(const char* key);
  // Each Get returns true when the key is present and valid, and fills *value. A missing
  // required key or an invalid value is reported as an error; a missing optional key leaves
  // *value unchanged.
  bool Get(const char* key, double* value, Need need);  // finite numbers only
  bool Get(const char* key, int* value, Need need);
  bool Get(const char* key, std::string* value, Need need);
  bool Get(const char* key, bool* value, Need need);
  // A sequence of finite numbers with a size in [min_size, max_size].
  bool Get(const char* key, std::vector<double>* value, std::size_t min_size, std::size_t max_size,
           Need need);
  // A nested map (or nullopt, reported when required).
  std::optional<YamlMap> GetMap(const char* key, Need need);
  // A nested sequence (or an undefined node, reported when required or not a sequence).
  YAML::Node GetSequence(const char* key, Need need);

  // Reports a warning for each key that none of the calls above asked for.
  void WarnUnknownKeys();

  std::int64_t line() const { return line_; }
  // Line of `key`'s value, or of the map when absent.
  std::int64_t LineOf(const char* key) const;
  // "origin.lat" for key "lat" in context "origin".
  std::string KeyName(const char* key) const;
  YamlFile* file() { return file_; }

 private:
  YAML::Node Lookup(const char* key, Need need);

  YamlFile* file_;
  YAML::Node node_;
  std::string context_;
  std::int64_t line_;
  std::set<std::string> used_;
};

// Parses a YAML scalar as a number, accepting YAML's ".nan", ".inf", "-.inf" spellings.
bool ParseYamlDouble(const std::string& text, double* value);

}  // namespace crop4d::io
