// The kernel clock (docs/design.md §6): the time page seqlock and the timer table's deterministic firing.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "rejuv/clock/time_page.hpp"
#include "rejuv/clock/timers.hpp"
#include "rejuv/sys/memory.hpp"

namespace rejuv::clock {
namespace {

using std::chrono::milliseconds;

std::vector<KernelTimer> fire(TimerTable& t, Nanos now) {
  std::vector<KernelTimer> out;
  t.fire_due(now, [&](const KernelTimer& k) { out.push_back(k); });
  return out;
}

TEST(TimePage, Write_IsSeenByAReadOnlyReader) {
  auto writer = TimePageWriter::create();
  ASSERT_TRUE(writer.has_value()) << writer.error().to_string();
  auto reader = TimePageReader::map(writer->read_only_fd().get());
  ASSERT_TRUE(reader.has_value()) << reader.error().to_string();
  writer->write(TimeSample{.now = milliseconds{1234}, .mode = SrMode::CP, .epoch = Epoch{7}});
  const TimeSample s = reader->read();
  EXPECT_EQ(s.now, milliseconds{1234});
  EXPECT_EQ(s.mode, SrMode::CP);
  EXPECT_EQ(s.epoch, Epoch{7});
  writer->set_now(milliseconds{2000});
  EXPECT_EQ(reader->read().now, milliseconds{2000});
  EXPECT_EQ(reader->read().mode, SrMode::CP);
}

TEST(TimePage, ServiceFd_CannotBeMappedWritable) {
  auto writer = TimePageWriter::create();
  ASSERT_TRUE(writer.has_value());
  auto rw = sys::Mapping::map(writer->read_only_fd(), kTimePageBytes, sys::Access::ReadWrite);
  EXPECT_FALSE(rw.has_value());
}

// A service that reopens its read-only fd writable through the magic link /proc/self/fd/4 to make the
// sequence odd: the page is sealed (F_SEAL_FUTURE_WRITE) and 0444, so whatever fd a process gets of it — even
// root's O_RDWR reopen, which the mode does not stop — cannot write it or map it writable.
TEST(TimePage, MagicLinkReopen_CannotWriteNorMapWritable) {
  auto writer = TimePageWriter::create();
  ASSERT_TRUE(writer.has_value()) << writer.error().to_string();
  writer->write(TimeSample{.now = milliseconds{5}, .mode = SrMode::MC, .epoch = Epoch{1}});
  struct stat st {};
  ASSERT_EQ(::fstat(writer->read_only_fd().get(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777U, 0444U);
  const std::string link = "/proc/self/fd/" + std::to_string(writer->read_only_fd().get());
  const int rw = ::open(link.c_str(), O_RDWR | O_CLOEXEC);
  const int fd = rw >= 0 ? rw : writer->read_only_fd().get();  // as root the mode lets the open through
  const std::uint64_t odd = 1;
  errno = 0;
  EXPECT_EQ(::pwrite(fd, &odd, sizeof(odd), 0), -1);
  EXPECT_TRUE(errno == EPERM || errno == EBADF) << std::strerror(errno);
  void* map = ::mmap(nullptr, kTimePageBytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  EXPECT_EQ(map, MAP_FAILED) << "a writable shared mapping of the time page";
  if (map != MAP_FAILED) ::munmap(map, kTimePageBytes);
  if (rw >= 0) ::close(rw);
  auto reader = TimePageReader::map(writer->read_only_fd().get());
  ASSERT_TRUE(reader.has_value());
  EXPECT_EQ(reader->read().now, milliseconds{5});
  EXPECT_EQ(reader->stalls(), 0U);
}

// A page whose sequence stays odd (no writer finishes) does not hang its reader: try_read gives up after its
// bound, read() keeps the last consistent sample and counts the stall. The page here is a plain memfd the test
// writes itself (the kernel's is sealed against that).
TEST(TimePage, OddSequence_ReaderGivesUpAndCounts) {
  auto memfd = sys::make_memfd("odd-page", kTimePageBytes);
  ASSERT_TRUE(memfd.has_value());
  auto mapping = sys::Mapping::map(*memfd, kTimePageBytes, sys::Access::ReadWrite);
  ASSERT_TRUE(mapping.has_value());
  auto* page = new (mapping->data()) wire::TimePage{};
  page->sequence.store(2);
  page->now_ns.store(3'000'000);
  page->mode.store(static_cast<std::uint32_t>(SrMode::SC));
  auto reader = TimePageReader::map(memfd->get());
  ASSERT_TRUE(reader.has_value());
  EXPECT_EQ(reader->read().now, milliseconds{3});
  page->sequence.store(3);  // odd, and it stays so
  page->now_ns.store(9'000'000);
  EXPECT_FALSE(reader->try_read().has_value());
  EXPECT_EQ(reader->read().now, milliseconds{3}) << "not the last consistent sample";
  EXPECT_EQ(reader->stalls(), 1U);
  page->sequence.store(4);  // a writer finishes: readable again
  EXPECT_EQ(reader->read().now, milliseconds{9});
  EXPECT_EQ(reader->stalls(), 1U);
}

TEST(TimerTable, DueTimers_FireInDueServiceIdOrder) {
  TimerTable t(3);
  ASSERT_TRUE(t.arm(ServiceId{2}, 1, milliseconds{4}, Nanos{0}));
  ASSERT_TRUE(t.arm(ServiceId{0}, 9, milliseconds{4}, Nanos{0}));
  ASSERT_TRUE(t.arm(ServiceId{1}, 5, milliseconds{2}, Nanos{0}));
  ASSERT_TRUE(t.arm(ServiceId{0}, 3, milliseconds{4}, Nanos{0}));
  ASSERT_TRUE(t.arm(ServiceId{1}, 6, milliseconds{9}, Nanos{0}));
  const auto fired = fire(t, milliseconds{4});
  ASSERT_EQ(fired.size(), 4U);
  EXPECT_EQ(fired[0].service, ServiceId{1});
  EXPECT_EQ(fired[1].id, 3U);
  EXPECT_EQ(fired[2].id, 9U);
  EXPECT_EQ(fired[3].service, ServiceId{2});
  EXPECT_EQ(t.total(), 1U);  // one-shot timers are gone; the one due at 9 ms is left
  EXPECT_EQ(t.next_due(), milliseconds{9});
}

TEST(TimerTable, PeriodicTimer_MissedPeriodsFireOnceAndAreCounted) {
  TimerTable t(1);
  ASSERT_TRUE(t.arm(ServiceId{0}, 1, milliseconds{2}, milliseconds{2}));
  EXPECT_EQ(fire(t, milliseconds{7}).size(), 1U);  // due at 2, 4, 6: one fire
  EXPECT_EQ(t.coalesced(), 2U);
  EXPECT_EQ(t.next_due(), milliseconds{8});
  EXPECT_TRUE(fire(t, milliseconds{7}).empty());
}

TEST(TimerTable, RearmingAnId_ReplacesIt) {
  TimerTable t(1);
  ASSERT_TRUE(t.arm(ServiceId{0}, 1, milliseconds{2}, Nanos{0}));
  ASSERT_TRUE(t.arm(ServiceId{0}, 1, milliseconds{5}, Nanos{0}));
  EXPECT_EQ(t.count(ServiceId{0}), 1U);
  EXPECT_TRUE(fire(t, milliseconds{4}).empty());
}

TEST(TimerTable, ThirtyThirdTimer_IsTooMany) {
  TimerTable t(1);
  for (std::uint64_t i = 0; i < kMaxTimersPerService; ++i) ASSERT_TRUE(t.arm(ServiceId{0}, i, milliseconds{1}, Nanos{0}));
  auto r = t.arm(ServiceId{0}, 99, milliseconds{1}, Nanos{0});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error(), TimerError::TooManyTimers);
}

TEST(TimerTable, PeriodBelowMinimum_IsBadPeriod) {
  TimerTable t(1);
  auto r = t.arm(ServiceId{0}, 1, milliseconds{1}, Nanos{10});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error(), TimerError::BadPeriod);
}

TEST(TimerTable, UnknownService_IsRefused) {
  TimerTable t(1);
  auto r = t.arm(ServiceId{1}, 1, milliseconds{1}, Nanos{0});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error(), TimerError::NoSuchService);
}

TEST(TimerTable, CancelOfAnUnarmedTimer_IsNoSuchTimer) {
  TimerTable t(1);
  auto r = t.cancel(ServiceId{0}, 4);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error(), TimerError::NoSuchTimer);
}

TEST(TimerTable, RemoveService_DropsItsTimersOnly) {
  TimerTable t(2);
  ASSERT_TRUE(t.arm(ServiceId{0}, 1, milliseconds{1}, Nanos{0}));
  ASSERT_TRUE(t.arm(ServiceId{0}, 2, milliseconds{1}, Nanos{0}));
  ASSERT_TRUE(t.arm(ServiceId{1}, 1, milliseconds{1}, Nanos{0}));
  EXPECT_EQ(t.remove_service(ServiceId{0}), 2U);
  EXPECT_EQ(t.total(), 1U);
  ASSERT_EQ(t.armed().size(), 1U);
  EXPECT_EQ(t.armed()[0].service, ServiceId{1});
}

}  // namespace
}  // namespace rejuv::clock
