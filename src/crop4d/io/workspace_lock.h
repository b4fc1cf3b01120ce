#pragma once

// One crop4d process writes into a workspace at a time. The workspace's lock file
// (workspace::Layout::Lock(), WS/.crop4d.lock) carries an advisory lock (flock) for as long as
// its holder runs: the kernel releases it when the process ends in any way, kill -9 included, so
// a lock left by a killed run never blocks the next one. The file also says who holds it
// (command, process id, host, start time) so that a second process can name the running one.
// The class takes the file's path: io sits below workspace/, which alone knows where it lives.

#include <filesystem>
#include <string>

namespace crop4d::io {

class WorkspaceLock {
 public:
  // What a second process does while another one holds the lock.
  enum class IfBusy { kFail, kWait };
  // kExclusive: one process alone (a local run, a stage command). kShared: the tasks of a
  // cluster run (pipeline/cluster_run.h), which write disjoint files side by side; they keep
  // exclusive holders out and are kept out by them. Shared holders leave the holder line alone.
  enum class Sharing { kExclusive, kShared };

  // Takes the lock held in `lock_file` (created when missing, in an existing folder) for
  // `command` (e.g. "crop4d run"). While held, the file's first line names the holder:
  // "crop4d run, pid 123 on host, since 2026-11-26T13:20:00Z". kFail: throws InputError naming
  // the holder when another process holds it. kWait: logs once who holds it and blocks until it
  // is released. Throws InputError when the lock file cannot be created.
  WorkspaceLock(const std::filesystem::path& lock_file, const std::string& command,
                IfBusy if_busy = IfBusy::kFail, Sharing sharing = Sharing::kExclusive);
  // Releases the lock (the file stays: removing it would race with a process waiting on it).
  ~WorkspaceLock();
  WorkspaceLock(const WorkspaceLock&) = delete;
  WorkspaceLock& operator=(const WorkspaceLock&) = delete;

 private:
  int fd_ = -1;
  bool exclusive_ = true;
};

}  // namespace crop4d::io
