// One test per BrokerError (sel4test style): the smallest request refused with exactly that error, and
// "a refused request leaves no trace" checked through the checkpoint state where the request could change it.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "broker_fixture.hpp"

namespace rejuv::broker {
namespace {

using namespace rejuv::broker::testing;

Result<Broker, ConfigError> create_with(TopicConfig bad) {
  auto config = small_config();
  config.push_back(std::move(bad));
  return Broker::create(config);
}

void expect_config_error(const Result<Broker, ConfigError>& r, BrokerError want, std::size_t index) {
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().error, want) << r.error().to_string();
  EXPECT_EQ(r.error().topic_index, index);
  EXPECT_FALSE(r.error().message.empty());
}

TEST(BrokerError, BadConfig_DepthNotPowerOfTwo_Refused) {
  expect_config_error(create_with({.object = ObjectId{20}, .name = "t", .payload_size = 8, .depth = 3}),
                      BrokerError::BadConfig, 3);
}

TEST(BrokerError, BadConfig_DepthZero_Refused) {
  expect_config_error(create_with({.object = ObjectId{20}, .name = "t", .payload_size = 8, .depth = 0}),
                      BrokerError::BadConfig, 3);
}

TEST(BrokerError, BadConfig_DepthAboveMax_Refused) {
  expect_config_error(
      create_with({.object = ObjectId{20}, .name = "t", .payload_size = 8, .depth = 2 * kMaxDepth}),
      BrokerError::BadConfig, 3);
}

TEST(BrokerError, BadConfig_PayloadSizeZero_Refused) {
  expect_config_error(create_with({.object = ObjectId{20}, .name = "t", .payload_size = 0, .depth = 4}),
                      BrokerError::BadConfig, 3);
}

TEST(BrokerError, BadConfig_PayloadAboveMax_Refused) {
  expect_config_error(
      create_with({.object = ObjectId{20}, .name = "t", .payload_size = kMaxPayloadBytes + 1, .depth = 4}),
      BrokerError::BadConfig, 3);
}

TEST(BrokerError, BadConfig_EmptyName_Refused) {
  expect_config_error(create_with({.object = ObjectId{20}, .name = "", .payload_size = 8, .depth = 4}),
                      BrokerError::BadConfig, 3);
}

TEST(BrokerError, BadConfig_ObjectIdAboveMax_Refused) {
  expect_config_error(
      create_with({.object = ObjectId{kMaxTopicObjectId + 1}, .name = "t", .payload_size = 8, .depth = 4}),
      BrokerError::BadConfig, 3);
}

TEST(BrokerError, BadConfig_LimitsThemselves_Accepted) {
  auto b = Broker::create(std::vector<TopicConfig>{
      {.object = ObjectId{kMaxTopicObjectId}, .name = "t", .payload_size = kMaxPayloadBytes, .depth = 1},
      {.object = ObjectId{0}, .name = "u", .payload_size = 1, .depth = kMaxDepth}});
  EXPECT_TRUE(b.has_value());
}

TEST(BrokerError, DuplicateTopic_SameObject_Refused) {
  expect_config_error(create_with({.object = kState, .name = "other", .payload_size = 8, .depth = 4}),
                      BrokerError::DuplicateTopic, 3);
}

TEST(BrokerError, DuplicateTopic_SameName_Refused) {
  expect_config_error(
      create_with({.object = ObjectId{20}, .name = "vehicle_state", .payload_size = 8, .depth = 4}),
      BrokerError::DuplicateTopic, 3);
}

TEST(BrokerError, UnknownTopic_Publish_RefusedAndNothingChanged) {
  Broker b = make_broker();
  const BrokerSnapshot before = b.snapshot();
  auto r = b.publish(kNoSuchTopic, payload(kGyroSize, 1), Nanos{0});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::UnknownTopic);
  EXPECT_EQ(b.snapshot(), before);
}

TEST(BrokerError, UnknownTopic_ObjectBeyondTable_Refused) {
  Broker b = make_broker();
  auto r = b.publish(ObjectId{kMaxTopicObjectId}, payload(kGyroSize, 1), Nanos{0});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::UnknownTopic);
}

TEST(BrokerError, UnknownTopic_Subscribe_Refused) {
  Broker b = make_broker();
  auto r = b.subscribe(kEkf2, kNoSuchTopic, SubscriberKind::Rejuvenated);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::UnknownTopic);
  EXPECT_EQ(b.subscriber_count(), 0U);
}

TEST(BrokerError, UnknownTopic_Inspection_Refused) {
  Broker b = make_broker();
  EXPECT_EQ(b.subscribers_of(kNoSuchTopic).error(), BrokerError::UnknownTopic);
  EXPECT_EQ(b.head(kNoSuchTopic).error(), BrokerError::UnknownTopic);
  EXPECT_EQ(b.topic_stats(kNoSuchTopic).error(), BrokerError::UnknownTopic);
}

TEST(BrokerError, WrongSize_OneByteLonger_RefusedAndNothingChanged) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  publish_tagged(b, kState, kStateSize, 1);
  const BrokerSnapshot before = b.snapshot();
  auto r = b.publish(kState, payload(kStateSize + 1, 2), Nanos{0});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::WrongSize);
  EXPECT_EQ(b.snapshot(), before);
  EXPECT_EQ(b.topic_stats(kState)->published, 1U);
  EXPECT_EQ(*b.pending(s), 1U);
}

TEST(BrokerError, WrongSize_OneByteShorter_Refused) {
  Broker b = make_broker();
  auto r = b.publish(kState, payload(kStateSize - 1, 2), Nanos{0});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::WrongSize);
  EXPECT_EQ(b.head(kState)->value(), 0U);
}

TEST(BrokerError, WrongSize_Empty_Refused) {
  Broker b = make_broker();
  auto r = b.publish(kMode, std::span<const std::byte>{}, Nanos{0});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::WrongSize);
}

TEST(BrokerError, UnknownSubscriber_NeverIssued_Refused) {
  Broker b = make_broker();
  EXPECT_EQ(b.next(SubscriberId{0}).error(), BrokerError::UnknownSubscriber);
  EXPECT_EQ(b.pending(SubscriberId{0}).error(), BrokerError::UnknownSubscriber);
  EXPECT_EQ(b.subscriber_stats(SubscriberId{0}).error(), BrokerError::UnknownSubscriber);
  EXPECT_EQ(b.subscriber(SubscriberId{0}).error(), BrokerError::UnknownSubscriber);
  EXPECT_EQ(b.unsubscribe(SubscriberId{0}).error(), BrokerError::UnknownSubscriber);
}

TEST(BrokerError, UnknownSubscriber_AfterUnsubscribe_Refused) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  ASSERT_TRUE(b.unsubscribe(s).has_value());
  EXPECT_EQ(b.next(s).error(), BrokerError::UnknownSubscriber);
  EXPECT_EQ(b.unsubscribe(s).error(), BrokerError::UnknownSubscriber);
}

TEST(BrokerError, UnknownSubscriber_AfterRemoveService_Refused) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  EXPECT_EQ(b.remove_service(kEkf2), 1U);
  EXPECT_EQ(b.next(s).error(), BrokerError::UnknownSubscriber);
}

TEST(BrokerError, UnknownSubscriber_IdNotReusedAfterUnsubscribe_Refused) {
  Broker b = make_broker();
  const SubscriberId old = subscribe_ok(b, kEkf2, kState);
  ASSERT_TRUE(b.unsubscribe(old).has_value());
  const SubscriberId fresh = subscribe_ok(b, kEkf2, kState);
  EXPECT_NE(fresh, old);
  EXPECT_EQ(b.next(old).error(), BrokerError::UnknownSubscriber);
}

TEST(BrokerError, AlreadySubscribed_SameServiceAndTopic_RefusedAndNothingChanged) {
  Broker b = make_broker();
  subscribe_ok(b, kEkf2, kState);
  const BrokerSnapshot before = b.snapshot();
  auto r = b.subscribe(kEkf2, kState, SubscriberKind::Rejuvenated);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::AlreadySubscribed);
  EXPECT_EQ(b.subscriber_count(), 1U);
  EXPECT_EQ(b.subscribers_of(kState)->size(), 1U);
  EXPECT_EQ(b.snapshot(), before);
}

TEST(BrokerError, AlreadySubscribed_OtherKind_Refused) {
  Broker b = make_broker();
  subscribe_ok(b, kEkf2, kState);
  auto r = b.subscribe(kEkf2, kState, SubscriberKind::Driver);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::AlreadySubscribed);
}

TEST(BrokerError, SnapshotMismatch_OtherTopicSet_RefusedAndNothingChanged) {
  Broker b = make_broker();
  auto other_config = small_config();
  other_config[1].depth = 16;  // same topics, other ring depth: another layout
  Broker other = make_broker(other_config);
  publish_tagged(b, kState, kStateSize, 1);
  const BrokerSnapshot before = b.snapshot();
  auto r = b.restore(other.snapshot());
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::SnapshotMismatch);
  EXPECT_EQ(b.snapshot(), before);
}

TEST(BrokerError, SnapshotMismatch_EmptySnapshot_Refused) {
  Broker b = make_broker();
  auto r = b.restore(BrokerSnapshot{});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::SnapshotMismatch);
}

TEST(BrokerError, SnapshotMismatch_EmptySnapshotOnEmptyBroker_Refused) {
  Broker b = make_broker({});
  auto r = b.restore(BrokerSnapshot{});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), BrokerError::SnapshotMismatch);
}

TEST(BrokerError, ToString_EveryError_DistinctName) {
  const std::array all{BrokerError::BadConfig,         BrokerError::DuplicateTopic,
                       BrokerError::UnknownTopic,      BrokerError::WrongSize,
                       BrokerError::UnknownSubscriber, BrokerError::AlreadySubscribed,
                       BrokerError::SnapshotMismatch};
  std::set<std::string_view> names;
  for (BrokerError e : all) {
    EXPECT_NE(to_string(e), "BrokerError(?)");
    names.insert(to_string(e));
  }
  EXPECT_EQ(names.size(), all.size());
}

}  // namespace
}  // namespace rejuv::broker
