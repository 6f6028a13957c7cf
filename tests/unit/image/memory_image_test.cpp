// memory_image's help for the critical paths of images by written pages (docs/design.md §7; memory_image.hpp):
// the record file made ahead, and a copy making its working set its own after a fork. Each test runs in a
// forked child, since prepare_self and write tracking change the whole process (malloc, the stack, uffd).
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "rejuv/sdk/memory_image.hpp"
#include "rejuv/sys/sanitizer.hpp"

namespace rejuv::memory_image {
namespace {

// Runs body() in a child; its exit code is the number of the first check that failed (0: all held).
int in_child(int (*body)()) {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(body());
  int status = 0;
  if (pid < 0 || ::waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

long minor_faults() {
  rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}

constexpr std::size_t kPages = 6;
// prepare_self refused (a sanitized build: its allocator refuses mallopt) or no userfaultfd
// write-protection on this kernel: images are by fork there, and there is no working set to touch.
constexpr int kNoTracking = 77;

TEST(MemoryImage, RecordFileIsSealableWithPagesAllocatedAhead) {
  EXPECT_EQ(in_child([]() -> int {
              auto file = make_record_file();
              if (!file) return 2;
              struct stat st{};
              if (::fstat(file->get(), &st) != 0) return 3;
              // The table's page and at least kRecordPagesAhead pages after it, allocated (not a hole).
              if (static_cast<std::size_t>(st.st_size) < kWrittenPagesAt + kRecordPagesAhead * kPageBytes) return 4;
              if (static_cast<std::size_t>(st.st_blocks) * 512 < (1 + kRecordPagesAhead) * kPageBytes) return 5;
              if (::fcntl(file->get(), F_ADD_SEALS, F_SEAL_WRITE) != 0) return 6;
              return 0;
            }),
            0);
}

TEST(MemoryImage, TouchedWorkingSetIsUnchangedAndTakesNoFaultAfterTheFork) {
  const int failed = in_child([]() -> int {
              if (!prepare_self()) return kNoTracking;
              // Allocated before tracking starts, so that it lies in the tracked heap (tracking covers the heap
              // as it is then; where a later allocation lands depended on what the binary allocated before).
              auto* buf = static_cast<unsigned char*>(std::aligned_alloc(kPageBytes, kPages * kPageBytes));
              if (buf == nullptr) return 2;
              if (!track_writes_self()) return kNoTracking;
              for (std::size_t i = 0; i < kPages * kPageBytes; ++i) buf[i] = static_cast<unsigned char>(i * 7 + 1);
              // The working set: what copy_written_self found (these pages among them).
              auto file = make_record_file();
              if (!file) return 3;
              auto n = copy_written_self(file->get());
              if (!n || *n < kPages) return 4;
              const std::vector<unsigned char> before(buf, buf + kPages * kPageBytes);
              const pid_t copy = ::fork();
              if (copy == 0) {
                // The copy: its pages shared copy-on-write with its parent until it touches them.
                touch_working_set();
                if (std::memcmp(before.data(), buf, before.size()) != 0) ::_exit(10);
                const long faults = minor_faults();
                for (std::size_t p = 0; p < kPages; ++p) buf[p * kPageBytes] = static_cast<unsigned char>(p);
                ::_exit(minor_faults() == faults ? 0 : 11);
              }
              int status = 0;
              if (copy < 0 || ::waitpid(copy, &status, 0) != copy || !WIFEXITED(status)) return 5;
              if (WEXITSTATUS(status) != 0) return WEXITSTATUS(status);
              // The parent's memory is its own: the copy's writes did not reach it.
              if (std::memcmp(before.data(), buf, before.size()) != 0) return 6;
              return 0;
            });
  if (failed == kNoTracking) GTEST_SKIP() << "images by written pages unavailable here (sanitized build or no UFFD_FEATURE_WP_ASYNC)";
  EXPECT_EQ(failed, 0);
}

TEST(MemoryImage, WithoutTheTouchTheCopyFaultsOnEachPage) {
  // The counterpart of the test above: it shows that the fault count it asserts on does move.
#if defined(REJUV_TSAN)
  // Not in a ThreadSanitizer build, which skips the test above: its allocator's heap is not the brk heap an
  // image tracks, and a copy's writes there take fewer faults than pages.
  GTEST_SKIP() << "the heap is ThreadSanitizer's, whose faults after a fork are not per page";
#endif
  EXPECT_EQ(in_child([]() -> int {
              auto* buf = static_cast<unsigned char*>(std::aligned_alloc(kPageBytes, kPages * kPageBytes));
              if (buf == nullptr) return 2;
              std::memset(buf, 1, kPages * kPageBytes);
              const pid_t copy = ::fork();
              if (copy == 0) {
                const long faults = minor_faults();
                for (std::size_t p = 0; p < kPages; ++p) buf[p * kPageBytes] = static_cast<unsigned char>(p);
                ::_exit(minor_faults() - faults >= static_cast<long>(kPages) ? 0 : 11);
              }
              int status = 0;
              if (copy < 0 || ::waitpid(copy, &status, 0) != copy || !WIFEXITED(status)) return 5;
              return WEXITSTATUS(status);
            }),
            0);
}

}  // namespace
}  // namespace rejuv::memory_image
