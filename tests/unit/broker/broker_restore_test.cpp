// Checkpoint state of the queues (docs/design.md §7; paper §IV-A: queued messages are global state; §IV-C: the
// driver level is never rolled back). Given a snapshot, When more happens and the snapshot is restored,
// Then rings, generations and rejuvenated cursors are exactly as at the snapshot and drivers go on.
#include <gtest/gtest.h>

#include "broker_fixture.hpp"

namespace rejuv::broker {
namespace {

using namespace rejuv::broker::testing;

TEST(BrokerRestore, Restore_AfterMorePublishes_SnapshotIdentical) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  subscribe_ok(b, kLqr, kGyro);
  for (std::uint32_t tag = 0; tag < 5; ++tag) {
    publish_tagged(b, kState, kStateSize, tag);
    publish_tagged(b, kGyro, kGyroSize, 100 + tag);
  }
  next_ok(b, s);
  const BrokerSnapshot cp = b.snapshot();
  for (std::uint32_t tag = 5; tag < 30; ++tag) {  // overwrite every ring several times
    publish_tagged(b, kState, kStateSize, tag);
    publish_tagged(b, kGyro, kGyroSize, 100 + tag);
    publish_tagged(b, kMode, kModeSize, tag);
  }
  next_ok(b, s);
  ASSERT_NE(b.snapshot(), cp);
  ASSERT_TRUE(b.restore(cp).has_value());
  EXPECT_EQ(b.snapshot(), cp);
  EXPECT_EQ(b.head(kState)->value(), 5U);
  EXPECT_EQ(b.head(kMode)->value(), 0U);
}

TEST(BrokerRestore, Restore_QueuedAtCheckpoint_RedeliveredToRejuvenated) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  publish_tagged(b, kState, kStateSize, 1);
  publish_tagged(b, kState, kStateSize, 2);
  next_ok(b, s);
  const BrokerSnapshot cp = b.snapshot();  // message 2 queued, unread
  next_ok(b, s);
  publish_tagged(b, kState, kStateSize, 3);
  next_ok(b, s);
  ASSERT_TRUE(b.restore(cp).has_value());
  const Delivery d = next_ok(b, s);
  EXPECT_EQ(d.generation, TopicGeneration{1});
  EXPECT_EQ(bytes_of(d.payload), payload(kStateSize, 2));
  EXPECT_EQ(d.lost, 0U);
  EXPECT_TRUE(drained(b, s));
}

TEST(BrokerRestore, Restore_Driver_NoReplayOfBacklog) {
  Broker b = make_broker();
  const SubscriberId drv = subscribe_ok(b, kDriver, kState, SubscriberKind::Driver);
  publish_tagged(b, kState, kStateSize, 1);
  publish_tagged(b, kState, kStateSize, 2);
  const BrokerSnapshot cp = b.snapshot();  // two queued for the driver
  next_ok(b, drv);
  next_ok(b, drv);
  publish_tagged(b, kState, kStateSize, 3);
  ASSERT_TRUE(b.restore(cp).has_value());
  EXPECT_TRUE(drained(b, drv));
  EXPECT_EQ(*b.pending(drv), 0U);
}

TEST(BrokerRestore, Restore_Driver_PublishAfterRestoreDeliveredExactlyOnce) {
  Broker b = make_broker();
  const SubscriberId drv = subscribe_ok(b, kDriver, kState, SubscriberKind::Driver);
  publish_tagged(b, kState, kStateSize, 1);
  const BrokerSnapshot cp = b.snapshot();
  for (std::uint32_t tag = 2; tag < 6; ++tag) {  // the driver reads ahead of the checkpoint's head
    publish_tagged(b, kState, kStateSize, tag);
  }
  for (int i = 0; i < 5; ++i) {
    next_ok(b, drv);
  }
  ASSERT_TRUE(drained(b, drv));
  ASSERT_TRUE(b.restore(cp).has_value());
  publish_tagged(b, kState, kStateSize, 77);
  const Delivery d = next_ok(b, drv);
  EXPECT_EQ(bytes_of(d.payload), payload(kStateSize, 77));
  EXPECT_EQ(d.generation, TopicGeneration{1});  // the restored head
  EXPECT_EQ(d.lost, 0U);
  EXPECT_TRUE(drained(b, drv));
}

TEST(BrokerRestore, Restore_DriverBehindCheckpointHead_DoesNotStall) {
  Broker b = make_broker();
  const SubscriberId drv = subscribe_ok(b, kDriver, kState, SubscriberKind::Driver);
  for (std::uint32_t tag = 0; tag < 3; ++tag) {
    publish_tagged(b, kState, kStateSize, tag);
  }
  const BrokerSnapshot cp = b.snapshot();
  ASSERT_TRUE(b.restore(cp).has_value());
  publish_tagged(b, kState, kStateSize, 9);
  EXPECT_EQ(*b.pending(drv), 1U);
  EXPECT_EQ(bytes_of(next_ok(b, drv).payload), payload(kStateSize, 9));
}

TEST(BrokerRestore, Restore_DriverNotInSnapshot_SnapshotHoldsRejuvenatedOnly) {
  Broker b = make_broker();
  subscribe_ok(b, kEkf2, kState);
  subscribe_ok(b, kDriver, kState, SubscriberKind::Driver);
  EXPECT_EQ(b.snapshot().rejuvenated_subscribers(), 1U);
}

TEST(BrokerRestore, Restore_DriverCreatedAfterSnapshot_KeptAndRebased) {
  Broker b = make_broker();
  publish_tagged(b, kState, kStateSize, 1);
  const BrokerSnapshot cp = b.snapshot();
  const SubscriberId drv = subscribe_ok(b, kDriver, kState, SubscriberKind::Driver);
  publish_tagged(b, kState, kStateSize, 2);
  auto report = b.restore(cp);
  ASSERT_TRUE(report.has_value());
  EXPECT_EQ(report->drivers_rebased, 1U);
  EXPECT_TRUE(drained(b, drv));
  publish_tagged(b, kState, kStateSize, 3);
  EXPECT_EQ(bytes_of(next_ok(b, drv).payload), payload(kStateSize, 3));
}

TEST(BrokerRestore, Restore_RejuvenatedCreatedAfterSnapshot_Removed) {
  Broker b = make_broker();
  const BrokerSnapshot cp = b.snapshot();
  const SubscriberId late = subscribe_ok(b, kEkf2, kState);
  auto report = b.restore(cp);
  ASSERT_TRUE(report.has_value());
  EXPECT_EQ(report->rejuvenated_dropped, 1U);
  EXPECT_EQ(b.next(late).error(), BrokerError::UnknownSubscriber);
  EXPECT_TRUE(b.subscribers_of(kState)->empty());
  // The restored service subscribes again in its restored run.
  EXPECT_TRUE(b.subscribe(kEkf2, kState, SubscriberKind::Rejuvenated).has_value());
}

TEST(BrokerRestore, Restore_RejuvenatedRemovedAfterSnapshot_RecreatedUnderOldIdWithCursor) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  publish_tagged(b, kState, kStateSize, 1);
  const BrokerSnapshot cp = b.snapshot();
  EXPECT_EQ(b.remove_service(kEkf2), 1U);  // the service died: rollback follows
  auto report = b.restore(cp);
  ASSERT_TRUE(report.has_value());
  EXPECT_EQ(report->rejuvenated_recreated, 1U);
  EXPECT_EQ(*b.subscriber(s),
            (Route{.subscriber = s, .service = kEkf2, .kind = SubscriberKind::Rejuvenated}));
  ASSERT_EQ(b.subscribers_of(kState)->size(), 1U);
  EXPECT_EQ(bytes_of(next_ok(b, s).payload), payload(kStateSize, 1));
  EXPECT_EQ(*b.subscriber_stats(s), (SubscriberStats{.delivered = 1, .lost = 0}));  // restarted at zero
}

TEST(BrokerRestore, Restore_RejuvenatedIdsAfterRestore_NewIdsStillUnique) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  const BrokerSnapshot cp = b.snapshot();
  const SubscriberId late = subscribe_ok(b, kLqr, kState);
  ASSERT_TRUE(b.restore(cp).has_value());
  const SubscriberId again = subscribe_ok(b, kLqr, kState);
  EXPECT_NE(again, s);
  EXPECT_NE(again, late);  // the counter is not rolled back
}

TEST(BrokerRestore, Restore_StatsNotRolledBack) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  const BrokerSnapshot cp = b.snapshot();
  publish_tagged(b, kState, kStateSize, 1);
  next_ok(b, s);
  ASSERT_TRUE(b.restore(cp).has_value());
  EXPECT_EQ(b.topic_stats(kState)->published, 1U);
  EXPECT_EQ(b.subscriber_stats(s)->delivered, 1U);
}

TEST(BrokerRestore, Restore_SameSnapshotTwice_SameState) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kGyro);
  publish_tagged(b, kGyro, kGyroSize, 1);
  const BrokerSnapshot cp = b.snapshot();
  ASSERT_TRUE(b.restore(cp).has_value());
  publish_tagged(b, kGyro, kGyroSize, 2);
  next_ok(b, s);
  ASSERT_TRUE(b.restore(cp).has_value());
  EXPECT_EQ(b.snapshot(), cp);
  EXPECT_EQ(bytes_of(next_ok(b, s).payload), payload(kGyroSize, 1));
}

TEST(BrokerRestore, Restore_RingsOverrunAfterSnapshot_OverrunAgainCountsLossFromCheckpointCursor) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kGyro);
  const BrokerSnapshot cp = b.snapshot();
  for (std::uint32_t tag = 0; tag < 3 * kGyroDepth; ++tag) {
    publish_tagged(b, kGyro, kGyroSize, tag);
  }
  ASSERT_TRUE(b.restore(cp).has_value());
  for (std::uint32_t tag = 0; tag < kGyroDepth + 1; ++tag) {
    publish_tagged(b, kGyro, kGyroSize, 500 + tag);
  }
  const Delivery d = next_ok(b, s);
  EXPECT_EQ(d.lost, 1U);
  EXPECT_EQ(bytes_of(d.payload), payload(kGyroSize, 501));
}

TEST(BrokerRestore, Restore_DriverClashingWithRestoredRejuvenated_Dropped) {
  Broker b = make_broker();
  const SubscriberId s = subscribe_ok(b, kEkf2, kState);
  const BrokerSnapshot cp = b.snapshot();
  ASSERT_TRUE(b.unsubscribe(s).has_value());
  const SubscriberId drv = subscribe_ok(b, kEkf2, kState, SubscriberKind::Driver);
  auto report = b.restore(cp);
  ASSERT_TRUE(report.has_value());
  EXPECT_EQ(report->drivers_dropped, 1U);
  EXPECT_EQ(b.next(drv).error(), BrokerError::UnknownSubscriber);
  EXPECT_TRUE(b.subscriber(s).has_value());
  EXPECT_EQ(b.subscribers_of(kState)->size(), 1U);
}

TEST(BrokerRestore, SnapshotInto_ReusedStorage_EqualsFreshSnapshot) {
  Broker b = make_broker();
  subscribe_ok(b, kEkf2, kState);
  BrokerSnapshot reused;
  b.snapshot_into(reused);
  publish_tagged(b, kState, kStateSize, 1);
  subscribe_ok(b, kLqr, kGyro);
  b.snapshot_into(reused);
  EXPECT_EQ(reused, b.snapshot());
  EXPECT_EQ(reused.rejuvenated_subscribers(), 2U);
  EXPECT_EQ(reused.heads()[1], 1U);
  EXPECT_GT(reused.size_bytes(), kGyroDepth * kGyroSize + kStateDepth * kStateSize);
}

TEST(BrokerRestore, Restore_MovedBroker_StillWorks) {
  Broker a = make_broker();
  const SubscriberId s = subscribe_ok(a, kEkf2, kState);
  publish_tagged(a, kState, kStateSize, 1);
  const BrokerSnapshot cp = a.snapshot();
  Broker b = std::move(a);
  publish_tagged(b, kState, kStateSize, 2);
  ASSERT_TRUE(b.restore(cp).has_value());
  EXPECT_EQ(bytes_of(next_ok(b, s).payload), payload(kStateSize, 1));
}

}  // namespace
}  // namespace rejuv::broker
