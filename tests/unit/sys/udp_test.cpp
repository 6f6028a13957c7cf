// The UDP socket of the network gate (kernel_sim/sys/udp.hpp), on loopback.
#include <gtest/gtest.h>

#include <array>
#include <cerrno>
#include <vector>

#include "rejuv/sys/event.hpp"
#include "rejuv/sys/udp.hpp"

namespace rejuv::sys {
namespace {

UdpSocket bound() {
  auto s = UdpSocket::bind(UdpAddress::loopback(0));
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  return std::move(*s);
}

UdpAddress address_of(const UdpSocket& s) {
  auto a = s.local_address();
  EXPECT_TRUE(a.has_value());
  return a.value_or(UdpAddress{});
}

TEST(UdpSocket, BindPortZero_GetsEphemeralLoopbackPort) {
  const UdpSocket s = bound();
  const UdpAddress a = address_of(s);
  EXPECT_NE(a.port, 0);
  EXPECT_EQ(a.ip, 0x7F00'0001U);
  EXPECT_EQ(a.to_string(), "127.0.0.1:" + std::to_string(a.port));
}

TEST(UdpSocket, SendReceive_KeepsDatagramAndReportsSender) {
  const UdpSocket a = bound();
  const UdpSocket b = bound();
  const std::array<std::byte, 5> msg{std::byte{1}, std::byte{2}, std::byte{3}, std::byte{4}, std::byte{5}};
  ASSERT_TRUE(a.send_to(msg, address_of(b)).has_value());
  ASSERT_TRUE(wait_fd(b.fd(), WaitFor::Readable, std::chrono::seconds{5}).value_or(false));
  std::array<std::byte, 64> buf{};
  auto r = b.receive(buf);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_EQ(r->size, msg.size());
  EXPECT_EQ(r->datagram_size, msg.size());
  EXPECT_FALSE(r->truncated);
  EXPECT_EQ(r->from, address_of(a));
  EXPECT_TRUE(std::equal(msg.begin(), msg.end(), buf.begin()));
}

TEST(UdpSocket, Receive_OversizedDatagram_ReportsRealSizeTruncated) {
  const UdpSocket a = bound();
  const UdpSocket b = bound();
  const std::vector<std::byte> big(3000, std::byte{0x5A});
  ASSERT_TRUE(a.send_to(big, address_of(b)).has_value());
  ASSERT_TRUE(wait_fd(b.fd(), WaitFor::Readable, std::chrono::seconds{5}).value_or(false));
  std::array<std::byte, 100> buf{};
  auto r = b.receive(buf);
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(r->truncated);
  EXPECT_EQ(r->size, buf.size());
  EXPECT_EQ(r->datagram_size, big.size());
}

TEST(UdpSocket, Receive_NothingQueued_EagainAsValue) {
  const UdpSocket s = bound();
  std::array<std::byte, 16> buf{};
  auto r = s.receive(buf);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().error, EAGAIN);
}

TEST(UdpSocket, BindPortInUse_ErrorValue) {
  const UdpSocket a = bound();
  auto b = UdpSocket::bind(address_of(a));
  ASSERT_FALSE(b.has_value());
  EXPECT_EQ(b.error().error, EADDRINUSE);
}

TEST(UdpAddress, Parse_RejectsNonAddress) {
  EXPECT_TRUE(UdpAddress::parse("127.0.0.1", 1).has_value());
  EXPECT_EQ(UdpAddress::parse("10.1.2.3", 7)->ip, 0x0A01'0203U);
  EXPECT_FALSE(UdpAddress::parse("localhost", 1).has_value());
  EXPECT_FALSE(UdpAddress::parse("1.2.3", 1).has_value());
  EXPECT_FALSE(UdpAddress::parse("", 1).has_value());
}

TEST(UdpSocket, Close_ReleasesFd) {
  const int before = count_open_fds().value_or(-1);
  {
    UdpSocket s = bound();
    EXPECT_EQ(count_open_fds().value_or(-1), before + 1);
    UdpSocket moved = std::move(s);
    EXPECT_FALSE(s.valid());  // NOLINT(bugprone-use-after-move): the moved-from state is the point
    EXPECT_TRUE(moved.valid());
  }
  EXPECT_EQ(count_open_fds().value_or(-1), before);
}

}  // namespace
}  // namespace rejuv::sys
