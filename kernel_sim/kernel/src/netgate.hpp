// The network gate's state (DESIGN §2; docs/protocol.md "Network gate"): the kernel's UDP socket of the
// external link, who may receive from it, where replies go, and its counters. Code in netgate.cpp.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "rejuv/channel/wire.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/sys/udp.hpp"

namespace rejuv::kernel {

inline constexpr std::uint16_t kDefaultNetworkPort = 14555;  // launch `network.bind_port` unset
inline constexpr std::size_t kDatagramsPerPoll = 64;         // fairness: datagrams read per wakeup / step
// Relayed datagrams a verdict may still name (the receiver judges each as it handles it, so within a step).
inline constexpr std::size_t kRecentDatagrams = 256;

struct NetGate {
  // A policy slot that may hold the gate's object with Read in some mode (checked in the current mode
  // through the cap system before every relay).
  struct Reader {
    ServiceId service{};
    Slot slot{};
  };
  sys::UdpSocket socket{};                // invalid: no gate (disabled, no NETWORK object, bind failed)
  std::optional<ObjectId> object{};       // the NETWORK object it serves
  std::uint16_t port = 0;                 // bound port
  std::vector<Reader> readers{};
  // The ground station: the source of the last datagram its receiver judged valid (NetReceive verdict 0).
  // Not simply the last relayed one: anyone can send garbage, and telemetry must not follow it.
  std::optional<sys::UdpAddress> peer{};
  // The datagrams relayed lately, by id (NetDatagram aux), each judged at most once.
  struct Relayed {
    std::uint64_t id = 0;
    std::optional<sys::UdpAddress> from{};
    bool judged = false;
  };
  std::array<Relayed, kRecentDatagrams> recent{};
  std::uint64_t next_id = 1;
  NetStats stats{};
  // Set when the launch file gives a signing key: the MAVLink 2 signature check every datagram must pass
  // before it is relayed (the key stays here, in the kernel; ext_link never holds it).
  std::optional<mavlink::SignatureChecker> signing{};
  // Drop and refusal log lines: 10 of burst, 1 per second sustained (a flood must not flood the log).
  double log_tokens = 10;
  Nanos log_last{0};
  std::uint64_t log_suppressed = 0;
  // One byte more than a datagram may have, so that a longer one shows as truncated.
  alignas(8) std::array<std::byte, wire::kMaxDatagramBytes + 1> rx{};
};

}  // namespace rejuv::kernel
