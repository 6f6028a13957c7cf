// The generic bridge (rejuv/dds/bridge.hpp) and the plant-lockstep adapter on it (plant_lockstep.hpp) in one
// process: the bridge on one participant, the test playing the plant on another, on a private domain. And the
// step table both ends pack and unpack through (plant_topics.hpp, kStepSamples).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "dds_test_support.hpp"
#include "rejuv/dds/bridge.hpp"
#include "rejuv/dds/plant_lockstep.hpp"
#include "rejuv/dds/plant_topics.hpp"
#include "rejuv/dds/run_partition.hpp"

namespace rejuv::dds {
namespace {

using namespace std::chrono_literals;
using test_support::kLiveness;
using test_support::readable_within;
namespace pt = plant_topics;

constexpr std::size_t kTopics = 8;  // kernel topics of the tests: ObjectIds 0..7

rejuv_msg_SensorGyro gyro(std::uint64_t t) {
  rejuv_msg_SensorGyro g{};
  g.timestamp_ns = t;
  g.omega_B_rad_s[0] = 0.5;
  return g;
}

rejuv_msg_ActuatorOutputs outputs(double level) {
  rejuv_msg_ActuatorOutputs u{};
  for (double& m : u.motor) m = level;
  return u;
}

template <class T>
std::span<const std::byte> bytes_of(const T& value) {
  return std::as_bytes(std::span<const T, 1>(&value, 1));
}

class BridgeTest : public ::testing::Test {
 protected:
  void SetUp() override { test_support::use_loopback_config(); }

  static Participant peer() {
    auto p = Participant::create(test_support::test_domain());
    REJUV_ASSERT(p.has_value(), "participant on the test domain");
    return std::move(*p);
  }
  static Bridge open(std::span<const BridgeEntry> table) {
    auto b = Bridge::open(test_support::test_domain(), "", table, kTopics);
    REJUV_ASSERT(b.has_value(), "a bridge on the test domain");
    return std::move(*b);
  }
  template <class T>
  static BridgeEntry row(std::uint32_t topic, pt::Topic<T> t, Direction direction) {
    return BridgeEntry{.topic = ObjectId{topic}, .dds_name = std::string(t.name), .type = &pt::type_of(t),
                       .direction = direction};
  }
  // Takes from `r` until `count` samples of T arrived (bounded: a liveness guard, not a timing).
  template <class T>
  static std::vector<T> take(Reader& r, std::size_t count) {
    std::vector<T> got;
    const auto deadline = std::chrono::steady_clock::now() + kLiveness;
    while (got.size() < count && std::chrono::steady_clock::now() < deadline) {
      if (!readable_within(r.ready_fd(), 100ms)) continue;
      EXPECT_TRUE(r.take_as<T>([&](const T& v) { got.push_back(v); }).has_value());
    }
    return got;
  }
};

TEST_F(BridgeTest, Open_Table_OneEndpointPerRowInputsInTableOrder) {
  const std::vector<BridgeEntry> table = {row(3, pt::kSensorGyro, Direction::In),
                                          row(5, pt::kActuatorOutputs, Direction::Out),
                                          row(1, pt::kSensorBaro, Direction::In)};
  Bridge b = open(table);
  ASSERT_EQ(b.inputs().size(), 2U);
  EXPECT_EQ(b.inputs()[0].topic, ObjectId{3});
  EXPECT_EQ(b.inputs()[0].reader.topic_name(), pt::kSensorGyro.name);
  EXPECT_EQ(b.inputs()[1].topic, ObjectId{1});
  EXPECT_EQ(b.find_input(pt::kSensorBaro.name, pt::type_of(pt::kSensorBaro)), 1U);
  EXPECT_FALSE(b.find_input(pt::kSensorBaro.name, pt::type_of(pt::kSensorGyro)).has_value());  // another type
  EXPECT_TRUE(b.bridges_in(pt::kSensorGyro.name));
  EXPECT_FALSE(b.bridges_in(pt::kSensorMag.name));
  EXPECT_NE(b.output(ObjectId{5}), nullptr);
  EXPECT_EQ(b.output(ObjectId{3}), nullptr);  // bridged in, not out
  EXPECT_EQ(b.find_output(pt::kActuatorOutputs.name, pt::type_of(pt::kActuatorOutputs)), ObjectId{5});
}

TEST_F(BridgeTest, WriteOut_TopicNotBridgedOut_FalseAndNothingWritten) {
  const std::vector<BridgeEntry> table = {row(3, pt::kSensorGyro, Direction::In)};
  Bridge b = open(table);
  const rejuv_msg_SensorGyro g = gyro(1);
  auto wrote = b.write_out(ObjectId{3}, bytes_of(g));
  ASSERT_TRUE(wrote.has_value());
  EXPECT_FALSE(*wrote);
}

TEST_F(BridgeTest, WriteOut_BridgedOut_PeerReceivesSameBytes) {
  const std::vector<BridgeEntry> table = {row(2, pt::kActuatorOutputs, Direction::Out)};
  Bridge b = open(table);
  Participant plant = peer();
  auto r = Reader::create(plant, pt::kActuatorOutputs.name, pt::type_of(pt::kActuatorOutputs));
  ASSERT_TRUE(r.has_value());
  ASSERT_TRUE(b.output(ObjectId{2})->writer.wait_for_readers(1, kLiveness).has_value());
  const rejuv_msg_ActuatorOutputs u = outputs(0.25);
  auto wrote = b.write_out(ObjectId{2}, bytes_of(u));
  ASSERT_TRUE(wrote.has_value()) << wrote.error().to_string();
  EXPECT_TRUE(*wrote);
  const auto got = take<rejuv_msg_ActuatorOutputs>(*r, 1);
  ASSERT_EQ(got.size(), 1U);
  // Field by field: the struct's tail padding is not on the wire, and the reader's copy of it is whatever its
  // allocator left there (0xbe under AddressSanitizer).
  EXPECT_EQ(got[0].timestamp_ns, u.timestamp_ns);
  EXPECT_EQ(std::memcmp(got[0].motor, u.motor, sizeof(u.motor)), 0);
  EXPECT_EQ(got[0].limits_restricted, u.limits_restricted);
}

TEST_F(BridgeTest, WriteOut_WrongPayloadSize_WriteErrorNamingTheTopic) {
  const std::vector<BridgeEntry> table = {row(2, pt::kActuatorOutputs, Direction::Out)};
  Bridge b = open(table);
  const std::array<std::byte, 3> short_payload{};
  auto wrote = b.write_out(ObjectId{2}, short_payload);
  ASSERT_FALSE(wrote.has_value());
  EXPECT_EQ(wrote.error().kind, BridgeError::Kind::Write);
  EXPECT_EQ(wrote.error().topic, pt::kActuatorOutputs.name);
  EXPECT_EQ(wrote.error().cause.kind, DdsError::Kind::SizeMismatch);
  EXPECT_EQ(wrote.error().to_string().rfind("DDS write rejuv/actuator_outputs: ", 0), 0U) << wrote.error().to_string();
}

// A run's partition (run_partition.hpp): a peer in the bridge's partition hears its outputs and is heard on its
// inputs; a peer on the same domain and topics in another run's partition (or the default one) is matched to
// nothing.
TEST_F(BridgeTest, Partition_PeerOfTheSameRunMatchedPeerOfAnotherRunNot) {
  const std::string mine = run_partition(RunId{0x1111222233334444ULL});
  const std::string theirs = run_partition(RunId{0x5555666677778888ULL});
  const std::vector<BridgeEntry> table = {row(2, pt::kActuatorOutputs, Direction::Out),
                                          row(3, pt::kSensorGyro, Direction::In)};
  auto opened = Bridge::open(test_support::test_domain(), mine, table, kTopics);
  ASSERT_TRUE(opened.has_value()) << opened.error().to_string();
  Bridge& b = *opened;
  EXPECT_EQ(b.partition(), mine);
  Participant plant = peer();
  auto other_run = Reader::create(plant, pt::kActuatorOutputs.name, pt::type_of(pt::kActuatorOutputs),
                                  EndpointQos{.partition = theirs});
  auto default_partition = Reader::create(plant, pt::kActuatorOutputs.name, pt::type_of(pt::kActuatorOutputs));
  auto same_run = Reader::create(plant, pt::kActuatorOutputs.name, pt::type_of(pt::kActuatorOutputs),
                                 EndpointQos{.partition = mine});
  auto other_writer = Writer::create(plant, pt::kSensorGyro.name, pt::type_of(pt::kSensorGyro),
                                     EndpointQos{.partition = theirs});
  ASSERT_TRUE(other_run && default_partition && same_run && other_writer);
  // The same run's reader matches; once it has, discovery has seen every endpoint of the peer.
  ASSERT_TRUE(b.output(ObjectId{2})->writer.wait_for_readers(1, kLiveness).has_value());
  ASSERT_TRUE(same_run->wait_for_writers(1, kLiveness).has_value());
  const rejuv_msg_ActuatorOutputs u = outputs(0.5);
  ASSERT_TRUE(b.write_out(ObjectId{2}, bytes_of(u)).has_value());
  ASSERT_EQ(take<rejuv_msg_ActuatorOutputs>(*same_run, 1).size(), 1U);
  EXPECT_EQ(*b.output(ObjectId{2})->writer.matched_readers(), 1U);  // not the other run's, not the default's
  EXPECT_EQ(*other_run->matched_writers(), 0U);
  EXPECT_EQ(*default_partition->matched_writers(), 0U);
  EXPECT_EQ(*b.inputs()[0].reader.matched_writers(), 0U);  // the other run's gyro writer
  EXPECT_EQ(*other_writer->matched_readers(), 0U);
  // Nothing arrives in the other partitions (a bounded look, not a timing: nothing should ever arrive).
  EXPECT_FALSE(readable_within(other_run->ready_fd(), 200ms));
  EXPECT_FALSE(readable_within(default_partition->ready_fd(), 10ms));
}

TEST(RunPartition, RunIdPrintedAsSixteenHexDigitsAndParsedBack) {
  EXPECT_EQ(to_string(RunId{0xabcULL}), "0000000000000abc");
  EXPECT_EQ(run_partition(RunId{0xabcULL}), "rejuv.0000000000000abc");
  const RunId fresh = random_run_id();
  EXPECT_EQ(parse_run_id(to_string(fresh)), fresh);
  EXPECT_EQ(parse_run_id("FFFFFFFFFFFFFFFF"), RunId{~0ULL});
  EXPECT_FALSE(parse_run_id("abc").has_value());
  EXPECT_FALSE(parse_run_id("0x00000000000abc").has_value());
  EXPECT_FALSE(parse_run_id("-000000000000abc").has_value());
}

TEST(RunPartition, RandomRunIds_Differ) {
  // 64 random bits: two equal in a row would be a broken source, not bad luck (2^-64).
  EXPECT_NE(random_run_id(), random_run_id());
}

TEST_F(BridgeTest, Open_DomainOutOfRange_ParticipantError) {
  auto b = Bridge::open(DomainId{kMaxDomainId + 1}, "", {}, kTopics);
  ASSERT_FALSE(b.has_value());
  EXPECT_EQ(b.error().kind, BridgeError::Kind::Participant);
  EXPECT_EQ(b.error().cause.kind, DdsError::Kind::BadArgument);
}

TEST_F(BridgeTest, AddInput_EmptyName_ReaderError) {
  Bridge b = open({});
  auto added = b.add_input("", pt::type_of(pt::kSimStep));
  ASSERT_FALSE(added.has_value());
  EXPECT_EQ(added.error().kind, BridgeError::Kind::Reader);
}

// ---- the plant-lockstep adapter ----

TEST_F(BridgeTest, PlantLockstepOpen_GyroBridged_CountOnlyInputForEveryOtherSampleTopicThenStepLast) {
  const std::vector<BridgeEntry> table = {row(3, pt::kSensorGyro, Direction::In)};
  Bridge b = open(table);
  auto lockstep = PlantLockstep::open(b, DdsNaming::Rejuv);
  ASSERT_TRUE(lockstep.has_value()) << lockstep.error().to_string();
  // gyro (routed), then accel, mag, baro, gps, ground truth (count-only), then sim_step.
  ASSERT_EQ(b.inputs().size(), 1 + (pt::kStepSampleKinds - 1) + 1);
  EXPECT_EQ(lockstep->step_input(), b.inputs().size() - 1);
  EXPECT_EQ(b.inputs()[lockstep->step_input()].reader.topic_name(), pt::kSimStep.name);
  for (std::size_t i = 1; i < lockstep->step_input(); ++i) EXPECT_FALSE(b.inputs()[i].topic.has_value()) << i;
  EXPECT_EQ(b.inputs()[1].reader.topic_name(), pt::kSensorAccel.name);
}

TEST_F(BridgeTest, PlantLockstepTakeSteps_CarriedSamples_StagedAsTheInputBridgingTheirTopic) {
  // gyro and ground truth bridged in (inputs 0 and 1); accel is not: its carried sample is dropped.
  const std::vector<BridgeEntry> table = {row(3, pt::kSensorGyro, Direction::In),
                                          row(4, pt::kGroundTruth, Direction::In)};
  Bridge b = open(table);
  auto lockstep = PlantLockstep::open(b, DdsNaming::Rejuv);
  ASSERT_TRUE(lockstep.has_value());
  Participant plant = peer();
  auto w = Writer::create(plant, pt::kSimStep.name, pt::type_of(pt::kSimStep));
  ASSERT_TRUE(w.has_value());
  ASSERT_TRUE(w->wait_for_readers(1, kLiveness).has_value());

  rejuv_msg_SimStep step{};
  step.step = 7;
  step.time_ns = 28'000'000;
  step.samples_published = 3;
  ASSERT_TRUE(pt::step_kind_of<rejuv_msg_SensorGyro>().put(step, gyro(1)));
  ASSERT_TRUE(pt::step_kind_of<rejuv_msg_SensorGyro>().put(step, gyro(2)));
  step.accel_count = 1;
  step.ground_truth.timestamp_ns = 28'000'000;
  ASSERT_TRUE(w->write_value(step).has_value());

  std::vector<PlantLockstep::Step> steps;
  std::vector<std::pair<std::size_t, std::uint64_t>> staged;  // (input, timestamp)
  const int fd = b.inputs()[lockstep->step_input()].reader.ready_fd();
  const auto deadline = std::chrono::steady_clock::now() + kLiveness;
  while (steps.empty() && std::chrono::steady_clock::now() < deadline) {
    if (!readable_within(fd, 100ms)) continue;
    auto n = lockstep->take_steps(
        b, [&](const PlantLockstep::Step& s) { steps.push_back(s); },
        [&](std::size_t input, std::span<const std::byte> bytes) {
          std::uint64_t t = 0;
          std::memcpy(&t, bytes.data(), sizeof(t));
          staged.emplace_back(input, t);
        });
    ASSERT_TRUE(n.has_value());
  }
  ASSERT_EQ(steps.size(), 1U);
  EXPECT_EQ(steps[0].step, 7U);
  EXPECT_EQ(steps[0].t, Nanos{28'000'000});
  EXPECT_EQ(steps[0].samples_needed, 3U);
  const std::vector<std::pair<std::size_t, std::uint64_t>> want = {{0, 1}, {0, 2}, {1, 28'000'000}};
  EXPECT_EQ(staged, want);
}

TEST_F(BridgeTest, PlantLockstepWriteOut_ThreeOutputsInAStep_OldestOnTheTopicNewestTwoInTheAck) {
  const std::vector<BridgeEntry> table = {row(2, pt::kActuatorOutputs, Direction::Out)};
  Bridge b = open(table);
  auto lockstep = PlantLockstep::open(b, DdsNaming::Rejuv);
  ASSERT_TRUE(lockstep.has_value());
  Participant plant = peer();
  auto outs = Reader::create(plant, pt::kActuatorOutputs.name, pt::type_of(pt::kActuatorOutputs));
  auto acks = Reader::create(plant, pt::kSimStepAck.name, pt::type_of(pt::kSimStepAck));
  ASSERT_TRUE(outs && acks);

  for (const double level : {0.1, 0.2, 0.3}) {
    const rejuv_msg_ActuatorOutputs u = outputs(level);
    auto wrote = lockstep->write_out(b, ObjectId{2}, bytes_of(u));
    ASSERT_TRUE(wrote.has_value()) << wrote.error().to_string();
    EXPECT_TRUE(*wrote);
  }
  ASSERT_TRUE(lockstep->write_ack(9, Nanos{36'000'000}, Nanos{550'000}).has_value());

  const auto on_topic = take<rejuv_msg_ActuatorOutputs>(*outs, 1);
  ASSERT_EQ(on_topic.size(), 1U);
  EXPECT_EQ(on_topic[0].motor[0], 0.1);
  const auto ack = take<rejuv_msg_SimStepAck>(*acks, 1);
  ASSERT_EQ(ack.size(), 1U);
  EXPECT_EQ(ack[0].step, 9U);
  EXPECT_EQ(ack[0].time_ns, 36'000'000U);
  EXPECT_EQ(ack[0].charged_ns, 550'000U);
  EXPECT_EQ(ack[0].outputs_published, 1U);
  ASSERT_EQ(ack[0].outputs_count, 2U);
  EXPECT_EQ(ack[0].outputs[0].motor[0], 0.2);
  EXPECT_EQ(ack[0].outputs[1].motor[0], 0.3);
}

TEST_F(BridgeTest, PlantLockstepWriteOut_OtherTopic_WrittenThroughTheBridge) {
  const std::vector<BridgeEntry> table = {row(6, pt::kSensorGyro, Direction::Out)};
  Bridge b = open(table);
  auto lockstep = PlantLockstep::open(b, DdsNaming::Rejuv);
  ASSERT_TRUE(lockstep.has_value());
  const rejuv_msg_SensorGyro g = gyro(5);
  auto wrote = lockstep->write_out(b, ObjectId{6}, bytes_of(g));
  ASSERT_TRUE(wrote.has_value());
  EXPECT_TRUE(*wrote);
  auto unbridged = lockstep->write_out(b, ObjectId{7}, bytes_of(g));
  ASSERT_TRUE(unbridged.has_value());
  EXPECT_FALSE(*unbridged);
}

// ---- the step table ----

TEST(StepTable, PutThenSamples_EachKindRoundTripsAndAFullArrayRefuses) {
  rejuv_msg_SimStep step{};
  pt::for_each_step_kind([&](std::size_t /*row*/, const auto& kind) { kind.clear(step); });
  const auto& g = pt::step_kind_of<rejuv_msg_SensorGyro>();
  EXPECT_TRUE(g.put(step, gyro(1)));
  EXPECT_TRUE(g.put(step, gyro(2)));
  EXPECT_FALSE(g.put(step, gyro(3)));  // two fit (idl/sim.idl): the third goes out on its own topic
  ASSERT_EQ(g.samples(step).size(), 2U);
  EXPECT_EQ(g.samples(step)[1].timestamp_ns, 2U);
  EXPECT_TRUE(pt::step_kind_of<rejuv_msg_SensorMag>().samples(step).empty());
  EXPECT_EQ(pt::step_kind_of<rejuv_msg_GroundTruth>().samples(step).size(), 1U);  // always one
  step.gyro_count = 200;  // a count beyond the array (a corrupt step) is clamped
  EXPECT_EQ(g.samples(step).size(), 2U);
}

// The table's properties rather than a copy of it (a copy would be one more file for every new sensor): each
// row a plant topic of its own type, the sensors of the plant in their staging order, the ground truth (the
// one StepValue) last.
TEST(StepTable, Rows_OnePlantTopicPerTypeSensorsInStagingOrderGroundTruthLast) {
  std::vector<std::string_view> names;
  std::vector<std::string_view> types;
  pt::for_each_step_kind([&](std::size_t, const auto& kind) {
    names.push_back(kind.topic.name);
    types.push_back(pt::type_of(kind.topic).name);
    EXPECT_TRUE(kind.topic.name.starts_with("rejuv/")) << kind.topic.name;
  });
  ASSERT_EQ(names.size(), pt::kStepSampleKinds);
  for (std::size_t i = 0; i < names.size(); ++i) {
    for (std::size_t j = i + 1; j < names.size(); ++j) {
      EXPECT_NE(names[i], names[j]);
      EXPECT_NE(types[i], types[j]);  // step_row_of<T> finds one row per type
    }
  }
  const std::vector<std::string_view> sensors = {pt::kSensorGyro.name, pt::kSensorAccel.name, pt::kSensorMag.name,
                                                 pt::kSensorBaro.name, pt::kSensorGps.name};
  auto at = names.begin();
  for (std::string_view sensor : sensors) {
    at = std::find(at, names.end(), sensor);
    ASSERT_NE(at, names.end()) << sensor << " missing or out of order";
  }
  EXPECT_EQ(names.back(), pt::kGroundTruth.name);
  EXPECT_EQ(pt::step_row_of<rejuv_msg_GroundTruth>(), pt::kStepSampleKinds - 1);
}

// The plant's message type and a step's sample count come from the table, not from a list of sensors.
TEST(StepTable, SensorSampleAndSamplesIn_FollowTheTable) {
  EXPECT_EQ(std::variant_size_v<pt::SensorSample>, pt::kStepSampleKinds - 1);  // every row but the ground truth
  EXPECT_TRUE((std::is_same_v<std::variant_alternative_t<0, pt::SensorSample>, rejuv_msg_SensorGyro>));
  rejuv_msg_SimStep step{};
  EXPECT_EQ(pt::samples_in(step), 1U);  // the ground truth only
  EXPECT_TRUE(pt::step_kind_of<rejuv_msg_SensorGyro>().put(step, gyro(1)));
  EXPECT_TRUE(pt::step_kind_of<rejuv_msg_SensorGyro>().put(step, gyro(2)));
  EXPECT_TRUE(pt::step_kind_of<rejuv_msg_SensorMag>().put(step, rejuv_msg_SensorMag{}));
  EXPECT_EQ(pt::samples_in(step), 4U);
  step.gyro_count = 200;  // clamped to the array, as the kernel's adapter reads it
  EXPECT_EQ(pt::samples_in(step), 4U);
}

// A step's samples start with their uint64 timestamp_ns (the kernel orders staged samples by it); a struct
// that does not is refused at compile time.
static_assert(pt::StampedSample<rejuv_msg_SensorGyro>);
static_assert(pt::StampedSample<rejuv_msg_GroundTruth>);
static_assert(!pt::StampedSample<rejuv_msg_SimStep>);  // first member: step
struct TimestampSecond {
  double value;
  std::uint64_t timestamp_ns;
};
static_assert(!pt::StampedSample<TimestampSecond>);
struct StampOfAnotherType {
  double timestamp_ns;
};
static_assert(!pt::StampedSample<StampOfAnotherType>);

}  // namespace
}  // namespace rejuv::dds
