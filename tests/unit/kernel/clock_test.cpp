// The kernel clock (DESIGN §6): the time page seqlock and the timer table's deterministic firing.
#include <gtest/gtest.h>

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
