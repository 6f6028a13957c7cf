// sys::LinkClosure by its effect (link_closure.hpp; docs/across_hosts.md "Closing the link"): two network
// namespaces joined by a veth pair stand for the vehicle and the companion; a UDP sender at a steady rate in
// each, a counter in the other. While the vehicle's closure is closed no datagram arrives either way, and
// tcpdump in the companion's namespace captures no packet (where it captured the open window's); after open()
// they arrive again. The table is gone once the closure is destroyed, and once its process is killed. The
// fallback without CAP_NET_ADMIN (LinkClosure::freezing) stops a process in a cgroup of its own and lets it go
// again. Root only (namespaces, nftables, cgroups); skipped otherwise. Namespaces, cgroups, threads and processes
// are removed on every exit path.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sched.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../../cgroup_v2_group.hpp"
#include "../../netns_pair.hpp"
#include "../../rejuv_cli.hpp"
#include "rejuv/sys/link_closure.hpp"

namespace {

namespace fs = std::filesystem;
using rejuv::sys::LinkClosure;
using rejuv::sys::LinkState;
using rejuv::sys::UniqueFd;
using rejuv::sys::UplinkSpec;
using rejuv::test_support::CliOutcome;
using rejuv::test_support::slurp;
using Clock = std::chrono::steady_clock;

const fs::path kIp = "/usr/sbin/ip";
const fs::path kTcpdump = "/usr/bin/tcpdump";
constexpr const char* kVehicleAddress = "10.79.0.1";
constexpr const char* kCompanionAddress = "10.79.0.2";
constexpr std::uint16_t kPort = 47311;
constexpr auto kDeadline = std::chrono::seconds{20};

// Waits until `done` holds or the deadline passes; whether it held.
bool wait_for(const std::function<bool()>& done) {
  const auto until = Clock::now() + kDeadline;
  while (Clock::now() < until) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds{5});
  }
  return done();
}

// A UDP socket made inside namespace `ns` (it stays there), bound to `address`:kPort, non-blocking.
UniqueFd udp_in(const std::string& ns, const char* address) {
  UniqueFd own(::open("/proc/thread-self/ns/net", O_RDONLY | O_CLOEXEC));
  UniqueFd target(::open(("/run/netns/" + ns).c_str(), O_RDONLY | O_CLOEXEC));
  if (!own || !target || ::setns(target.get(), CLONE_NEWNET) != 0) return {};
  UniqueFd fd(::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (::setns(own.get(), CLONE_NEWNET) != 0) std::abort();  // the test thread must not stay elsewhere
  sockaddr_in at{};
  at.sin_family = AF_INET;
  at.sin_port = htons(kPort);
  ::inet_pton(AF_INET, address, &at.sin_addr);
  if (!fd || ::bind(fd.get(), reinterpret_cast<const sockaddr*>(&at), sizeof at) != 0) return {};
  return fd;
}

// Datagrams from `from` to `to_address` every 2 ms until stopped; how many were sent.
class Sender {
 public:
  Sender(int from, const char* to_address) : thread_([this, from, to_address] { run(from, to_address); }) {}
  Sender(const Sender&) = delete;
  Sender& operator=(const Sender&) = delete;
  ~Sender() {
    stop_ = true;
    thread_.join();
  }
  [[nodiscard]] std::uint64_t sent() const { return sent_; }

 private:
  void run(int from, const char* to_address) {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(kPort);
    ::inet_pton(AF_INET, to_address, &to.sin_addr);
    while (!stop_) {
      const char payload[] = "rejuv link closure";
      if (::sendto(from, payload, sizeof payload, 0, reinterpret_cast<const sockaddr*>(&to), sizeof to) > 0) ++sent_;
      std::this_thread::sleep_for(std::chrono::milliseconds{2});
    }
  }
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> sent_{0};
  std::thread thread_;
};

// Datagrams waiting on `fd`, read and counted.
std::uint64_t drain(int fd) {
  std::uint64_t n = 0;
  std::array<char, 256> buf{};
  while (::recv(fd, buf.data(), buf.size(), 0) > 0) ++n;
  return n;
}

class LinkClosureTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (::geteuid() != 0) return;
    const std::string id = std::to_string(::getpid());
    dir_ = fs::temp_directory_path() / ("rejuv_link_closure_" + id);
    fs::create_directories(dir_ / "cmd");
    hosts_.emplace(dir_ / "cmd", "rjN");
    setup_error_ = hosts_->make(kVehicleAddress, kCompanionAddress);
  }
  static void TearDownTestSuite() {
    hosts_.reset();  // before its folder goes
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root: network namespaces, a veth pair and nftables";
    ASSERT_TRUE(setup_error_.empty()) << setup_error_;
  }

  // `nft list tables` in the vehicle's namespace.
  static std::string vehicle_tables() {
    return rejuv::test_support::run_program(dir_ / "cmd", kIp, {"netns", "exec", hosts_->vehicle, "nft", "list", "tables"})
        .out;
  }

  static UplinkSpec vehicle_uplink(const std::string& label) {
    return UplinkSpec{.label = label + "_" + std::to_string(::getpid()), .netns = hosts_->vehicle};
  }

  static inline fs::path dir_;
  static inline std::optional<rejuv::test_support::NetnsPair> hosts_;
  static inline std::string setup_error_;
};

// tcpdump on the companion's veth: the vehicle's datagrams to it (the companion's own, which the vehicle's
// ingress drops, leave through the companion's tap and are left out); its packet count once stopped.
class Capture {
 public:
  explicit Capture(const fs::path& dir, const std::string& ns, const std::string& dev) : dir_(dir) {
    fs::create_directories(dir_);
    pid_ = rejuv::test_support::start_program(
        dir_, kIp, {"netns", "exec", ns, kTcpdump.string(), "-i", dev, "-n", "-l", "-q", "--immediate-mode", "udp port " + std::to_string(kPort) + " and src host " + kVehicleAddress});
  }
  Capture(const Capture&) = delete;
  Capture& operator=(const Capture&) = delete;
  ~Capture() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  [[nodiscard]] bool listening() const {
    return wait_for([this] { return slurp(dir_ / "stderr").find("listening on") != std::string::npos; });
  }
  // Stops it (SIGINT: it prints its statistics); the packets it printed, one line each.
  std::size_t stop() {
    ::kill(pid_, SIGINT);
    (void)rejuv::test_support::wait_program(dir_, std::exchange(pid_, -1));
    return rejuv::test_support::count_of(slurp(dir_ / "stdout"), "UDP");
  }
  [[nodiscard]] std::string said() const { return slurp(dir_ / "stderr"); }

 private:
  fs::path dir_;
  pid_t pid_ = -1;
};

TEST_F(LinkClosureTest, Closed_NothingCrossesEitherWay_OpenedCrossesAgain) {
  auto link = LinkClosure::create(vehicle_uplink("effect"));
  ASSERT_TRUE(link) << link.error().to_string();
  EXPECT_EQ(link->state(), LinkState::Open);
  EXPECT_NE(vehicle_tables().find(link->table()), std::string::npos) << vehicle_tables();

  UniqueFd at_vehicle = udp_in(hosts_->vehicle, kVehicleAddress);
  UniqueFd at_companion = udp_in(hosts_->companion, kCompanionAddress);
  ASSERT_TRUE(at_vehicle && at_companion);
  Sender to_companion(at_vehicle.get(), kCompanionAddress);
  Sender to_vehicle(at_companion.get(), kVehicleAddress);
  std::uint64_t got_v = 0, got_c = 0;
  auto both_receive = [&](std::uint64_t from_v, std::uint64_t from_c) {
    return wait_for([&] {
      got_v += drain(at_vehicle.get());
      got_c += drain(at_companion.get());
      return got_v >= from_v + 20 && got_c >= from_c + 20;
    });
  };

  // Open: both ways deliver, and tcpdump at the companion sees the vehicle's datagrams (the capture's control).
  {
    Capture open_window(dir_ / "tcpdump_open", hosts_->companion, hosts_->companion_veth);
    ASSERT_TRUE(open_window.listening()) << open_window.said();
    ASSERT_TRUE(both_receive(0, 0)) << "open: vehicle got " << got_v << ", companion got " << got_c;
    EXPECT_GT(open_window.stop(), 0U) << open_window.said();
  }

  // Closed: whatever was in flight drained once the senders sent more; then nothing arrives either way while
  // each sender sends at least 100 more, and tcpdump captures nothing.
  for (const char* what : {"close", "close again (idempotent)"}) {
    auto closed = link->close();
    ASSERT_TRUE(closed) << what << ": " << closed.error().to_string();
  }
  EXPECT_EQ(link->state(), LinkState::Closed);
  const std::uint64_t closed_at = to_companion.sent();
  ASSERT_TRUE(wait_for([&] { return to_companion.sent() >= closed_at + 10; }));
  (void)drain(at_vehicle.get());
  (void)drain(at_companion.get());
  {
    Capture closed_window(dir_ / "tcpdump_closed", hosts_->companion, hosts_->companion_veth);
    ASSERT_TRUE(closed_window.listening()) << closed_window.said();
    const std::uint64_t sent_c = to_companion.sent(), sent_v = to_vehicle.sent();
    ASSERT_TRUE(wait_for([&] { return to_companion.sent() >= sent_c + 100 && to_vehicle.sent() >= sent_v + 100; }));
    EXPECT_EQ(drain(at_companion.get()), 0U) << "datagrams from the vehicle crossed a closed link";
    EXPECT_EQ(drain(at_vehicle.get()), 0U) << "datagrams to the vehicle crossed a closed link";
    EXPECT_EQ(closed_window.stop(), 0U) << slurp(dir_ / "tcpdump_closed" / "stdout");
  }

  // Open again: both ways deliver again.
  for (const char* what : {"open", "open again (idempotent)"}) {
    auto opened = link->open();
    ASSERT_TRUE(opened) << what << ": " << opened.error().to_string();
  }
  got_v = got_c = 0;
  EXPECT_TRUE(both_receive(0, 0)) << "reopened: vehicle got " << got_v << ", companion got " << got_c;
}

TEST_F(LinkClosureTest, Destroyed_TableGone) {
  std::string table;
  {
    auto link = LinkClosure::create(vehicle_uplink("scoped"));
    ASSERT_TRUE(link) << link.error().to_string();
    auto closed = link->close();
    ASSERT_TRUE(closed) << closed.error().to_string();
    table = link->table();
    LinkClosure moved = std::move(*link);
    EXPECT_FALSE(link->valid());
    EXPECT_TRUE(moved.valid());
    EXPECT_NE(vehicle_tables().find(table), std::string::npos);
  }
  EXPECT_EQ(vehicle_tables().find(table), std::string::npos) << vehicle_tables();
}

TEST_F(LinkClosureTest, ProcessKilled_TableGone) {
  const std::string label = "killed_" + std::to_string(::getpid());
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(ready[0]);
    auto link = LinkClosure::create(UplinkSpec{.label = label, .netns = hosts_->vehicle});
    const char ok = link && link->close() ? '1' : '0';
    (void)::write(ready[1], &ok, 1);
    ::pause();
    ::_exit(0);
  }
  ::close(ready[1]);
  char ok = '0';
  (void)::read(ready[0], &ok, 1);
  ::close(ready[0]);
  const bool made = vehicle_tables().find("rejuv_link_" + label) != std::string::npos;
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_EQ(ok, '1');
  EXPECT_TRUE(made);
  EXPECT_TRUE(wait_for([&] { return vehicle_tables().find("rejuv_link_" + label) == std::string::npos; }))
      << vehicle_tables();
}

TEST_F(LinkClosureTest, SameLabelTwice_Exists) {
  auto first = LinkClosure::create(vehicle_uplink("twice"));
  ASSERT_TRUE(first) << first.error().to_string();
  auto second = LinkClosure::create(vehicle_uplink("twice"));
  ASSERT_FALSE(second);
  // EPERM where the first is owned by another socket (nf_tables looks the owner up before EXCL).
  EXPECT_TRUE(second.error().error == EEXIST || second.error().error == EPERM) << second.error().to_string();
}

TEST_F(LinkClosureTest, NoSuchNamespace_NotFound) {
  auto link = LinkClosure::create(UplinkSpec{.label = "nons", .netns = "rjN_absent_" + std::to_string(::getpid())});
  ASSERT_FALSE(link);
  EXPECT_EQ(link.error().error, ENOENT) << link.error().to_string();
  EXPECT_NE(link.error().to_string().find("/run/netns/rjN_absent_"), std::string::npos) << link.error().to_string();
}

TEST_F(LinkClosureTest, NoSuchDevice_NoDevice) {
  UplinkSpec spec = vehicle_uplink("nodev");
  spec.devices = {"rjNabsent0"};
  auto link = LinkClosure::create(spec);
  ASSERT_FALSE(link);
  EXPECT_EQ(link.error().error, ENODEV) << link.error().to_string();
  EXPECT_NE(link.error().to_string().find("rjNabsent0"), std::string::npos) << link.error().to_string();
}

TEST_F(LinkClosureTest, BadLabel_Invalid) {
  auto link = LinkClosure::create(UplinkSpec{.label = "no spaces", .netns = hosts_->vehicle});
  ASSERT_FALSE(link);
  EXPECT_EQ(link.error().error, EINVAL) << link.error().to_string();
}

// The fallback without CAP_NET_ADMIN, by its effect: a process in a v2 cgroup of its own writes a byte every
// millisecond; frozen by close(), it writes none while a process outside the group writes 50; thawed by open(),
// it writes again. Root only (a cgroup under the v2 hierarchy at /sys/fs/cgroup/unified).
// Bytes waiting in the pipe `fd`, read and counted.
std::uint64_t drain_bytes(int fd) {
  std::uint64_t n = 0;
  std::array<char, 256> buf{};
  for (ssize_t got; (got = ::read(fd, buf.data(), buf.size())) > 0;) n += static_cast<std::uint64_t>(got);
  return n;
}

class LinkClosureFreeze : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root: a cgroup of its own";
    std::string why;
    const auto group = rejuv::test_support::make_own_cgroup_v2_group("rjN_freeze_" + std::to_string(::getpid()), why);
    if (!group) GTEST_SKIP() << why;
    group_ = *group;
  }
  void TearDown() override {
    for (pid_t& p : children_) {
      if (p > 0) {
        ::kill(p, SIGKILL);
        int status = 0;
        ::waitpid(p, &status, 0);
      }
    }
    if (!group_.empty()) ::rmdir(group_.c_str());
  }
  // A child writing a byte to `to` every millisecond, in `group` when given (it joins before its first byte).
  void writer(int to, const fs::path& group) {
    const pid_t p = ::fork();
    ASSERT_GE(p, 0);
    if (p == 0) {
      if (!group.empty()) {
        const int procs = ::open((group / "cgroup.procs").c_str(), O_WRONLY);
        if (procs < 0 || ::write(procs, "0", 1) != 1) ::_exit(3);
        ::close(procs);
      }
      for (;;) {
        if (::write(to, "x", 1) != 1) ::_exit(0);
        ::usleep(1000);
      }
    }
    children_.push_back(p);
  }
  // How the writers that ended ended ("pid 12: exit 3"), for a failure's message.
  std::string ended() {
    std::string out;
    for (pid_t& p : children_) {
      int status = 0;
      if (p > 0 && ::waitpid(p, &status, WNOHANG) == p) {
        out += "pid " + std::to_string(p) + ": " +
               (WIFEXITED(status) ? "exit " + std::to_string(WEXITSTATUS(status)) : "signal " + std::to_string(WTERMSIG(status))) + "; ";
        p = -1;
      }
    }
    return out.empty() ? "both writers still run" : out;
  }
  fs::path group_;
  std::vector<pid_t> children_;
};

TEST_F(LinkClosureFreeze, Closed_GroupWritesNothing_OpenedWritesAgain) {
  int in_group[2], outside[2];
  ASSERT_EQ(::pipe2(in_group, O_NONBLOCK | O_CLOEXEC), 0);
  ASSERT_EQ(::pipe2(outside, O_NONBLOCK | O_CLOEXEC), 0);
  UniqueFd group_read(in_group[0]), group_write(in_group[1]), out_read(outside[0]), out_write(outside[1]);
  writer(group_write.get(), group_);
  writer(out_write.get(), {});
  auto link = LinkClosure::freezing(group_, "test");
  ASSERT_TRUE(link) << link.error().to_string();
  ASSERT_TRUE(wait_for([&] { return drain_bytes(group_read.get()) > 0; })) << "the writer in the group never wrote: " << ended();

  auto closed = link->close();
  ASSERT_TRUE(closed) << closed.error().to_string();
  ASSERT_TRUE(wait_for([&] { return slurp(group_ / "cgroup.events").find("frozen 1") != std::string::npos; }))
      << slurp(group_ / "cgroup.events");
  (void)drain_bytes(group_read.get());
  (void)drain_bytes(out_read.get());
  std::uint64_t outside_wrote = 0;
  ASSERT_TRUE(wait_for([&] { return (outside_wrote += drain_bytes(out_read.get())) >= 50; }));
  EXPECT_EQ(drain_bytes(group_read.get()), 0U) << "a frozen group wrote";

  auto opened = link->open();
  ASSERT_TRUE(opened) << opened.error().to_string();
  EXPECT_TRUE(wait_for([&] { return drain_bytes(group_read.get()) > 0; })) << "the thawed group did not write again";
}

TEST(LinkClosureFreezeErrors, NoSuchCgroup_NotFound) {
  auto link = LinkClosure::freezing("/sys/fs/cgroup/unified/rjN_absent_" + std::to_string(::getpid()), "absent");
  ASSERT_FALSE(link);
  EXPECT_EQ(link.error().error, ENOENT) << link.error().to_string();
}

}  // namespace
