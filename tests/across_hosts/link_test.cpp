// The link between hosts, by its effect (docs/across_hosts.md "The link"; root only, skipped otherwise): two network
// namespaces joined by a veth pair stand for the vehicle and the companion; a keystore is made with `rejuv keys`;
// the square of launch/quad_square with SR, on the vehicle's host, and the monitor of monitor.cpp on the
// companion's, each part run by its own `rejuv run --host` kernel in real time. Checked:
//   - the companion's monitor receives vehicle states, in MC (through link_companion → DDS with DDS Security →
//     link_vehicle);
//   - the vehicle's link is a process of its own (not the kernel) in the vehicle's network namespace;
//   - killed, the link is started again by its kernel (a new pid), and the vehicle stays in its safety set (the
//     run summary's max V < 1);
//   - both runs end by themselves, and no link process is left in either namespace.
// No timing is asserted: the runs last as long as they last, the waits are for events.
#include "link_fixture.hpp"

namespace {

using namespace rejuv::test_support::across;

class HostLink : public TwoHostsTest {
 protected:
  HostLink() : TwoHostsTest("rjL") {}
};

TEST_F(HostLink, SquareWithACompanion_StatesCrossInMc_LinkRestarted_VehicleSafe) {
  // The companion outlasts the vehicle: it sees the whole flight (each run also aligns for the same 20 s first).
  auto companion = start("companion", 40);
  ASSERT_GT(companion->pid(), 0);
  auto vehicle = start("vehicle", 30);
  ASSERT_GT(vehicle->pid(), 0);

  // The vehicle's link: a process of its own, the kernel's child, in the vehicle's network namespace.
  std::set<pid_t> first;
  ASSERT_TRUE(until(*vehicle, [&] { return !(first = links_of(vehicle->pid())).empty(); })) << vehicle->err();
  ASSERT_EQ(first.size(), 1U);
  const pid_t link = *first.begin();
  EXPECT_NE(link, vehicle->pid());
  const ino_t vehicle_ns = netns_inode(fs::path("/run/netns") / vehicle_ns_);
  ASSERT_NE(vehicle_ns, 0U);
  EXPECT_EQ(netns_inode(fs::path("/proc") / std::to_string(link) / "ns" / "net"), vehicle_ns);
  EXPECT_NE(netns_inode("/proc/self/ns/net"), vehicle_ns);

  // The monitor on the companion gets vehicle states, in MC; then the link is killed.
  ASSERT_TRUE(until(*companion, [&] { return received_in_mc(companion->err()) > 0; })) << companion->err();
  ASSERT_EQ(::kill(link, SIGKILL), 0);
  std::set<pid_t> again;
  ASSERT_TRUE(until(*vehicle, [&] {
    again = links_of(vehicle->pid());
    return !again.empty() && again.count(link) == 0;
  })) << vehicle->err();
  EXPECT_EQ(netns_inode(fs::path("/proc") / std::to_string(*again.begin()) / "ns" / "net"), vehicle_ns);

  const CliOutcome v = vehicle->wait();
  const CliOutcome c = companion->wait();
  EXPECT_NE(v.err.find("service 'link_companion' restarted from its binary"), std::string::npos) << v.err;
  // The vehicle stayed in its safety set: the run summary's max V below 1.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(v.out, m, std::regex(R"(max V = ([0-9.]+))"))) << v.out;
  EXPECT_LT(std::stod(m[1].str()), 1.0) << v.out;
  EXPECT_GT(received_in_mc(c.err), 0) << c.err;
  EXPECT_EQ(c.exit_code, 0) << c.out << c.err;
  // Nothing left behind: no link in either namespace.
  EXPECT_TRUE(links_in(vehicle_ns).empty());
  EXPECT_TRUE(links_in(netns_inode(fs::path("/run/netns") / companion_ns_)).empty());
}

}  // namespace
