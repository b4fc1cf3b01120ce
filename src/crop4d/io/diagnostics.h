#pragma once

// Problems found while reading a dataset, each with the file, the line and what is wrong.
//
// Readers take a `Diagnostics*`. With a collector, they report every problem into it and carry
// on (the validator uses this to list everything, not only the first problem). Without one
// (nullptr), data problems are logged as warnings and the bad sample is skipped, while
// problems in metadata (YAML) throw InputError, since nothing useful can be computed then.

#include <cstdint>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <tuple>
#include <vector>

namespace crop4d::io {

enum class Severity { kWarning, kError };

struct Diagnostic {
  Severity severity = Severity::kError;
  std::string file;       // as reported, or relative to Options::root
  std::int64_t line = 0;  // 1-based; 0 = the whole file
  std::string message;

  // "error: sessions/s1/imu0/data.csv:17: expected 7 columns, found 5".
  std::string ToString() const;
};

const char* SeverityName(Severity severity);

// Thread-safe collector of diagnostics.
class Diagnostics {
 public:
  struct Options {
    // Paths below this folder are stored relative to it ("sessions/s1/imu0/data.csv").
    std::string root;
    // Also log every new item through spdlog (warnings at warn level, errors at error level).
    bool log = false;
    // Keep at most this many items per file; later ones are only counted (0 = no limit).
    std::size_t max_items_per_file = 1000;
    // With `log`, log at most this many items per file (0 = no limit).
    std::size_t max_logged_per_file = 20;
  };

  Diagnostics() : Diagnostics(Options()) {}
  explicit Diagnostics(Options options);

  void Error(const std::string& file, std::int64_t line, const std::string& message);
  void Warning(const std::string& file, std::int64_t line, const std::string& message);
  // Adds an item. An exact repeat of an item already present is ignored.
  void Add(Diagnostic diagnostic);

  // Every item kept, in the order reported.
  std::vector<Diagnostic> items() const;
  // Counts include the items that were only counted (over max_items_per_file).
  std::size_t error_count() const;
  std::size_t warning_count() const;
  bool HasErrors() const { return error_count() > 0; }
  // Items counted but not kept, per file.
  std::map<std::string, std::size_t> suppressed() const;

  // The path as it is stored: relative to the root when below it.
  std::string DisplayPath(const std::string& file) const;

 private:
  Options options_;
  mutable std::mutex mutex_;
  std::vector<Diagnostic> items_;
  std::set<std::tuple<int, std::string, std::int64_t, std::string>> seen_;
  std::map<std::string, std::size_t> per_file_;
  std::map<std::string, std::size_t> suppressed_;
  std::size_t errors_ = 0, warnings_ = 0;
};

}  // namespace crop4d::io
