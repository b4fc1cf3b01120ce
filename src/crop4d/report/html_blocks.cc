#include "crop4d/report/html_blocks.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <sstream>

#include "crop4d/io/csv.h"
#include "crop4d/report/html_report.h"

namespace crop4d::report::html {

std::string E(const std::string& s) { return HtmlEscape(s); }

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

bool IsDir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

std::vector<fs::path> ListDir(const fs::path& dir, bool folders) {
  std::vector<fs::path> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code ec2;
    if (folders ? it->is_directory(ec2) : it->is_regular_file(ec2)) out.push_back(it->path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::optional<std::string> ReadBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) return std::nullopt;
  return s.str();
}

const json* At(const json& j, std::initializer_list<const char*> keys) {
  const json* v = &j;
  for (const char* k : keys) {
    if (!v->is_object()) return nullptr;
    auto it = v->find(k);
    if (it == v->end()) return nullptr;
    v = &*it;
  }
  return v;
}

std::optional<double> Num(const json& j, std::initializer_list<const char*> keys) {
  const json* v = At(j, keys);
  if (v == nullptr || !v->is_number()) return std::nullopt;
  const double d = v->get<double>();
  if (!std::isfinite(d)) return std::nullopt;
  return d;
}

std::string Str(const json& j, std::initializer_list<const char*> keys) {
  const json* v = At(j, keys);
  if (v == nullptr) return "";
  if (v->is_string()) return v->get<std::string>();
  if (v->is_boolean()) return v->get<bool>() ? "yes" : "no";
  if (v->is_number()) return v->dump();
  return "";
}

std::optional<bool> Bool(const json& j, std::initializer_list<const char*> keys) {
  const json* v = At(j, keys);
  if (v == nullptr || !v->is_boolean()) return std::nullopt;
  return v->get<bool>();
}

std::string F(std::optional<double> v, int decimals) {
  if (!v) return kDash;
  return fmt::format("{:.{}f}", *v, decimals);
}

std::string I(std::optional<double> v) {
  if (!v) return kDash;
  const long long n = std::llround(*v);
  std::string digits = std::to_string(n < 0 ? -n : n);
  std::string out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += "&#8201;";
    out += digits[i];
  }
  return n < 0 ? "-" + out : out;
}

std::string Duration(std::optional<double> seconds) {
  if (!seconds) return kDash;
  const double s = *seconds;
  if (s < 10) return fmt::format("{:.2f} s", s);
  if (s < 60) return fmt::format("{:.1f} s", s);
  const long long total = std::llround(s);
  if (total < 3600) return fmt::format("{} min {:02d} s", total / 60, int(total % 60));
  return fmt::format("{} h {:02d} min", total / 3600, int((total % 3600) / 60));
}

std::string Percent(std::optional<double> fraction, int decimals) {
  if (!fraction) return kDash;
  return fmt::format("{:.{}f} %", 100.0 * *fraction, decimals);
}

std::string Hex(const cv::Vec3b& bgr) {
  return fmt::format("#{:02x}{:02x}{:02x}", bgr[2], bgr[1], bgr[0]);
}

double NiceStep(double x) {
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * p >= x * 0.999) return m * p;
  }
  return 10 * p;
}

std::string NowIsoUtc() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string Table(const std::vector<std::string>& head,
                  const std::vector<std::vector<std::string>>& rows, const std::string& align,
                  const std::string& css_class) {
  std::string h = css_class.empty() ? "<table>" : "<table class=\"" + css_class + "\">";
  h += "<thead><tr>";
  for (std::size_t c = 0; c < head.size(); ++c) {
    h += c < align.size() && align[c] == 'r' ? "<th class=\"num\">" : "<th>";
    h += head[c] + "</th>";
  }
  h += "</tr></thead><tbody>\n";
  for (const auto& row : rows) {
    h += "<tr>";
    for (std::size_t c = 0; c < row.size(); ++c) {
      h += c < align.size() && align[c] == 'r' ? "<td class=\"num\">" : "<td>";
      h += row[c] + "</td>";
    }
    h += "</tr>\n";
  }
  return h + "</tbody></table>\n";
}

std::string KeyValues(const std::vector<std::pair<std::string, std::string>>& kv) {
  std::string h = "<table class=\"kv\"><tbody>\n";
  for (const auto& [k, v] : kv) h += "<tr><th>" + k + "</th><td>" + v + "</td></tr>\n";
  return h + "</tbody></table>\n";
}

std::string Details(const std::string& summary, const std::string& body) {
  return "<details><summary>" + summary + "</summary>\n" + body + "</details>\n";
}

std::string Empty(const std::string& text) { return "<p class=\"empty\">" + text + "</p>\n"; }

std::string Code(const std::string& text) { return "<code>" + E(text) + "</code>"; }

std::string PngDataUri(const std::string& png) {
  return "data:image/png;base64," + Base64Encode(png);
}

std::optional<double> ParseNum(const std::string& s) {
  double v = 0;
  if (!io::ParseDouble(s, &v) || !std::isfinite(v)) return std::nullopt;
  return v;
}

}  // namespace crop4d::report::html
