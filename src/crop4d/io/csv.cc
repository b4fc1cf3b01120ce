#include "crop4d/io/csv.h"

#include <cerrno>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "crop4d/core/error.h"

namespace crop4d::io {
namespace {

std::string_view Trim(std::string_view text) {
  std::size_t begin = 0, end = text.size();
  while (begin < end && (text[begin] == ' ' || text[begin] == '\t' || text[begin] == '\r')) {
    ++begin;
  }
  while (end > begin && (text[end - 1] == ' ' || text[end - 1] == '\t' || text[end - 1] == '\r')) {
    --end;
  }
  return text.substr(begin, end - begin);
}

}  // namespace

CsvReader::CsvReader(const std::string& path, Options options) : options_(options), name_(path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) {
    throw InputError(path, 0, "file not found");
  }
  if (std::filesystem::is_directory(status)) {
    throw InputError(path, 0, "is a folder, expected a file");
  }
  file_.open(path, std::ios::binary);
  if (!file_) {
    throw InputError(path, 0, std::string("cannot open: ") + std::strerror(errno));
  }
  in_ = &file_;
}

CsvReader::CsvReader(std::istream& in, std::string name, Options options)
    : options_(options), name_(std::move(name)), in_(&in) {}

bool CsvReader::Next(CsvRecord* record) {
  while (true) {
    line_.clear();
    // getline with a length guard: stop storing once over the limit, but consume the line.
    bool got_any = false;
    bool terminated = false;
    too_long_ = false;
    std::streambuf* buf = in_->rdbuf();
    while (true) {
      const int c = buf->sbumpc();
      if (c == std::char_traits<char>::eof()) break;
      got_any = true;
      if (c == '\n') {
        terminated = true;
        break;
      }
      if (line_.size() < options_.max_line_length) {
        line_.push_back(static_cast<char>(c));
      } else {
        too_long_ = true;
      }
    }
    if (!got_any) return false;
    ++line_number_;
    const std::string_view trimmed = Trim(line_);
    if (trimmed.empty() && !too_long_) continue;
    if (!too_long_ && trimmed.front() == '#') {
      if (!seen_data_ && !header_) {
        header_ = std::string(Trim(trimmed.substr(1)));
        header_line_ = line_number_;
      }
      continue;
    }
    seen_data_ = true;
    record->line = line_number_;
    record->unterminated = !terminated;
    record->fields.clear();
    if (!too_long_) SplitCsvLine(line_, options_.delimiter, &record->fields);
    return true;
  }
}

void SplitCsvLine(std::string_view line, char delimiter, std::vector<std::string_view>* fields) {
  fields->clear();
  std::size_t start = 0;
  while (true) {
    const std::size_t end = line.find(delimiter, start);
    if (end == std::string_view::npos) {
      fields->push_back(Trim(line.substr(start)));
      return;
    }
    fields->push_back(Trim(line.substr(start, end - start)));
    start = end + 1;
  }
}

bool ParseInt64(std::string_view text, std::int64_t* value) {
  if (text.empty()) return false;
  if (text.front() == '+') text.remove_prefix(1);
  if (text.empty() || text.front() == '+') return false;
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, *value);
  return result.ec == std::errc() && result.ptr == end;
}

bool ParseDouble(std::string_view text, double* value) {
  if (!text.empty() && text.front() == '+') {
    text.remove_prefix(1);
    if (!text.empty() && text.front() == '-') return false;  // "+-1"
  }
  if (text.empty() || text.front() == '+') return false;
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, *value, std::chars_format::general);
  if (result.ptr != end) return false;
  if (result.ec == std::errc::result_out_of_range) {
    // "1e999" or "1e-999": from_chars leaves the value alone; strtod gives ±HUGE_VAL or 0,
    // so that an overflow is rejected as non-finite by the caller, not as text.
    const std::string copy(text);
    *value = std::strtod(copy.c_str(), nullptr);
    return true;
  }
  return result.ec == std::errc();
}

}  // namespace crop4d::io
