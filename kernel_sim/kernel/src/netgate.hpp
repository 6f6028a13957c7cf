// The network gate's state (docs/design.md §2; docs/protocol.md "Network gate"): the kernel's UDP socket of the
// external link, who may receive from it, its GroundLink (the signing check and where replies go), and its
// counters. Code in netgate.cpp.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "rejuv/channel/wire.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/mavlink/frame.hpp"
#include "rejuv/mavlink/messages.hpp"
#include "rejuv/sys/udp.hpp"

namespace rejuv::kernel {

inline constexpr std::uint16_t kDefaultNetworkPort = 14555;  // launch `network.bind_port` unset
inline constexpr std::size_t kDatagramsPerPoll = 64;         // fairness: datagrams read per wakeup / step
// Relayed datagrams a verdict may still name (the receiver judges each as it handles it, so within a step).
inline constexpr std::size_t kRecentDatagrams = 256;

// Who the ground station is, and what admits a datagram from the network (docs/design.md §2; docs/mavlink.md
// "Signing", "Where the vehicle sends"). The ground address changes in one place only: judge() with a valid
// verdict on a datagram that admit() passed and relayed() recorded. A datagram refused by the signing check is
// never recorded, so it has no id that a verdict could name: nothing it carries can move the telemetry.
class GroundLink {
 public:
  GroundLink() = default;
  // `key`: the launch file's signing key (none: no signing check); `ground`: where the vehicle's datagrams go
  // before any ground station has spoken (launch network.ground_address).
  GroundLink(std::optional<mavlink::SigningKey> key, std::optional<sys::UdpAddress> ground);
  [[nodiscard]] bool signing() const { return signing_.has_value(); }
  // The signing check (mavlink::SignatureChecker; without a key everything passes) against the local signing
  // clock: the gate gives the wall clock (mavlink::SigningClock::now(), also in lockstep: the ground station
  // stamps from its own wall clock), a unit test any time it likes.
  [[nodiscard]] Result<void, mavlink::SigningRefusal> admit(std::span<const std::byte> datagram,
                                                            mavlink::SigningTime local_clock);
  // The id the next relayed datagram gets (the NetDatagram frame's aux).
  [[nodiscard]] std::uint64_t next_id() const { return next_id_; }
  // The datagram next_id() named was relayed from `from`: a verdict may now name it, once.
  void relayed(const sys::UdpAddress& from);
  enum class Verdict : std::uint8_t { Valid, Refused };
  enum class JudgeError : std::uint8_t { NotRelayed };  // not relayed lately (unknown or too old), or judged already
  // The receiver's verdict on a relayed datagram: a valid one makes its source the ground station.
  [[nodiscard]] Result<void, JudgeError> judge(std::uint64_t id, Verdict verdict);
  [[nodiscard]] const std::optional<sys::UdpAddress>& ground() const { return ground_; }
  // With a signing key: the vehicle's frame signed with it (mavlink::sign_frame; link id 0, stamped from
  // `local_clock`, strictly later than the last frame signed here). nullopt: not a MAVLink 2 frame the gate can
  // sign, which it does not send (with signing on, the vehicle speaks only in frames a ground station can verify).
  // Without a key: not called.
  [[nodiscard]] std::optional<mavlink::Frame> sign_outgoing(std::span<const std::byte> datagram,
                                                            mavlink::SigningTime local_clock);

 private:
  // A datagram relayed lately, by id, judged at most once.
  struct Relayed {
    std::uint64_t id = 0;
    std::optional<sys::UdpAddress> from{};
    bool judged = false;
  };
  // With a signing key: the MAVLink 2 signature check every datagram must pass before it is relayed, and the
  // key sign_outgoing() signs with (the key stays here, in the kernel; ext_link never holds it).
  std::optional<mavlink::SignatureChecker> signing_{};
  mavlink::SigningTime last_signed_{};
  std::array<Relayed, kRecentDatagrams> recent_{};
  std::uint64_t next_id_ = 1;
  // The ground station: the source of the last datagram its receiver judged valid (NetReceive verdict 0), not
  // simply the last relayed one: anyone can send garbage, and telemetry must not follow it.
  std::optional<sys::UdpAddress> ground_{};
};

// The network gate: its socket, the NETWORK object it serves, the policy slots that may receive from it, its
// GroundLink and its counters, changed only through the methods below, each of which counts what it did. The
// gate's code (netgate.cpp: Kernel::Impl::net_open, net_poll, net_invoke) opens it, reads from and sends on
// it; Kernel::net_stats and network_port read stats() and port(); the ChannelInput counts a NetSend it
// refused (count_send_refused).
class NetGate {
 public:
  // A policy slot that may hold the gate's object with Read in some mode (checked in the current mode
  // through the cap system before every relay).
  struct Reader {
    ServiceId service{};
    Slot slot{};
  };
  // Why a datagram read from the socket reached no service (NetStats: dropped_*).
  enum class Drop : std::uint8_t { Empty, Oversize, SecureInterval, NoReceiver, Busy };

  // ---- opening (net_open) ----
  // The gate serves `object` on `socket`, bound to `port`, for `readers`; `link` checks the signatures and
  // knows the ground station. Once.
  void open(sys::UdpSocket socket, ObjectId object, std::uint16_t port, std::vector<Reader> readers,
            GroundLink link);
  // False: no gate (disabled, no NETWORK object, bind failed).
  [[nodiscard]] bool is_open() const { return socket_.valid(); }
  [[nodiscard]] int fd() const { return socket_.fd(); }  // the socket, for epoll
  [[nodiscard]] std::uint16_t port() const { return port_; }  // bound port
  [[nodiscard]] bool serves(ObjectId object) const { return object_ == object; }
  [[nodiscard]] const std::vector<Reader>& readers() const { return readers_; }
  [[nodiscard]] const NetStats& stats() const { return stats_; }
  [[nodiscard]] bool signing() const { return link_.signing(); }
  [[nodiscard]] const std::optional<sys::UdpAddress>& ground() const { return link_.ground(); }

  // ---- from the network (net_poll) ----
  // The next queued datagram, read into the gate's buffer and counted as received.
  [[nodiscard]] sys::SysResult<sys::UdpReceived> receive();
  // The bytes receive() read for `r`.
  [[nodiscard]] std::span<const std::byte> bytes_of(const sys::UdpReceived& r) const {
    return {rx_.data(), r.size};
  }
  void count_dropped(Drop why);
  // The signing check (GroundLink::admit); a refused datagram is counted by its reason.
  [[nodiscard]] Result<void, mavlink::SigningRefusal> admit(std::span<const std::byte> datagram,
                                                            mavlink::SigningTime local_clock);
  [[nodiscard]] std::uint64_t next_id() const { return link_.next_id(); }  // the id the next relayed one gets
  // The datagram next_id() named was relayed from `from`: counted, and a verdict may now name it, once.
  void relayed(const sys::UdpAddress& from);
  // The receiver's verdict on a relayed datagram (NetReceive: `reason` 0 valid, else its refusal code below
  // kNetVerdictCodes), counted by reason once GroundLink::judge has taken it.
  [[nodiscard]] Result<void, GroundLink::JudgeError> judge(std::uint64_t id, std::uint64_t reason);

  // ---- to the ground station (net_invoke) ----
  // With signing on: `datagram` signed (GroundLink::sign_outgoing).
  [[nodiscard]] std::optional<mavlink::Frame> sign_outgoing(std::span<const std::byte> datagram,
                                                            mavlink::SigningTime local_clock) {
    return link_.sign_outgoing(datagram, local_clock);
  }
  // Sends one datagram to `to`; counted as sent if it went.
  [[nodiscard]] sys::SysResult<void> send(std::span<const std::byte> datagram, const sys::UdpAddress& to);
  void count_send_refused() { ++stats_.send_refused; }          // denied by the cap check, bad data, send error
  void count_unsent_no_ground() { ++stats_.unsent_no_ground; }  // no ground station has spoken yet

  // Drop and refusal log lines: 10 of burst, 1 per second sustained (a flood must not flood the log). False:
  // this one is not logged (and counted as suppressed).
  [[nodiscard]] bool may_log(Nanos wall_now);

 private:
  sys::UdpSocket socket_{};
  std::optional<ObjectId> object_{};  // the NETWORK object it serves
  std::uint16_t port_ = 0;
  std::vector<Reader> readers_{};
  GroundLink link_{};  // the signing check, the datagrams relayed lately, the ground station
  NetStats stats_{};
  double log_tokens_ = 10;
  Nanos log_last_{0};
  std::uint64_t log_suppressed_ = 0;
  // One byte more than a datagram may have, so that a longer one shows as truncated.
  alignas(8) std::array<std::byte, wire::kMaxDatagramBytes + 1> rx_{};
};

}  // namespace rejuv::kernel
