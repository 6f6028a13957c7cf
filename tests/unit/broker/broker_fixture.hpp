// Shared helpers for the broker tests: a small topic set and payloads whose bytes say which message they are.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "rejuv/broker/broker.hpp"

namespace rejuv::broker::testing {

inline constexpr ObjectId kGyro{3};   // depth 4, 32-byte payload
inline constexpr ObjectId kState{7};  // depth 8, 96-byte payload
inline constexpr ObjectId kMode{9};   // depth 1, 5-byte payload (not a multiple of the slot alignment)
inline constexpr ObjectId kNoSuchTopic{4};
inline constexpr std::size_t kGyroSize = 32;
inline constexpr std::size_t kStateSize = 96;
inline constexpr std::size_t kModeSize = 5;
inline constexpr std::uint32_t kGyroDepth = 4;
inline constexpr std::uint32_t kStateDepth = 8;

inline constexpr ServiceId kEkf2{1};
inline constexpr ServiceId kLqr{2};
inline constexpr ServiceId kDriver{7};

inline std::vector<TopicConfig> small_config() {
  return {
      {.object = kGyro, .name = "sensor_gyro", .payload_size = kGyroSize, .depth = kGyroDepth},
      {.object = kState, .name = "vehicle_state", .payload_size = kStateSize, .depth = kStateDepth},
      {.object = kMode, .name = "sr_mode", .payload_size = kModeSize, .depth = 1},
  };
}

inline Broker make_broker(const std::vector<TopicConfig>& config = small_config()) {
  auto b = Broker::create(config);
  if (!b) {
    ADD_FAILURE() << b.error().to_string();
    std::abort();
  }
  return std::move(*b);
}

// A payload of `size` bytes, every byte derived from `tag`, so a delivery shows which message it was.
inline std::vector<std::byte> payload(std::size_t size, std::uint32_t tag) {
  std::vector<std::byte> p(size);
  for (std::size_t i = 0; i < size; ++i) {
    p[i] = static_cast<std::byte>((tag * 131U + i * 7U + 1U) & 0xFFU);
  }
  return p;
}

inline std::vector<std::byte> bytes_of(std::span<const std::byte> s) {
  return {s.begin(), s.end()};
}

// Publishes message `tag` on a topic with its configured size; fails the test on refusal.
inline TopicGeneration publish_tagged(Broker& b, ObjectId topic, std::size_t size, std::uint32_t tag) {
  auto g = b.publish(topic, payload(size, tag), Nanos{1000 + tag});
  EXPECT_TRUE(g.has_value()) << to_string(g.error());
  return g.value_or(TopicGeneration{});
}

inline SubscriberId subscribe_ok(Broker& b, ServiceId service, ObjectId topic,
                                 SubscriberKind kind = SubscriberKind::Rejuvenated) {
  auto s = b.subscribe(service, topic, kind);
  EXPECT_TRUE(s.has_value()) << to_string(s.error());
  return s.value_or(SubscriberId{});
}

// The next delivery, which must exist.
inline Delivery next_ok(Broker& b, SubscriberId s) {
  auto d = b.next(s);
  EXPECT_TRUE(d.has_value()) << to_string(d.error());
  EXPECT_TRUE(d.has_value() && d->has_value()) << "nothing pending";
  return d.has_value() && d->has_value() ? **d : Delivery{};
}

// True when the subscriber has nothing to read.
inline bool drained(Broker& b, SubscriberId s) {
  auto d = b.next(s);
  return d.has_value() && !d->has_value();
}

}  // namespace rejuv::broker::testing
