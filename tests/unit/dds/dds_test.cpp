// The DDS bridge in one process (docs/design.md §5): two participants (or ignorelocal off) on a private domain.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstddef>
#include <cstring>
#include <vector>

#include "dds_test_support.hpp"
#include "rejuv/dds/dds.hpp"
#include "rejuv/dds/plant_topics.hpp"

namespace rejuv::dds {
namespace {

using namespace std::chrono_literals;
using test_support::kLiveness;
using test_support::readable_now;
using test_support::readable_within;

const msgs::TopicType& type_named(std::string_view name) {
  const msgs::TopicType* t = msgs::find_topic_type(name);
  REJUV_ASSERT(t != nullptr, "known topic type");
  return *t;
}
const msgs::TopicType& gyro_type() {
  return type_named(msgs::TopicTraits<rejuv_msg_SensorGyro>::name);
}
const msgs::TopicType& accel_type() {
  return type_named(msgs::TopicTraits<rejuv_msg_SensorAccel>::name);
}

rejuv_msg_SensorGyro gyro_sample(std::uint64_t t) {
  rejuv_msg_SensorGyro g{};
  g.timestamp_ns = t;
  g.omega_B_rad_s[0] = 0.1 * static_cast<double>(t);
  g.omega_B_rad_s[1] = -0.2;
  g.omega_B_rad_s[2] = 0.3;
  g.temperature_c = 25;
  return g;
}

class DdsTest : public ::testing::Test {
 protected:
  void SetUp() override { test_support::use_loopback_config(); }

  static Participant participant() {
    auto p = Participant::create(test_support::test_domain());
    REJUV_ASSERT(p.has_value(), "participant on the test domain");
    return std::move(*p);
  }

  // Waits until both ends see each other: a volatile sample written earlier would never arrive.
  static void connect(const Writer& w, const Reader& r) {
    ASSERT_TRUE(w.wait_for_readers(1, kLiveness).has_value());
    ASSERT_TRUE(r.wait_for_writers(1, kLiveness).has_value());
  }

  // Takes gyro samples until `count` arrived (bounded).
  static std::vector<rejuv_msg_SensorGyro> take_gyros(Reader& r, std::size_t count) {
    std::vector<rejuv_msg_SensorGyro> got;
    const auto deadline = std::chrono::steady_clock::now() + kLiveness;
    while (got.size() < count && std::chrono::steady_clock::now() < deadline) {
      if (!readable_within(r.ready_fd(), 100ms)) continue;
      auto n = r.take_as<rejuv_msg_SensorGyro>([&](const rejuv_msg_SensorGyro& g) { got.push_back(g); });
      EXPECT_TRUE(n.has_value());
    }
    return got;
  }
};

TEST_F(DdsTest, WriterReader_TwoParticipants_RoundTripSameBytes) {
  Participant a = participant();
  Participant b = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  auto r = Reader::create(b, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w && r);
  connect(*w, *r);

  const rejuv_msg_SensorGyro sent = gyro_sample(42);
  ASSERT_TRUE(w->write(std::as_bytes(std::span(&sent, 1))).has_value());

  ASSERT_TRUE(readable_within(r->ready_fd(), kLiveness));
  std::vector<std::byte> received;
  auto n = r->take([&](std::span<const std::byte> bytes) { received.assign(bytes.begin(), bytes.end()); });
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(*n, 1U);
  ASSERT_EQ(received.size(), sizeof sent);
  EXPECT_EQ(std::memcmp(received.data(), &sent, sizeof sent), 0);
}

TEST_F(DdsTest, Write_WrongSize_RefusedWithSizeMismatch) {
  Participant a = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w.has_value());
  const std::array<std::byte, 10> short_payload{};
  auto result = w->write(short_payload);
  ASSERT_FALSE(result.has_value());
  EXPECT_EQ(result.error().kind, DdsError::Kind::SizeMismatch);
  EXPECT_EQ(result.error().expected_size, sizeof(rejuv_msg_SensorGyro));
  EXPECT_EQ(result.error().actual_size, 10U);
  EXPECT_NE(result.error().to_string().find("10 bytes"), std::string::npos) << result.error().to_string();
}

TEST_F(DdsTest, Write_OversizedPayload_RefusedWithSizeMismatch) {
  Participant a = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w.has_value());
  std::vector<std::byte> long_payload(sizeof(rejuv_msg_SensorGyro) + 1);
  auto result = w->write(long_payload);
  ASSERT_FALSE(result.has_value());
  EXPECT_EQ(result.error().kind, DdsError::Kind::SizeMismatch);
}

TEST_F(DdsTest, SizeMismatch_NothingDelivered_NextSampleIsFirst) {
  Participant a = participant();
  Participant b = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  auto r = Reader::create(b, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w && r);
  connect(*w, *r);
  const std::array<std::byte, 8> wrong{};
  ASSERT_FALSE(w->write(wrong).has_value());
  ASSERT_TRUE(w->write_value(gyro_sample(7)).has_value());
  const auto got = take_gyros(*r, 1);
  ASSERT_EQ(got.size(), 1U);
  EXPECT_EQ(got[0].timestamp_ns, 7U);  // FIFO: had the refused write gone out, it would come first
}

TEST_F(DdsTest, WriteValue_OtherCType_TypeMismatch) {
  Participant a = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w.has_value());
  const rejuv_msg_SensorAccel accel{};
  auto result = w->write_value(accel);
  ASSERT_FALSE(result.has_value());
  EXPECT_EQ(result.error().kind, DdsError::Kind::TypeMismatch);
}

TEST_F(DdsTest, TakeAs_OtherCType_TypeMismatch) {
  Participant a = participant();
  auto r = Reader::create(a, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(r.has_value());
  auto result = r->take_as<rejuv_msg_SensorAccel>([](const rejuv_msg_SensorAccel&) {});
  ASSERT_FALSE(result.has_value());
  EXPECT_EQ(result.error().kind, DdsError::Kind::TypeMismatch);
}

TEST_F(DdsTest, ReadyFd_DataArrives_BecomesReadableAndTakeClearsIt) {
  Participant a = participant();
  Participant b = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  auto r = Reader::create(b, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w && r);
  connect(*w, *r);
  ASSERT_GE(r->ready_fd(), 0);
  EXPECT_FALSE(readable_now(r->ready_fd()));

  ASSERT_TRUE(w->write_value(gyro_sample(1)).has_value());
  EXPECT_TRUE(readable_within(r->ready_fd(), kLiveness));

  auto n = r->take([](std::span<const std::byte>) {});
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(*n, 1U);
  EXPECT_FALSE(readable_now(r->ready_fd()));
}

TEST_F(DdsTest, SignallingOff_DataArrives_FdStaysUnreadableButTakeGetsIt) {
  Participant a = participant();
  Participant b = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  auto r = Reader::create(b, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w && r);
  connect(*w, *r);
  r->set_signalling(false);
  ASSERT_TRUE(w->write_value(gyro_sample(1)).has_value());
  std::size_t taken = 0;
  // The sample arrives on Cyclone's thread without a signal: poll take() until it is there.
  const auto deadline = std::chrono::steady_clock::now() + kLiveness;
  while (taken == 0 && std::chrono::steady_clock::now() < deadline) {
    auto n = r->take([](std::span<const std::byte>) {});
    ASSERT_TRUE(n.has_value());
    taken += *n;
  }
  EXPECT_EQ(taken, 1U);
  EXPECT_FALSE(readable_now(r->ready_fd()));
}

TEST_F(DdsTest, SignallingBackOn_NextSampleMakesFdReadable) {
  Participant a = participant();
  Participant b = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  auto r = Reader::create(b, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w && r);
  connect(*w, *r);
  r->set_signalling(false);
  r->set_signalling(true);
  ASSERT_TRUE(w->write_value(gyro_sample(2)).has_value());
  EXPECT_TRUE(readable_within(r->ready_fd(), kLiveness));
  auto n = r->take([](std::span<const std::byte>) {});
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(*n, 1U);
  EXPECT_FALSE(readable_now(r->ready_fd()));
}

TEST_F(DdsTest, Take_NoData_ReturnsZero) {
  Participant a = participant();
  auto r = Reader::create(a, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(r.has_value());
  auto n = r->take([](std::span<const std::byte>) { ADD_FAILURE() << "no sample expected"; });
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(*n, 0U);
}

TEST_F(DdsTest, Take_MoreThanOneBatch_AllInPublishOrder) {
  Participant a = participant();
  Participant b = participant();
  const EndpointQos deep{.history_depth = 100, .ignore_local = IgnoreLocal::Participant};
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type(), deep);
  auto r = Reader::create(b, "rejuv/test_gyro", gyro_type(), deep);
  ASSERT_TRUE(w && r);
  connect(*w, *r);
  constexpr std::uint64_t kCount = 75;  // > the take batch of 32
  for (std::uint64_t i = 0; i < kCount; ++i) {
    ASSERT_TRUE(w->write_value(gyro_sample(i)).has_value());
  }
  const auto got = take_gyros(*r, kCount);
  ASSERT_EQ(got.size(), kCount);
  for (std::uint64_t i = 0; i < kCount; ++i) {
    EXPECT_EQ(got[i].timestamp_ns, i);
  }
}

TEST_F(DdsTest, MultipleTopics_EachReaderGetsOnlyItsTopic) {
  Participant a = participant();
  Participant b = participant();
  auto wg = Writer::create(a, "rejuv/test_gyro", gyro_type());
  auto wa = Writer::create(a, "rejuv/test_accel", accel_type());
  auto wg2 = Writer::create(a, "rejuv/test_gyro_2", gyro_type());  // same type, other topic
  auto rg = Reader::create(b, "rejuv/test_gyro", gyro_type());
  auto ra = Reader::create(b, "rejuv/test_accel", accel_type());
  auto rg2 = Reader::create(b, "rejuv/test_gyro_2", gyro_type());
  ASSERT_TRUE(wg && wa && wg2 && rg && ra && rg2);
  connect(*wg, *rg);
  connect(*wa, *ra);
  connect(*wg2, *rg2);

  for (std::uint64_t i = 0; i < 3; ++i) ASSERT_TRUE(wg->write_value(gyro_sample(i)).has_value());
  for (std::uint64_t i = 0; i < 2; ++i) {
    rejuv_msg_SensorAccel acc{};
    acc.timestamp_ns = 100 + i;
    ASSERT_TRUE(wa->write_value(acc).has_value());
  }
  ASSERT_TRUE(wg2->write_value(gyro_sample(200)).has_value());

  const auto gyros = take_gyros(*rg, 3);
  const auto gyros2 = take_gyros(*rg2, 1);
  std::vector<std::uint64_t> accels;
  const auto deadline = std::chrono::steady_clock::now() + kLiveness;
  while (accels.size() < 2 && std::chrono::steady_clock::now() < deadline) {
    if (!readable_within(ra->ready_fd(), 100ms)) continue;
    ASSERT_TRUE(ra->take_as<rejuv_msg_SensorAccel>([&](const rejuv_msg_SensorAccel& s) {
                    accels.push_back(s.timestamp_ns);
                  }).has_value());
  }
  ASSERT_EQ(gyros.size(), 3U);
  EXPECT_EQ(gyros[2].timestamp_ns, 2U);
  EXPECT_EQ(accels, (std::vector<std::uint64_t>{100, 101}));
  ASSERT_EQ(gyros2.size(), 1U);
  EXPECT_EQ(gyros2[0].timestamp_ns, 200U);
  // Nothing of the other topics leaked into the first gyro reader.
  auto extra = rg->take([](std::span<const std::byte>) {});
  ASSERT_TRUE(extra.has_value());
  EXPECT_EQ(*extra, 0U);
}

TEST_F(DdsTest, IgnoreLocalParticipant_SameParticipant_NotMatched) {
  Participant a = participant();
  Participant b = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  auto local = Reader::create(a, "rejuv/test_gyro", gyro_type());
  auto remote = Reader::create(b, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w && local && remote);
  connect(*w, *remote);
  // Local matching is immediate in Cyclone, so by now the local reader would be matched if it were going to.
  EXPECT_EQ(w->matched_readers().value_or(99), 1U);
  EXPECT_EQ(local->matched_writers().value_or(99), 0U);

  ASSERT_TRUE(w->write_value(gyro_sample(5)).has_value());
  ASSERT_EQ(take_gyros(*remote, 1).size(), 1U);  // the remote copy has arrived ...
  auto n = local->take([](std::span<const std::byte>) {});
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(*n, 0U);  // ... and the kernel does not hear itself (docs/design.md §5)
}

TEST_F(DdsTest, IgnoreLocalNone_SameParticipant_RoundTrip) {
  Participant a = participant();
  const EndpointQos hear_self{.history_depth = 4, .ignore_local = IgnoreLocal::None};
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type(), hear_self);
  auto r = Reader::create(a, "rejuv/test_gyro", gyro_type(), hear_self);
  ASSERT_TRUE(w && r);
  connect(*w, *r);
  ASSERT_TRUE(w->write_value(gyro_sample(9)).has_value());
  const auto got = take_gyros(*r, 1);
  ASSERT_EQ(got.size(), 1U);
  EXPECT_EQ(got[0].timestamp_ns, 9U);
}

TEST_F(DdsTest, Write_MisalignedPayload_DeliveredIntact) {
  Participant a = participant();
  Participant b = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  auto r = Reader::create(b, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w && r);
  connect(*w, *r);
  const rejuv_msg_SensorGyro sent = gyro_sample(3);
  alignas(8) std::array<std::byte, sizeof sent + 1> buffer{};
  std::memcpy(buffer.data() + 1, &sent, sizeof sent);
  ASSERT_TRUE(w->write(std::span(buffer).subspan(1)).has_value());
  const auto got = take_gyros(*r, 1);
  ASSERT_EQ(got.size(), 1U);
  EXPECT_EQ(std::memcmp(&got[0], &sent, sizeof sent), 0);
}

// A sample's padding arrives as zero whatever the heap held where the reader's take buffers were allocated:
// Cyclone writes the members, not the padding (SensorGps: 6 bytes after satellites_used), and the buffers are
// zero in every byte. The heap is first filled with a pattern in blocks of the sizes a take buffer has, and
// freed, so that the reader's buffers are likely made of that memory.
TEST_F(DdsTest, Take_SampleWithPadding_PaddingZeroWhateverTheHeapHeld) {
  Participant a = participant();
  Participant b = participant();
  const msgs::TopicType& gps_type = type_named(msgs::TopicTraits<rejuv_msg_SensorGps>::name);
  auto w = Writer::create(a, "rejuv/test_gps", gps_type);
  ASSERT_TRUE(w.has_value());
  {
    std::vector<std::vector<std::byte>> dirt;
    for (std::size_t size = 512; size <= 16384; size += 32) dirt.emplace_back(size, std::byte{0xA5});
  }
  auto r = Reader::create(b, "rejuv/test_gps", gps_type);
  ASSERT_TRUE(r.has_value());
  connect(*w, *r);

  rejuv_msg_SensorGps sent;
  std::memset(&sent, 0, sizeof sent);  // zero padding too, which `sent{}` need not give
  sent.timestamp_ns = 7;
  sent.p_N_m[2] = -3.0;
  sent.fix_type = 3;
  sent.satellites_used = 10;
  static_assert(sizeof sent > offsetof(rejuv_msg_SensorGps, satellites_used) + 1, "SensorGps has tail padding");
  ASSERT_TRUE(w->write_value(sent).has_value());

  ASSERT_TRUE(readable_within(r->ready_fd(), kLiveness));
  std::vector<std::byte> received;
  auto n = r->take([&](std::span<const std::byte> bytes) { received.assign(bytes.begin(), bytes.end()); });
  ASSERT_TRUE(n.has_value());
  ASSERT_EQ(received.size(), sizeof sent);
  for (std::size_t i = offsetof(rejuv_msg_SensorGps, satellites_used) + 1; i < sizeof sent; ++i) {
    EXPECT_EQ(received[i], std::byte{0}) << "padding byte " << i;
  }
  EXPECT_EQ(std::memcmp(received.data(), &sent, sizeof sent), 0);
}

TEST_F(DdsTest, Reader_MovedAfterCreate_ListenerStillSignals) {
  Participant a = participant();
  Participant b = participant();
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type());
  auto created = Reader::create(b, "rejuv/test_gyro", gyro_type());
  ASSERT_TRUE(w && created);
  Reader moved = std::move(*created);
  EXPECT_FALSE(created->valid());  // NOLINT(bugprone-use-after-move): the moved-from state is the point
  EXPECT_EQ(created->ready_fd(), -1);
  connect(*w, moved);
  ASSERT_TRUE(w->write_value(gyro_sample(11)).has_value());
  EXPECT_TRUE(readable_within(moved.ready_fd(), kLiveness));
  EXPECT_EQ(take_gyros(moved, 1).size(), 1U);
}

TEST_F(DdsTest, Create_HistoryDepthZero_BadArgument) {
  Participant a = participant();
  const EndpointQos none{.history_depth = 0, .ignore_local = IgnoreLocal::Participant};
  auto w = Writer::create(a, "rejuv/test_gyro", gyro_type(), none);
  auto r = Reader::create(a, "rejuv/test_gyro", gyro_type(), none);
  ASSERT_FALSE(w.has_value());
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(w.error().kind, DdsError::Kind::BadArgument);
  EXPECT_EQ(r.error().kind, DdsError::Kind::BadArgument);
}

TEST_F(DdsTest, Create_EmptyTopicName_BadArgument) {
  Participant a = participant();
  auto w = Writer::create(a, "", gyro_type());
  ASSERT_FALSE(w.has_value());
  EXPECT_EQ(w.error().kind, DdsError::Kind::BadArgument);
}

TEST_F(DdsTest, Create_InvalidTopicName_DdsErrorWithCycloneText) {
  Participant a = participant();
  auto w = Writer::create(a, "bad topic name with spaces", gyro_type());
  ASSERT_FALSE(w.has_value());
  EXPECT_EQ(w.error().kind, DdsError::Kind::Dds);
  EXPECT_LT(w.error().code, 0);
  EXPECT_EQ(w.error().text(), dds_strretcode(w.error().code));
  EXPECT_NE(w.error().to_string().find("dds_create_topic"), std::string::npos) << w.error().to_string();
}

TEST_F(DdsTest, Participant_DomainOutOfRange_BadArgument) {
  auto p = Participant::create(DomainId{kMaxDomainId + 1});
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().kind, DdsError::Kind::BadArgument);
}

TEST_F(DdsTest, Participant_Moved_SourceEmptyAndEndpointsStillWork) {
  Participant a = participant();
  Participant moved = std::move(a);
  EXPECT_FALSE(a.valid());  // NOLINT(bugprone-use-after-move)
  EXPECT_TRUE(moved.valid());
  a.reset();  // resetting an empty handle is safe
  auto w = Writer::create(moved, "rejuv/test_gyro", gyro_type());
  EXPECT_TRUE(w.has_value());
}

TEST_F(DdsTest, WaitForReaders_NoneExists_Timeout) {
  Participant a = participant();
  auto w = Writer::create(a, "rejuv/test_nobody_listens", gyro_type());
  ASSERT_TRUE(w.has_value());
  auto waited = w->wait_for_readers(1, 0ms);
  ASSERT_FALSE(waited.has_value());
  EXPECT_EQ(waited.error().kind, DdsError::Kind::Timeout);
}

TEST_F(DdsTest, PlantTopics_EveryTopic_CreatesWithItsType) {
  Participant a = participant();
  namespace pt = plant_topics;
  const auto check = [&](auto topic) {
    auto w = Writer::create(a, topic.name, pt::type_of(topic));
    ASSERT_TRUE(w.has_value()) << topic.name << ": " << w.error().to_string();
    EXPECT_EQ(w->type().size, sizeof(typename decltype(topic)::type));
  };
  check(pt::kSensorGyro);
  check(pt::kSensorAccel);
  check(pt::kSensorMag);
  check(pt::kSensorBaro);
  check(pt::kSensorGps);
  check(pt::kGroundTruth);
  check(pt::kActuatorOutputs);
  check(pt::kSimStep);
  check(pt::kSimStepAck);
}

}  // namespace
}  // namespace rejuv::dds
