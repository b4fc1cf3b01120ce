#pragma once

// Helpers for tests that build fields in temporary folders and break them one file at a time.
// Header-only; used by the io tests and the CLI tests.

#include <stdlib.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace crop4d::io::testing {

// A fresh folder under the system temp folder, removed with everything in it on destruction.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "crop4d_test_XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::string& path() const { return path_; }
  std::string operator/(const std::string& relative) const {
    return (std::filesystem::path(path_) / relative).string();
  }

 private:
  std::string path_;
};

inline void WriteText(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path);
}

inline std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The lines of a text file, without their '\n'.
inline std::vector<std::string> ReadLines(const std::string& path) {
  std::vector<std::string> lines;
  std::istringstream in(ReadText(path));
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

inline void WriteLines(const std::string& path, const std::vector<std::string>& lines,
                       bool final_newline = true) {
  std::string text;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    text += lines[i];
    if (i + 1 < lines.size() || final_newline) text += "\n";
  }
  WriteText(path, text);
}

// Replaces line `line` (1-based) of a text file.
inline void ReplaceLine(const std::string& path, int line, const std::string& text) {
  std::vector<std::string> lines = ReadLines(path);
  lines.at(line - 1) = text;
  WriteLines(path, lines);
}

// Replaces the first occurrence of `from` in a text file; throws when it is not there.
inline void ReplaceInFile(const std::string& path, const std::string& from, const std::string& to) {
  std::string text = ReadText(path);
  const std::size_t at = text.find(from);
  if (at == std::string::npos) throw std::runtime_error("'" + from + "' not in " + path);
  text.replace(at, from.size(), to);
  WriteText(path, text);
}

// The crop4d binary under test: $CROP4D_TEST_BINARY when set, else <build>/crop4d (test targets
// define CROP4D_BINARY_DIR).
#ifdef CROP4D_BINARY_DIR
inline std::string Crop4dBinary() {
  const char* override_path = std::getenv("CROP4D_TEST_BINARY");
  return override_path != nullptr ? override_path : std::string(CROP4D_BINARY_DIR) + "/crop4d";
}
#endif

// `s` in single quotes for a shell command line (the tests' paths hold no quote).
inline std::string ShellQuote(const std::string& s) { return "'" + s + "'"; }

// Exit code and captured output of one command run.
struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

// Runs `program args` through the shell, its stdout and stderr captured in files of `dir`.
inline CommandResult RunCommand(const TempDir& dir, const std::string& program,
                                const std::string& args) {
  const std::string out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string command =
      ShellQuote(program) + " " + args + " >" + ShellQuote(out) + " 2>" + ShellQuote(err);
  const int status = std::system(command.c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = ReadText(out);
  result.err = ReadText(err);
  return result;
}

}  // namespace crop4d::io::testing
