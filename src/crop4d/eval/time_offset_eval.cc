#include "crop4d/eval/time_offset_eval.h"

#include <fmt/format.h>

#include <charconv>
#include <fstream>

#include "crop4d/core/error.h"

namespace crop4d::eval {
namespace {

// The integer of `text` between `begin` and the next comma (or the end); false when malformed.
bool ParseField(const std::string& text, std::size_t* begin, Timestamp* value) {
  const std::size_t end = std::min(text.find(',', *begin), text.size());
  const char* first = text.data() + *begin;
  const char* last = text.data() + end;
  const auto [ptr, ec] = std::from_chars(first, last, *value);
  if (ec != std::errc() || ptr != last || first == last) return false;
  *begin = end + 1;
  return true;
}

}  // namespace

std::map<Timestamp, Timestamp> ReadCaptureInstants(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot be read");
  std::map<Timestamp, Timestamp> captures;
  std::string text;
  int line = 0;
  while (std::getline(in, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.empty() || text.front() == '#') continue;
    std::size_t at = 0;
    Timestamp stamp = 0, capture = 0;
    if (!ParseField(text, &at, &stamp) || at > text.size() || !ParseField(text, &at, &capture)) {
      throw InputError(path, line, "expected 'stamp [ns],capture [ns],...' with integer times");
    }
    if (!captures.emplace(stamp, capture).second) {
      throw InputError(path, line, fmt::format("stamp {} appears twice", stamp));
    }
  }
  return captures;
}

std::optional<double> TrueTimeOffset(const std::vector<Timestamp>& stamps,
                                     const std::map<Timestamp, Timestamp>& captures) {
  double sum = 0.0;
  int count = 0;
  for (const Timestamp t : stamps) {
    const auto it = captures.find(t);
    if (it == captures.end()) continue;
    sum += TimestampToSeconds(it->second - it->first);
    ++count;
  }
  if (count == 0) return std::nullopt;
  return sum / count;
}

}  // namespace crop4d::eval
