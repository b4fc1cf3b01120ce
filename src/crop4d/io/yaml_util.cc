#include "crop4d/io/yaml_util.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "crop4d/core/error.h"
#include "crop4d/io/csv.h"

namespace crop4d::io {
namespace {

// Metadata files are small; anything larger is not what it claims to be.
constexpr std::uintmax_t kMaxYamlBytes = 4 << 20;

const char* NodeKind(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "nothing";
    case YAML::NodeType::Scalar:
      return "a value";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
    default:
      return "nothing";
  }
}

std::string Quote(const std::string& text) {
  constexpr std::size_t kMax = 40;
  if (text.size() <= kMax) return "'" + text + "'";
  return "'" + text.substr(0, kMax) + "...'";
}

}  // namespace

std::int64_t YamlLine(const YAML::Node& node) {
  if (!node.IsDefined()) return 0;
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? 0 : static_cast<std::int64_t>(mark.line) + 1;
}

bool ParseYamlDouble(const std::string& text, double* value) {
  if (text == ".nan" || text == ".NaN" || text == ".NAN") {
    *value = std::nan("");
    return true;
  }
  if (text == ".inf" || text == ".Inf" || text == ".INF" || text == "+.inf" || text == "+.Inf" ||
      text == "+.INF") {
    *value = HUGE_VAL;
    return true;
  }
  if (text == "-.inf" || text == "-.Inf" || text == "-.INF") {
    *value = -HUGE_VAL;
    return true;
  }
  return ParseDouble(text, value);
}

// ---- YamlFile --------------------------------------------------------------------------------

YamlFile::YamlFile(std::string path, Diagnostics* diag) : path_(std::move(path)), diag_(diag) {
  std::error_code ec;
  const auto status = std::filesystem::status(path_, ec);
  if (ec || !std::filesystem::exists(status)) {
    Error(0, "file not found");
    Finish();
  }
  if (std::filesystem::is_directory(status)) {
    Error(0, "is a folder, expected a file");
    Finish();
  }
  const std::uintmax_t size = std::filesystem::file_size(path_, ec);
  if (!ec && size > kMaxYamlBytes) {
    Error(0, "too large for a YAML metadata file (" + std::to_string(size) + " bytes)");
    Finish();
  }
  std::ifstream in(path_, std::ios::binary);
  if (!in) {
    Error(0, "cannot open");
    Finish();
  }
  std::ostringstream text;
  text << in.rdbuf();
  Parse(text.str());
}

YamlFile::YamlFile(std::string name, const std::string& text, Diagnostics* diag)
    : path_(std::move(name)), diag_(diag) {
  Parse(text);
}

void YamlFile::Parse(const std::string& text) {
  try {
    root_ = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    const std::int64_t line = e.mark.is_null() ? 0 : static_cast<std::int64_t>(e.mark.line) + 1;
    Error(line, "malformed YAML: " + e.msg);
    Finish();
  }
}

YamlMap YamlFile::Root() { return YamlMap(this, root_, ""); }

void YamlFile::Error(std::int64_t line, const std::string& message) {
  ++error_count_;
  errors_.emplace_back(line, message);
  if (diag_ != nullptr) diag_->Error(path_, line, message);
}

void YamlFile::Warning(std::int64_t line, const std::string& message) {
  if (diag_ != nullptr) {
    diag_->Warning(path_, line, message);
  } else {
    spdlog::warn("{}", FormatLocation(path_, line, message));
  }
}

void YamlFile::Finish() {
  if (errors_.empty()) return;
  if (diag_ == nullptr) {
    // The first error is thrown (and printed by the CLI); the others would be lost otherwise.
    for (std::size_t i = 1; i < errors_.size(); ++i) {
      spdlog::error("{}", FormatLocation(path_, errors_[i].first, errors_[i].second));
    }
  }
  const auto first = errors_.front();
  errors_.clear();
  throw InputError(path_, first.first, first.second);
}

// ---- YamlMap ---------------------------------------------------------------------------------

YamlMap::YamlMap(YamlFile* file, YAML::Node node, std::string context, std::int64_t parent_line)
    : file_(file), node_(std::move(node)), context_(std::move(context)) {
  line_ = YamlLine(node_);
  if (line_ == 0) line_ = parent_line;
  if (!node_.IsMap()) {
    file_->Error(line_, (context_.empty() ? std::string("the file") : "key '" + context_ + "'") +
                            ": expected a map of keys, found " + NodeKind(node_));
    node_ = YAML::Node(YAML::NodeType::Map);
  }
}

std::string YamlMap::KeyName(const char* key) const {
  return context_.empty() ? std::string(key) : context_ + "." + key;
}

std::int64_t YamlMap::LineOf(const char* key) const {
  for (const auto& item : node_) {
    if (item.first.IsScalar() && item.first.Scalar() == key) {
      const std::int64_t line = YamlLine(item.second);
      return line != 0 ? line : YamlLine(item.first);
    }
  }
  return line_;
}

bool YamlMap::Has(const char* key) {
  used_.insert(key);
  for (const auto& item : node_) {
    if (item.first.IsScalar() && item.first.Scalar() == key) return true;
  }
  return false;
}

YAML::Node YamlMap::Lookup(const char* key, Need need) {
  used_.insert(key);
  for (const auto& item : node_) {
    if (item.first.IsScalar() && item.first.Scalar() == key) {
      if (item.second.IsNull()) {
        if (need == kRequired) {
          file_->Error(LineOf(key), "required key '" + KeyName(key) + "' has no value");
        }
        return YAML::Node(YAML::NodeType::Undefined);
      }
      return item.second;
    }
  }
  if (need == kRequired) {
    file_->Error(line_, "missing required key '" + KeyName(key) + "'");
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

bool YamlMap::Get(const char* key, double* value, Need need) {
  const YAML::Node node = Lookup(key, need);
  if (!node.IsDefined()) return false;
  double parsed = 0;
  if (!node.IsScalar() || !ParseYamlDouble(node.Scalar(), &parsed)) {
    file_->Error(LineOf(key), "key '" + KeyName(key) + "': expected a number, found " +
                                  (node.IsScalar() ? Quote(node.Scalar()) : NodeKind(node)));
    return false;
  }
  if (!std::isfinite(parsed)) {
    file_->Error(LineOf(key),
                 "key '" + KeyName(key) + "': value is not finite (" + node.Scalar() + ")");
    return false;
  }
  *value = parsed;
  return true;
}

bool YamlMap::Get(const char* key, int* value, Need need) {
  const YAML::Node node = Lookup(key, need);
  if (!node.IsDefined()) return false;
  std::int64_t parsed = 0;
  if (!node.IsScalar() || !ParseInt64(node.Scalar(), &parsed) || parsed < INT32_MIN ||
      parsed > INT32_MAX) {
    file_->Error(LineOf(key), "key '" + KeyName(key) + "': expected an integer, found " +
                                  (node.IsScalar() ? Quote(node.Scalar()) : NodeKind(node)));
    return false;
  }
  *value = static_cast<int>(parsed);
  return true;
}

bool YamlMap::Get(const char* key, std::string* value, Need need) {
  const YAML::Node node = Lookup(key, need);
  if (!node.IsDefined()) return false;
  if (!node.IsScalar()) {
    file_->Error(LineOf(key), "key '" + KeyName(key) + "': expected text, found " + NodeKind(node));
    return false;
  }
  *value = node.Scalar();
  return true;
}

bool YamlMap::Get(const char* key, bool* value, Need need) {
  const YAML::Node node = Lookup(key, need);
  if (!node.IsDefined()) return false;
  const std::string text = node.IsScalar() ? node.Scalar() : std::string();
  if (text == "true" || text == "True" || text == "TRUE" || text == "yes" || text == "Yes") {
    *value = true;
    return true;
  }
  if (text == "false" || text == "False" || text == "FALSE" || text == "no" || text == "No") {
    *value = false;
    return true;
  }
  file_->Error(LineOf(key), "key '" + KeyName(key) + "': expected true or false, found " +
                                (node.IsScalar() ? Quote(text) : NodeKind(node)));
  return false;
}

bool YamlMap::Get(const char* key, std::vector<double>* value, std::size_t min_size,
                  std::size_t max_size, Need need) {
  const YAML::Node node = Lookup(key, need);
  if (!node.IsDefined()) return false;
  const std::string name = "key '" + KeyName(key) + "'";
  if (!node.IsSequence()) {
    file_->Error(LineOf(key), name + ": expected a list of numbers, found " + NodeKind(node));
    return false;
  }
  if (node.size() < min_size || node.size() > max_size) {
    const std::string expected = min_size == max_size
                                     ? std::to_string(min_size)
                                     : std::to_string(min_size) + " to " + std::to_string(max_size);
    file_->Error(LineOf(key), name + ": expected " + expected + " numbers, found " +
                                  std::to_string(node.size()));
    return false;
  }
  std::vector<double> parsed;
  parsed.reserve(node.size());
  bool ok = true;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const YAML::Node item = node[i];
    double x = 0;
    if (!item.IsScalar() || !ParseYamlDouble(item.Scalar(), &x)) {
      file_->Error(LineOf(key), name + ": item " + std::to_string(i + 1) + " is not a number (" +
                                    (item.IsScalar() ? Quote(item.Scalar()) : NodeKind(item)) +
                                    ")");
      ok = false;
    } else if (!std::isfinite(x)) {
      file_->Error(LineOf(key), name + ": item " + std::to_string(i + 1) + " is not finite (" +
                                    item.Scalar() + ")");
      ok = false;
    }
    parsed.push_back(x);
  }
  if (ok) *value = std::move(parsed);
  return ok;
}

std::optional<YamlMap> YamlMap::GetMap(const char* key, Need need) {
  const YAML::Node node = Lookup(key, need);
  if (!node.IsDefined()) return std::nullopt;
  if (!node.IsMap()) {
    file_->Error(LineOf(key),
                 "key '" + KeyName(key) + "': expected a map of keys, found " + NodeKind(node));
    return std::nullopt;
  }
  return YamlMap(file_, node, KeyName(key), LineOf(key));
}

YAML::Node YamlMap::GetSequence(const char* key, Need need) {
  const YAML::Node node = Lookup(key, need);
  if (!node.IsDefined()) return node;
  if (!node.IsSequence()) {
    file_->Error(LineOf(key),
                 "key '" + KeyName(key) + "': expected a list, found " + NodeKind(node));
    return YAML::Node(YAML::NodeType::Undefined);
  }
  return node;
}

void YamlMap::WarnUnknownKeys() {
  for (const auto& item : node_) {
    const std::string key = item.first.IsScalar() ? item.first.Scalar() : std::string("?");
    if (used_.count(key) == 0) {
      file_->Warning(YamlLine(item.first), "unknown key '" + KeyName(key.c_str()) + "' (ignored)");
    }
  }
}

}  // namespace crop4d::io
