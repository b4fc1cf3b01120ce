#pragma once

// Atomic writes (DESIGN.md §5): write into "<path>.tmp.<pid>.<n>" in the same folder, flush,
// then rename over <path>. A reader never sees a half-written file, and a killed process
// leaves at most a stray temporary file, never a truncated result.

#include <fstream>
#include <string>

namespace crop4d::io {

class AtomicFile {
 public:
  // Opens the temporary file (binary mode); creates missing parent folders. Throws
  // InputError naming `path` when it cannot be created.
  explicit AtomicFile(std::string path);
  // Removes the temporary file if Commit() was not called.
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ofstream& stream() { return stream_; }
  // Flushes, closes and renames into place. Throws InputError on any I/O failure.
  void Commit();

 private:
  std::string path_, tmp_path_;
  std::ofstream stream_;
  bool committed_ = false;
};

// Writes `content` to `path` atomically.
void WriteFileAtomic(const std::string& path, const std::string& content);

// Removes, below `folder` (recursively), the temporary files that AtomicFile leaves when its
// process is killed before Commit(). Only for a folder that no other process is writing into.
// Returns how many were removed.
int RemoveStaleTemporaryFiles(const std::string& folder);

// Appends the file at `from` to `out`, read in blocks (it may be larger than memory). Throws
// InputError naming `target` (the file being written) when `from` cannot be opened or read.
void AppendFileTo(const std::string& from, const std::string& target, std::ostream& out);

}  // namespace crop4d::io
