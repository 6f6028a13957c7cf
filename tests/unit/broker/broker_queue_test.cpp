// uORB queue semantics (docs/design.md §5): publish order, generations, overrun clamping with exact loss counts,
// isolation between subscribers, initial generation, routing lists and stats.
#include <gtest/gtest.h>

#include "broker_fixture.hpp"

namespace rejuv::broker {
namespace {

using namespace rejuv::broker::testing;

TEST(BrokerQueue, Publish_FreshTopic_ReturnsConsecutiveGenerations) {
  Broker b = make_broker();
  EXPECT_EQ(publish_tagged(b, kState, kStateSize, 10), TopicGeneration{0});
  EXPECT_EQ(publish_tagged(b, kState, kStateSize, 11), TopicGeneration{1});
  EXPECT_EQ(publish_tagged(b, kGyro, kGyroSize, 12), TopicGeneration{0});  // per topic
  EXPECT_EQ(b.head(kState)->value(), 2U);
}

TEST(BrokerQueue, Next_SeveralPublished_DeliveredInPublishOrderWithBytesAndTime) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  for (std::uint32_t tag = 0; tag < kStateDepth; ++tag) {
    publish_tagged(b, kState, kStateSize, tag);
  }
  for (std::uint32_t tag = 0; tag < kStateDepth; ++tag) {
    const Delivery d = next_ok(b, s);
    EXPECT_EQ(d.generation, TopicGeneration{tag});
    EXPECT_EQ(bytes_of(d.payload), payload(kStateSize, tag));
    EXPECT_EQ(d.published_at, Nanos{1000 + tag});
    EXPECT_EQ(d.lost, 0U);
  }
  EXPECT_TRUE(drained(b, s));
}

TEST(BrokerQueue, Next_NothingPublished_Empty) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  EXPECT_TRUE(drained(b, s));
  EXPECT_EQ(*b.pending(s), 0U);
}

TEST(BrokerQueue, Next_PayloadNotMultipleOfAlignment_ExactBytes) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kMode);
  publish_tagged(b, kMode, kModeSize, 42);
  const Delivery d = next_ok(b, s);
  EXPECT_EQ(d.payload.size(), kModeSize);
  EXPECT_EQ(bytes_of(d.payload), payload(kModeSize, 42));
}

TEST(BrokerQueue, Next_PayloadStartsAligned_ForInPlaceView) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kMode);
  publish_tagged(b, kMode, kModeSize, 1);
  const Delivery d = next_ok(b, s);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(d.payload.data()) % 16, 0U);
}

TEST(BrokerQueue, Overrun_QPlus3WithStalledSubscriber_LastQDeliveredWithLost3) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  for (std::uint32_t tag = 0; tag < kStateDepth + 3; ++tag) {
    publish_tagged(b, kState, kStateSize, tag);
  }
  EXPECT_EQ(*b.pending(s), kStateDepth);
  for (std::uint32_t i = 0; i < kStateDepth; ++i) {
    const Delivery d = next_ok(b, s);
    EXPECT_EQ(d.generation, TopicGeneration{3 + i});
    EXPECT_EQ(bytes_of(d.payload), payload(kStateSize, 3 + i));
    EXPECT_EQ(d.lost, i == 0 ? 3U : 0U);
  }
  EXPECT_TRUE(drained(b, s));
  EXPECT_EQ(*b.subscriber_stats(s), (SubscriberStats{.delivered = kStateDepth, .lost = 3}));
  EXPECT_EQ(*b.topic_stats(kState), (TopicStats{.published = kStateDepth + 3, .lost = 3}));
}

TEST(BrokerQueue, Overrun_DepthOne_OnlyLatestWithLossCounted) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kMode);
  for (std::uint32_t tag = 0; tag < 5; ++tag) {
    publish_tagged(b, kMode, kModeSize, tag);
  }
  const Delivery d = next_ok(b, s);
  EXPECT_EQ(d.generation, TopicGeneration{4});
  EXPECT_EQ(d.lost, 4U);
  EXPECT_TRUE(drained(b, s));
}

TEST(BrokerQueue, Overrun_StalledSubscriber_DoesNotAffectReadingOne) {
  Broker b = make_broker();
  const SubscriberId stalled = subscribe_ok(b, kEkf2, kGyro);
  const SubscriberId reader = subscribe_ok(b, kLqr, kGyro);
  for (std::uint32_t tag = 0; tag < 5 * kGyroDepth; ++tag) {
    EXPECT_TRUE(b.publish(kGyro, payload(kGyroSize, tag), Nanos{tag}).has_value());
    const Delivery d = next_ok(b, reader);
    EXPECT_EQ(d.generation, TopicGeneration{tag});
    EXPECT_EQ(d.lost, 0U);
  }
  EXPECT_EQ(*b.subscriber_stats(reader), (SubscriberStats{.delivered = 5 * kGyroDepth, .lost = 0}));
  EXPECT_EQ(*b.pending(stalled), kGyroDepth);
  EXPECT_EQ(next_ok(b, stalled).lost, 4U * kGyroDepth);
}

TEST(BrokerQueue, Overrun_TwoStalledSubscribers_TopicLossIsTheirSum) {
  Broker b = make_broker();
  const SubscriberId a = subscribe_ok(b, kEkf2, kGyro);
  const SubscriberId c = subscribe_ok(b, kLqr, kGyro);
  for (std::uint32_t tag = 0; tag < kGyroDepth + 2; ++tag) {
    publish_tagged(b, kGyro, kGyroSize, tag);
  }
  next_ok(b, a);
  next_ok(b, c);
  EXPECT_EQ(b.topic_stats(kGyro)->lost, 4U);
}

TEST(BrokerQueue, Pending_PartlyRead_CountsRest) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  publish_tagged(b, kState, kStateSize, 1);
  publish_tagged(b, kState, kStateSize, 2);
  publish_tagged(b, kState, kStateSize, 3);
  next_ok(b, s);
  EXPECT_EQ(*b.pending(s), 2U);
}

TEST(BrokerQueue, Subscribe_AfterPublishes_LatestMessageOnly) {
  Broker b = make_broker();
  publish_tagged(b, kState, kStateSize, 1);
  publish_tagged(b, kState, kStateSize, 2);
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  const Delivery d = next_ok(b, s);
  EXPECT_EQ(d.generation, TopicGeneration{1});
  EXPECT_EQ(bytes_of(d.payload), payload(kStateSize, 2));
  EXPECT_EQ(d.lost, 0U);  // it did not exist when the older one was published
  EXPECT_TRUE(drained(b, s));
}

TEST(BrokerQueue, SubscribersOf_ThreeSubscribers_RoutesInIdOrder) {
  Broker b = make_broker();
  const SubscriberId a = subscribe_ok(b, kEkf2, kState);
  subscribe_ok(b, kEkf2, kGyro);
  const SubscriberId c = subscribe_ok(b, kLqr, kState);
  const SubscriberId d = subscribe_ok(b, kDriver, kState, SubscriberKind::Driver);
  const auto routes = b.subscribers_of(kState);
  ASSERT_TRUE(routes.has_value());
  ASSERT_EQ(routes->size(), 3U);
  EXPECT_EQ((*routes)[0], (Route{.subscriber = a, .service = kEkf2, .kind = SubscriberKind::Rejuvenated}));
  EXPECT_EQ((*routes)[1], (Route{.subscriber = c, .service = kLqr, .kind = SubscriberKind::Rejuvenated}));
  EXPECT_EQ((*routes)[2], (Route{.subscriber = d, .service = kDriver, .kind = SubscriberKind::Driver}));
}

TEST(BrokerQueue, Unsubscribe_OneOfTwo_OtherStillRouted) {
  Broker b = make_broker();
  const SubscriberId a = subscribe_ok(b, kEkf2, kState);
  const SubscriberId c = subscribe_ok(b, kLqr, kState);
  ASSERT_TRUE(b.unsubscribe(a).has_value());
  const auto routes = b.subscribers_of(kState);
  ASSERT_EQ(routes->size(), 1U);
  EXPECT_EQ((*routes)[0].subscriber, c);
  publish_tagged(b, kState, kStateSize, 5);
  EXPECT_EQ(bytes_of(next_ok(b, c).payload), payload(kStateSize, 5));
}

TEST(BrokerQueue, RemoveService_TwoSubscriptions_BothGoneOthersKept) {
  Broker b = make_broker();
  subscribe_ok(b, kEkf2, kState);
  subscribe_ok(b, kEkf2, kGyro);
  const SubscriberId keep = subscribe_ok(b, kLqr, kState);
  EXPECT_EQ(b.remove_service(kEkf2), 2U);
  EXPECT_EQ(b.subscriber_count(), 1U);
  EXPECT_TRUE(b.subscribers_of(kGyro)->empty());
  ASSERT_EQ(b.subscribers_of(kState)->size(), 1U);
  EXPECT_EQ((*b.subscribers_of(kState))[0].subscriber, keep);
  EXPECT_EQ(b.remove_service(kEkf2), 0U);
}

TEST(BrokerQueue, Subscriber_Info_ServiceAndKind) {
  Broker b = make_broker();
  const SubscriberId d = subscribe_ok(b, kDriver, kState, SubscriberKind::Driver);
  EXPECT_EQ(*b.subscriber(d), (Route{.subscriber = d, .service = kDriver, .kind = SubscriberKind::Driver}));
}

TEST(BrokerQueue, FindTopic_ByName_ObjectOrNothing) {
  Broker b = make_broker();
  EXPECT_EQ(b.find_topic("vehicle_state"), kState);
  EXPECT_EQ(b.find_topic("nope"), std::nullopt);
  EXPECT_EQ(b.topic_count(), 3U);
}

TEST(BrokerQueue, Publish_ManyLaps_GenerationsKeepCounting) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kGyro);
  for (std::uint32_t tag = 0; tag < 100; ++tag) {
    publish_tagged(b, kGyro, kGyroSize, tag);
    const Delivery d = next_ok(b, s);
    ASSERT_EQ(d.generation, TopicGeneration{tag});
    ASSERT_EQ(bytes_of(d.payload), payload(kGyroSize, tag));
  }
}

}  // namespace
}  // namespace rejuv::broker
