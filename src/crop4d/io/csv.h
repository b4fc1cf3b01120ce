#pragma once

// A streaming reader of comma-separated text that knows where it is: every record carries its
// 1-based line number, so that every problem can be reported as "file:line: what". Lines are
// read one at a time; the file is never held in memory.
//
//   CsvReader reader(path);            // throws InputError when the file cannot be opened
//   CsvRecord record;
//   while (reader.Next(&record)) { ... record.fields[i] ..., record.line ... }
//
// Blank lines are skipped. A line whose first non-blank character is '#' is a comment; the
// first such line before any data is kept as the header (EuRoC's "#timestamp [ns],...").
// Fields are trimmed of spaces, tabs and a trailing '\r' (files written on Windows).

#include <cstdint>
#include <fstream>
#include <istream>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace crop4d::io {

struct CsvRecord {
  std::int64_t line = 0;                 // 1-based line number in the file
  std::vector<std::string_view> fields;  // views into the reader's line buffer, valid until
                                         // the next call of Next()
  bool unterminated = false;             // the last line of the file, without a final newline
};

class CsvReader {
 public:
  struct Options {
    // Field separator.
    char delimiter = ',';
    // Lines longer than this many bytes are returned with no fields and `too_long` set in
    // the reader; guards against binary files read by mistake.
    std::size_t max_line_length = 1 << 16;
  };

  // Opens `path`. Throws InputError naming the path when it does not exist, is a folder or
  // cannot be read.
  explicit CsvReader(const std::string& path) : CsvReader(path, Options()) {}
  CsvReader(const std::string& path, Options options);
  // Reads from a stream (tests, fuzzing); `name` stands for the file in messages.
  CsvReader(std::istream& in, std::string name) : CsvReader(in, std::move(name), Options()) {}
  CsvReader(std::istream& in, std::string name, Options options);
  CsvReader(const CsvReader&) = delete;
  CsvReader& operator=(const CsvReader&) = delete;

  // Next data record; false at the end of the input.
  bool Next(CsvRecord* record);

  const std::string& name() const { return name_; }
  // Header comment text after the '#', when the first non-blank line was a comment.
  const std::optional<std::string>& header() const { return header_; }
  // Line number of the header (0 when there is none).
  std::int64_t header_line() const { return header_line_; }
  // Number of lines read so far.
  std::int64_t lines_read() const { return line_number_; }
  // Whether the record last returned came from a line over Options::max_line_length (its
  // `fields` are then empty).
  bool too_long() const { return too_long_; }

 private:
  Options options_;
  std::string name_;
  std::ifstream file_;
  std::istream* in_ = nullptr;
  std::string line_;
  std::optional<std::string> header_;
  std::int64_t header_line_ = 0;
  std::int64_t line_number_ = 0;
  bool seen_data_ = false;
  bool too_long_ = false;
};

// Splits `line` at `delimiter` and trims each field of blanks (' ', '\t', '\r').
void SplitCsvLine(std::string_view line, char delimiter, std::vector<std::string_view>* fields);

// Strict number parsing of a whole (already trimmed) field: no leading/trailing junk, no
// empty text. ParseDouble accepts "nan" and "inf" (callers check finiteness) and a leading
// '+'; ParseInt64 accepts an optional sign and decimal digits only.
bool ParseInt64(std::string_view text, std::int64_t* value);
bool ParseDouble(std::string_view text, double* value);

}  // namespace crop4d::io
