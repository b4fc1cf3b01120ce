#include "crop4d/io/diagnostics.h"

#include <spdlog/spdlog.h>

#include "crop4d/core/error.h"

namespace crop4d::io {

const char* SeverityName(Severity severity) {
  return severity == Severity::kError ? "error" : "warning";
}

std::string Diagnostic::ToString() const {
  return std::string(SeverityName(severity)) + ": " + FormatLocation(file, line, message);
}

Diagnostics::Diagnostics(Options options) : options_(std::move(options)) {
  while (options_.root.size() > 1 && options_.root.back() == '/') options_.root.pop_back();
}

std::string Diagnostics::DisplayPath(const std::string& file) const {
  const std::string& root = options_.root;
  if (root.empty() || file.size() <= root.size() + 1) return file;
  if (file.compare(0, root.size(), root) != 0 || file[root.size()] != '/') return file;
  std::size_t start = root.size();
  while (start < file.size() && file[start] == '/') ++start;
  return file.substr(start);
}

void Diagnostics::Error(const std::string& file, std::int64_t line, const std::string& message) {
  Add({Severity::kError, file, line, message});
}

void Diagnostics::Warning(const std::string& file, std::int64_t line, const std::string& message) {
  Add({Severity::kWarning, file, line, message});
}

void Diagnostics::Add(Diagnostic diagnostic) {
  diagnostic.file = DisplayPath(diagnostic.file);
  std::lock_guard<std::mutex> lock(mutex_);
  auto key = std::make_tuple(static_cast<int>(diagnostic.severity), diagnostic.file,
                             diagnostic.line, diagnostic.message);
  if (!seen_.insert(std::move(key)).second) return;
  if (diagnostic.severity == Severity::kError) {
    ++errors_;
  } else {
    ++warnings_;
  }
  const std::size_t count = ++per_file_[diagnostic.file];
  if (options_.log) {
    const std::size_t max_logged = options_.max_logged_per_file;
    if (max_logged == 0 || count <= max_logged) {
      const std::string text = FormatLocation(diagnostic.file, diagnostic.line, diagnostic.message);
      if (diagnostic.severity == Severity::kError) {
        spdlog::error("{}", text);
      } else {
        spdlog::warn("{}", text);
      }
    } else if (count == max_logged + 1) {
      spdlog::warn("{}: more problems in this file are not shown", diagnostic.file);
    }
  }
  if (options_.max_items_per_file != 0 && count > options_.max_items_per_file) {
    ++suppressed_[diagnostic.file];
    return;
  }
  items_.push_back(std::move(diagnostic));
}

std::vector<Diagnostic> Diagnostics::items() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return items_;
}

std::size_t Diagnostics::error_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return errors_;
}

std::size_t Diagnostics::warning_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return warnings_;
}

std::map<std::string, std::size_t> Diagnostics::suppressed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return suppressed_;
}

}  // namespace crop4d::io
