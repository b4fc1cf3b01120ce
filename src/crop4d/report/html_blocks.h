#pragma once

// The building blocks of the season report (html_report.h), internal to it: reading files and
// JSON values leniently, formatting numbers for people, and small pieces of HTML (tables, lists
// of keys and values, collapsible blocks). Cells and values passed to the HTML pieces are HTML
// already; E() escapes text.

#include <filesystem>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace crop4d::report::html {

namespace fs = std::filesystem;
using nlohmann::json;

// ---- files -------------------------------------------------------------------------------------

bool IsFile(const fs::path& p);
bool IsDir(const fs::path& p);

// Entries of a folder (files or folders), sorted by name; empty when it cannot be listed.
std::vector<fs::path> ListDir(const fs::path& dir, bool folders);

// The whole content of a file, or nullopt when it cannot be read.
std::optional<std::string> ReadBytes(const fs::path& p);

// ---- JSON values -------------------------------------------------------------------------------

// The value at keys... of j, or nullptr.
const json* At(const json& j, std::initializer_list<const char*> keys);

// The finite number at keys... of j, or nullopt.
std::optional<double> Num(const json& j, std::initializer_list<const char*> keys);

// The string at keys... of j ("yes"/"no" for a boolean, the JSON text of a number), or "".
std::string Str(const json& j, std::initializer_list<const char*> keys);

// The boolean at keys... of j, or nullopt.
std::optional<bool> Bool(const json& j, std::initializer_list<const char*> keys);

// A finite number parsed from a CSV cell, or nullopt.
std::optional<double> ParseNum(const std::string& s);

// ---- formatting --------------------------------------------------------------------------------

// What a missing value shows.
inline constexpr const char* kDash = "&ndash;";

// Fixed decimals, or a dash.
std::string F(std::optional<double> v, int decimals);

// An integer with thin-space thousands separators, or a dash.
std::string I(std::optional<double> v);

// A duration for people: "0.42 s", "17.2 s", "2 min 15 s", "1 h 03 min".
std::string Duration(std::optional<double> seconds);

// A fraction as a percentage ("12.5 %"), or a dash.
std::string Percent(std::optional<double> fraction, int decimals = 1);

// "#rrggbb" of a BGR colour.
std::string Hex(const cv::Vec3b& bgr);

// 1, 2 or 5 × 10^k nearest above `x` (> 0).
double NiceStep(double x);

// The current time, "YYYY-MM-DDTHH:MM:SSZ".
std::string NowIsoUtc();

// ---- HTML --------------------------------------------------------------------------------------

// `s` escaped for HTML (HtmlEscape).
std::string E(const std::string& s);

// An HTML table; cells are HTML already. `align`: one letter per column, 'l' or 'r' (numbers).
std::string Table(const std::vector<std::string>& head,
                  const std::vector<std::vector<std::string>>& rows, const std::string& align,
                  const std::string& css_class = "");

// A two-column key/value table.
std::string KeyValues(const std::vector<std::pair<std::string, std::string>>& kv);

// A collapsible block: `summary`, then `body` when opened (both HTML).
std::string Details(const std::string& summary, const std::string& body);

// A paragraph saying that there is nothing to show (`text` is HTML).
std::string Empty(const std::string& text);

// `text` escaped, in <code>.
std::string Code(const std::string& text);

// A data: URI of PNG bytes, for <img src>.
std::string PngDataUri(const std::string& png);

}  // namespace crop4d::report::html
