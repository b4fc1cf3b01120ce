#include "crop4d/io/workspace_lock.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "crop4d/core/error.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

using testing::ReadText;
using testing::TempDir;

// The lock file of a test (a workspace's is workspace::Layout::Lock()).
std::string Lock(const TempDir& dir) { return dir / "test.lock"; }

TEST(WorkspaceLockTest, ASecondHolderIsRefusedWithTheNameOfTheFirst) {
  TempDir ws;
  const WorkspaceLock first(Lock(ws), "crop4d run");
  EXPECT_NE(ReadText(Lock(ws)).find("crop4d run, pid " + std::to_string(::getpid())),
            std::string::npos);
  try {
    const WorkspaceLock second(Lock(ws), "crop4d fuse");
    FAIL() << "the second lock was granted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("in use by crop4d run, pid " + std::to_string(::getpid())),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("test.lock"), std::string::npos) << what;
  }
}

TEST(WorkspaceLockTest, AReleasedLockIsEmptyAndCanBeTakenAgain) {
  TempDir ws;
  { const WorkspaceLock first(Lock(ws), "crop4d run"); }
  EXPECT_EQ(ReadText(Lock(ws)), "");
  const WorkspaceLock second(Lock(ws), "crop4d slam");
  EXPECT_EQ(ReadText(Lock(ws)).rfind("crop4d slam, pid ", 0), 0u);
}

TEST(WorkspaceLockTest, AWaitingHolderGetsTheLockWhenTheFirstEnds) {
  TempDir ws;
  std::atomic<bool> released{false};
  auto first = std::make_unique<WorkspaceLock>(Lock(ws), "crop4d run");
  std::thread releaser([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    released = true;
    first.reset();
  });
  const auto start = std::chrono::steady_clock::now();
  const WorkspaceLock second(Lock(ws), "crop4d run", WorkspaceLock::IfBusy::kWait);
  EXPECT_TRUE(released.load());
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(250));
  releaser.join();
}

TEST(WorkspaceLockTest, TheLockOfAKilledProcessNeverBlocks) {
  TempDir ws;
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const WorkspaceLock lock(Lock(ws), "crop4d run");
    const char byte = 1;
    if (::write(ready[1], &byte, 1) != 1) ::_exit(3);
    for (;;) ::pause();
  }
  char byte = 0;
  ASSERT_EQ(::read(ready[0], &byte, 1), 1);
  EXPECT_THROW(WorkspaceLock(Lock(ws), "crop4d run"), InputError);
  ::kill(child, SIGKILL);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status));
  // The killed holder's line is still in the file; the lock is not.
  EXPECT_NE(ReadText(Lock(ws)).find(std::to_string(child)), std::string::npos);
  EXPECT_NO_THROW(WorkspaceLock(Lock(ws), "crop4d run"));
  ::close(ready[0]);
  ::close(ready[1]);
}

TEST(WorkspaceLockTest, AMissingWorkspaceFolderIsAnInputError) {
  TempDir ws;
  EXPECT_THROW(WorkspaceLock(ws / "no/such/folder/lock", "crop4d run"), InputError);
}

}  // namespace
}  // namespace crop4d::io
