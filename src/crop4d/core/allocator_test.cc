#include "crop4d/core/allocator.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <vector>

namespace crop4d {
namespace {

long MinorFaults() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_minflt;
}

// One round of the pattern of a SIFT scale space: several large buffers allocated, written and
// freed. Returns the page faults the round caused.
long Round(std::size_t block_bytes, int blocks) {
  const long before = MinorFaults();
  std::vector<char*> buffers;
  for (int b = 0; b < blocks; ++b) {
    char* p = static_cast<char*>(std::malloc(block_bytes));
    std::memset(p, b + 1, block_bytes);
    buffers.push_back(p);
  }
  // Keep the writes observable so that the compiler cannot drop them.
  long sum = 0;
  for (char* p : buffers) sum += p[block_bytes / 2];
  EXPECT_EQ(sum, blocks * (blocks + 1) / 2);
  for (char* p : buffers) std::free(p);
  return MinorFaults() - before;
}

// AddressSanitizer's allocator ignores mallopt (gcc and clang say that it is on differently).
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

TEST(Allocator, FreedLargeBlocksAreReusedWithoutPageFaults) {
  if (kSanitized) GTEST_SKIP() << "AddressSanitizer has its own allocator";
  ASSERT_TRUE(KeepFreedMemoryForReuse());
  constexpr std::size_t kBlock = 5u << 20;  // a 1280×960 float image
  constexpr int kBlocks = 12;               // 60 MiB, a SIFT scale space
  const long pages_per_round = static_cast<long>(kBlock * kBlocks / 4096);
  const long first = Round(kBlock, kBlocks);
  EXPECT_GT(first, pages_per_round / 2);  // the first round maps fresh pages...
  long later = 0;
  for (int round = 0; round < 5; ++round) later += Round(kBlock, kBlocks);
  // ...the later ones reuse them (glibc's defaults fault in every page again each round).
  EXPECT_LT(later, pages_per_round / 20) << "first round " << first << " faults";
}

// The resident size of this process, bytes (/proc/self/statm).
double ResidentBytes() {
  std::ifstream statm("/proc/self/statm");
  double size = 0, resident = 0;
  statm >> size >> resident;
  return resident * static_cast<double>(sysconf(_SC_PAGESIZE));
}

// Freed blocks the allocator keeps for reuse go back to the kernel when asked.
TEST(Allocator, FreedMemoryIsReturnedWhenAsked) {
  if (kSanitized) GTEST_SKIP() << "AddressSanitizer has its own allocator";
  ASSERT_TRUE(KeepFreedMemoryForReuse());
  constexpr std::size_t kBlock = 5u << 20;
  constexpr int kBlocks = 24;  // 120 MiB
  std::vector<char*> buffers;
  for (int b = 0; b < kBlocks; ++b) {
    buffers.push_back(static_cast<char*>(std::malloc(kBlock)));
    std::memset(buffers.back(), 1, kBlock);
  }
  // One block allocated last stays: the freed ones are not at the top of the heap.
  char* last = static_cast<char*>(std::malloc(4096));
  std::memset(last, 1, 4096);
  for (char* p : buffers) std::free(p);
  const double kept = ResidentBytes();
  ASSERT_TRUE(ReturnFreedMemory());
  const double returned = ResidentBytes();
  std::free(last);
  std::printf("resident %.0f MB with the freed blocks kept, %.0f MB once returned\n", kept / 1e6,
              returned / 1e6);
  EXPECT_GT(kept - returned, 0.8 * kBlock * kBlocks);
}

}  // namespace
}  // namespace crop4d
