// The vehicle stays safe when the link between hosts is bad or hostile (docs/across_hosts.md "The link"; root only,
// skipped otherwise). The set-up of link_test.cpp (link_fixture.hpp): the square with SR on the vehicle, the
// companion's monitor, each host's part run by its own `rejuv run --host` kernel in a network namespace of its own.
//   - LossyLinkAndAnIntruder: an nftables rule in the companion's namespace drops one packet in five at random
//     each way on its end of the veth (`numgen random mod 5 == 0`; this kernel has no netem) for the whole flight.
//     Beside the companion's kernel, in its namespace, three Cyclone participants (rejuv_dds_peer) subscribe to
//     rejuv/vehicle_state for the whole flight: one with an identity signed by the project's CA whose
//     permissions, signed by the CA too, grant nothing; one with such an identity and permissions granting the
//     topic that are signed by a CA of its own (the project's permissions CA never signed them); and, as the
//     control, participants with the companion's own enclave, one after another until one receives. (The forged
//     one's own Cyclone also refuses the vehicle's
//     participant, whose permissions do not verify against its CA: an intruder cannot trust both.) Checked: the
//     vehicle's run ends with max V < 1, the control receives vehicle states, the rule dropped packets (its
//     counters), and the two intruders receive none; what the companion's monitor received is said, not judged
//     (once, none in 30 s: the links' secure handshake through the lossy link open only in MC did not complete).
//     (A participant without security receives nothing: across_hosts_test.cpp.)
//   - CompanionKilledMidFlight: the companion's kernel, once its monitor receives vehicle states, is killed with
//     its whole process group (SIGKILL); the vehicle's run ends with max V < 1, its link is still a process of
//     its kernel after the companion is gone, and no process of the companion is left.
// No timing is asserted: the waits are for events; the namespaces (and the nftables table in one) are removed in
// TearDown, also when a check failed.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>

#include "keystore.hpp"
#include "link_fixture.hpp"
#include "rejuv/core/dds_name.hpp"
#include "rejuv/services/host_link/host_link.hpp"

namespace {

using namespace rejuv::test_support::across;

const fs::path kPeer = REJUV_DDS_PEER;
constexpr const char* kVehicleAddress = "10.77.0.1";  // as link_fixture.hpp's hosts
constexpr const char* kCompanionAddress = "10.77.0.2";
const std::string kVehicleStateTopic = rejuv::dds_topic_name("vehicle_state", rejuv::DdsNaming::Rejuv);

// The counters' packets of `nft list table` output, in order ("counter packets N bytes M").
std::vector<long long> counter_packets(const std::string& listing) {
  static const std::regex counter(R"(counter packets (\d+) bytes)");
  std::vector<long long> out;
  for (auto it = std::sregex_iterator(listing.begin(), listing.end(), counter); it != std::sregex_iterator(); ++it) {
    out.push_back(std::stoll((*it)[1].str()));
  }
  return out;
}

// The run summary's max V, or -1 when it has none.
double max_v(const std::string& out) {
  std::smatch m;
  return std::regex_search(out, m, std::regex(R"(max V = ([0-9.]+))")) ? std::stod(m[1].str()) : -1.0;
}

// A process by its pid and its start time (field 22 of /proc/<pid>/stat), so that a pid reused later is not
// taken for it.
using ProcessId = std::pair<pid_t, std::string>;

std::string start_time(pid_t pid) {
  const std::string stat = slurp(fs::path("/proc") / std::to_string(pid) / "stat");
  const std::size_t paren = stat.rfind(')');
  if (paren == std::string::npos) return {};
  std::istringstream fields(stat.substr(paren + 2));
  std::string f;
  for (int i = 3; i <= 22 && fields >> f; ++i) {
  }
  return f;
}

// `root` and every process descended from it.
std::vector<ProcessId> process_tree(pid_t root) {
  std::multimap<pid_t, pid_t> children;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator("/proc", ec)) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream status(e.path() / "status");
    for (std::string line; std::getline(status, line);) {
      if (line.rfind("PPid:", 0) == 0) children.emplace(static_cast<pid_t>(std::atoi(line.c_str() + 5)), std::stoi(name));
    }
  }
  std::vector<ProcessId> out{{root, start_time(root)}};
  for (std::size_t i = 0; i < out.size(); ++i) {
    for (auto [it, end] = children.equal_range(out[i].first); it != end; ++it) out.emplace_back(it->second, start_time(it->second));
  }
  return out;
}

// The processes of `tree` that still exist (the same pid with the same start time).
std::vector<pid_t> alive(const std::vector<ProcessId>& tree) {
  std::vector<pid_t> out;
  for (const auto& [pid, started] : tree) {
    if (!started.empty() && start_time(pid) == started) out.push_back(pid);
  }
  return out;
}

class HostileLink : public TwoHostsTest {
 protected:
  HostileLink() : TwoHostsTest("rjS") {}

  // An nftables table in the companion's namespace that drops one packet in five at random each way on the
  // companion's end of the veth, counting what it drops.
  void add_loss() {
    const fs::path rules = dir_ / "loss.nft";
    std::ofstream(rules) << "table inet rjS_loss {\n"
                         << "  chain in { type filter hook input priority 0; policy accept;\n"
                         << "    iifname \"" << veth_c_ << "\" numgen random mod 5 == 0 counter drop\n  }\n"
                         << "  chain out { type filter hook output priority 0; policy accept;\n"
                         << "    oifname \"" << veth_c_ << "\" numgen random mod 5 == 0 counter drop\n  }\n"
                         << "}\n";
    const CliOutcome r = rejuv::test_support::run_program(dir_ / "cmd", kIp,
                                                          {"netns", "exec", companion_ns_, "nft", "-f", rules.string()});
    ASSERT_EQ(r.exit_code, 0) << "nft -f: " << r.err;
  }
  std::vector<long long> dropped() {
    return counter_packets(rejuv::test_support::run_program(dir_ / "cmd", kIp,
                                                            {"netns", "exec", companion_ns_, "nft", "list", "table",
                                                             "inet", "rjS_loss"})
                               .out);
  }

  // rejuv_dds_peer subscribing to rejuv/vehicle_state in the companion's namespace with `enclave`, as the link's
  // Cyclone configuration (host_link::cyclone_config) would name it; it runs until stopped (or as `extra` says).
  std::unique_ptr<KernelRun> subscriber(const std::string& name, const fs::path& enclave,
                                        const std::vector<std::string>& extra = {"--seconds", "600"}) {
    const fs::path cfg = dir_ / (name + ".xml");
    std::ofstream(cfg) << rejuv::services::host_link::cyclone_config(
        {.address = kCompanionAddress, .peers = {kCompanionAddress, kVehicleAddress}, .enclave = enclave, .private_key_pem = {}});
    const fs::path d = dir_ / name;
    fs::create_directories(d);
    std::vector<std::string> args{"netns", "exec", companion_ns_, kPeer.string(), "subscribe", kVehicleStateTopic,
                                  "--domain", std::to_string(domain()), "--config", cfg.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return std::make_unique<KernelRun>(d, rejuv::test_support::start_program(d, kIp, std::move(args)));
  }
  static CliOutcome stop(std::unique_ptr<KernelRun>& peer) {
    ::kill(peer->pid(), SIGTERM);
    return peer->wait();
  }
  std::string out_of(const std::string& name) const { return slurp(dir_ / name / "stdout"); }
};

// The number N of a peer's "received N", or -1 without one.
long long received(const std::string& out) {
  std::smatch m;
  return std::regex_search(out, m, std::regex(R"(received (\d+))")) ? std::stoll(m[1].str()) : -1;
}

TEST_F(HostileLink, LossyLinkAndAnIntruder_VehicleSafe_CompanionReceives_IntrudersNothing) {
  // The intruders' enclaves. "nogrant": an identity of the project's CA (a copy of the keystore's CA) for a host
  // the graph does not have, whose permissions grant nothing. "forged": the same identity, with permissions
  // granting rejuv/vehicle_state signed by a CA of its own, named as its permissions CA.
  const fs::path stolen = dir_ / "intruder_keys", forged = dir_ / "forged_keys";
  fs::create_directories(stolen);
  fs::copy(keys_ / "public", stolen / "public", fs::copy_options::recursive);
  fs::copy(keys_ / "private", stolen / "private", fs::copy_options::recursive);
  auto nogrant = rejuv::keys::write_enclaves(stolen, {{.host = "intruder", .publish = {}, .subscribe = {}}}, domain());
  ASSERT_TRUE(nogrant) << nogrant.error();
  auto own_ca = rejuv::keys::init_keystore(forged);
  ASSERT_TRUE(own_ca) << own_ca.error();
  auto forged_grant = rejuv::keys::write_enclaves(
      forged, {{.host = "intruder", .publish = {}, .subscribe = {kVehicleStateTopic}}}, domain());
  ASSERT_TRUE(forged_grant) << forged_grant.error();
  namespace ef = rejuv::keys::enclave_file;
  for (const std::string_view f : {ef::kCert, ef::kKey, ef::kIdentityCa}) {
    fs::copy_file(stolen / "enclaves" / "intruder" / f, forged / "enclaves" / "intruder" / f,
                  fs::copy_options::overwrite_existing);
  }

  add_loss();
  if (HasFatalFailure()) return;
  auto no_grant = subscriber("no_grant", stolen / "enclaves" / "intruder");
  auto forged_perms = subscriber("forged_permissions", forged / "enclaves" / "intruder");
  for (const auto* p : {&no_grant, &forged_perms}) ASSERT_GT((*p)->pid(), 0);
  // The forged one reads (its reader exists) before the flight begins.
  ASSERT_TRUE(until(*forged_perms, [&] { return out_of("forged_permissions").find("reading") != std::string::npos; }))
      << out_of("forged_permissions") << forged_perms->err();

  auto companion = start("companion", 40);
  auto vehicle = start("vehicle", 30);
  ASSERT_GT(companion->pid(), 0);
  ASSERT_GT(vehicle->pid(), 0);
  // The control, while the intruders listen: a participant with the companion's enclave, each until its first
  // sample (or 10 s), one after another while the vehicle runs, until one receives. The first ones end with
  // nothing while the vehicle aligns (20 s without MC: its link is closed); and one participant for the whole
  // flight is not a reliable witness: its DDS Security handshake with the vehicle's link, through 20 % loss and a
  // link open only in the vehicle's MC windows, did not complete in 2 runs of 5 (it received nothing while the
  // companion's link received).
  int controls = 0;
  long long control_received = 0;
  while (control_received <= 0 && !vehicle->ended()) {
    const std::string name = "control_" + std::to_string(++controls);
    auto control = subscriber(name, keys_ / "enclaves" / "companion", {"--first", "--seconds", "10"});
    ASSERT_GT(control->pid(), 0);
    const CliOutcome r = control->wait();
    control_received = received(r.out);
  }
  const CliOutcome v = vehicle->wait();
  const CliOutcome c = companion->wait();

  // The vehicle stayed in its safety set (what the loss must not cost). What the companion got through the lossy
  // link is said, not judged: in one CI run of 30 s it got nothing (the two links' DDS Security handshake, through
  // a link open only in 200 ms MC windows and losing one packet in five each way, did not complete), in others
  // hundreds.
  const double v_max = max_v(v.out);
  ASSERT_GE(v_max, 0.0) << v.out << v.err;
  EXPECT_LT(v_max, 1.0) << v.out;
  std::printf("through the lossy link the companion's monitor received %lld vehicle states in MC\n",
              received_in_mc(c.err));
  EXPECT_EQ(c.exit_code, 0) << c.out << c.err;
  // The rule dropped packets each way.
  const std::vector<long long> drops = dropped();
  ASSERT_EQ(drops.size(), 2U);
  EXPECT_GT(drops[0], 0) << "nothing dropped coming in";
  EXPECT_GT(drops[1], 0) << "nothing dropped going out";

  const CliOutcome forged_out = stop(forged_perms);
  const CliOutcome nogrant_out = stop(no_grant);
  EXPECT_GT(control_received, 0) << controls << " participants with the companion's enclave received nothing";
  EXPECT_EQ(received(forged_out.out), 0) << forged_out.out << forged_out.err;
  // Without a grant, its own Cyclone refuses the participant (default DENY: "participant denied by default rule")
  // or the reader; or the reader exists and receives nothing.
  const bool refused = nogrant_out.out.find("refused: dds_create_participant") != std::string::npos ||
                       nogrant_out.out.find("refused: dds_create_reader") != std::string::npos;
  EXPECT_TRUE(refused || received(nogrant_out.out) == 0) << nogrant_out.out << nogrant_out.err;
  std::cout << "loss: dropped in/out " << drops[0] << "/" << drops[1] << "; companion's monitor in MC "
            << received_in_mc(c.err) << ", control received after " << controls << " participant(s), forged permissions "
            << received(forged_out.out) << ", no grant: " << nogrant_out.out << "max V " << v_max << "\n";
}

TEST_F(HostileLink, CompanionKilledMidFlight_VehicleSafe_NothingOfTheCompanionLeft) {
  auto companion = start("companion", 40, /*own_session=*/true);
  auto vehicle = start("vehicle", 30);
  ASSERT_GT(companion->pid(), 0);
  ASSERT_GT(vehicle->pid(), 0);
  // Mid-flight: the companion's monitor receives vehicle states.
  ASSERT_TRUE(until(*companion, [&] { return received_in_mc(companion->err()) > 0; })) << companion->err();
  ASSERT_EQ(::getpgid(companion->pid()), companion->pid());
  const std::vector<ProcessId> tree = process_tree(companion->pid());
  ASSERT_GT(tree.size(), 1U);  // the kernel and its services
  ASSERT_EQ(::kill(-companion->pid(), SIGKILL), 0);
  (void)companion->wait();

  // Every process of the companion goes (its services die with their kernel).
  EXPECT_TRUE(until(*vehicle, [&] { return alive(tree).empty(); })) << alive(tree).size() << " left";
  // The vehicle's link is a process of its kernel after the companion is gone.
  std::set<pid_t> links;
  EXPECT_TRUE(until(*vehicle, [&] { return !(links = links_of(vehicle->pid())).empty(); })) << vehicle->err();
  EXPECT_FALSE(vehicle->ended());

  const CliOutcome v = vehicle->wait();
  const double v_max = max_v(v.out);
  ASSERT_GE(v_max, 0.0) << v.out << v.err;
  EXPECT_LT(v_max, 1.0) << v.out;
  EXPECT_EQ(v.exit_code, 0) << v.out << v.err;
  EXPECT_TRUE(alive(tree).empty());
  EXPECT_TRUE(links_in(netns_inode(fs::path("/run/netns") / companion_ns_)).empty());
  std::cout << "companion killed (" << tree.size() << " processes); vehicle's max V " << v_max << "\n";
}

}  // namespace
