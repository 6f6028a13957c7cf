// `rejuv bench across-hosts [--samples N] [--rounds N] [--reopen-seconds N] [--out DIR] [--no-link]`
// (docs/performance.md "Across hosts"): the baseline of a graph across hosts (docs/across_hosts.md). Two network
// namespaces joined by a veth pair stand for the vehicle and the companion of
// tests/across_hosts/companion.launch.pbtxt; in each, one Cyclone DDS participant
// (bench/across_hosts/latency_peer.cpp, `ip netns exec`). The vehicle publishes a vehicle_state-sized sample
// (rejuv::msg::VehicleStateEstimate, 216 B) at 250 Hz on the cross-host topic `rejuv/state`; the companion takes
// it and records the publish → deliver latency (CLOCK_MONOTONIC is one clock for all namespaces).
// Rows, side by side in one run and alternated round by round (a shared machine's slow spells fall on all alike):
//   raw         Cyclone DDS without security (the Cyclone XML shape of tests/across_hosts);
//   secure      the same with DDS Security, the enclaves of a keystore made by `rejuv keys init` and
//               `rejuv keys hosts --launch companion.launch.pbtxt` (authenticated, access-controlled, encrypted);
//   link        service → kernel → link → DDS (secure) → link → kernel → service: the square (launch/quad_square,
//               no SR) on the vehicle with the probe of bench/across_hosts/link_probe.cpp on both hosts, each
//               host under its own `rejuv run --host` kernel with its link process (rejuv_host_link) in its
//               namespace; the probe's topic `link_probe` crosses like any cross-host topic (keystore of
//               `rejuv keys hosts` on that graph). Its first second of samples is left out (discovery).
// Each row as p50/p99/max and as a ratio to the raw row. Then the link's reopening: the same two hosts fly the
// square with SR, the vehicle's run writing its mode changes (events.csv, wall_s on CLOCK_MONOTONIC), the
// companion's probe logging when it received each sample; for each CP → MC after the two links met (the first
// window with a sample: discovery and the handshake run only while the link is open), the time until the
// companion's first sample, and until its first sample published after
// CP → MC, beside the probe's period and the link row's p50. Root only (network namespaces): without root it says so
// and measures nothing. The namespaces (rjP_v<pid>, rjP_c<pid>) and the veth pair are removed on every exit path.
// Nothing here is asserted: the table says what this machine did.
#include <fcntl.h>
#include <signal.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common_options.hpp"
#include "keystore.hpp"
#include "rejuv/core/cyclone_xml.hpp"
#include "args.hpp"
#include "rejuv/sys/lease.hpp"
#include "rejuv/sys/process.hpp"
#include "run_child.hpp"

namespace rejuv::cli {
namespace {

namespace fs = std::filesystem;

const fs::path kIp = "/usr/sbin/ip";
constexpr const char* kVehicleAddress = "10.77.0.1";  // as the graph's hosts
constexpr const char* kCompanionAddress = "10.77.0.2";
constexpr const char* kTopic = "rejuv/state";  // the graph's cross-host topic: vehicle → companion
constexpr std::uint32_t kDomain = 1;            // private to the two namespaces
constexpr int kRateHz = 250;                     // the control period of the in-tree graphs

// A child's output goes to `log`; it is killed and reaped if still running when dropped (sys::ChildProcess).
Result<sys::ChildProcess, std::string> start(const fs::path& executable, const std::vector<std::string>& args,
                                             const fs::path& log) {
  const sys::UniqueFd log_fd(::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (!log_fd) return fail("cannot write " + log.string());
  const sys::UniqueFd null_fd(::open("/dev/null", O_RDONLY | O_CLOEXEC));
  if (!null_fd) return fail(std::string("cannot open /dev/null"));
  sys::SpawnSpec spec;
  spec.executable = executable.string();
  spec.args = args;
  for (char** e = environ; *e != nullptr; ++e) spec.env.emplace_back(*e);
  spec.fds = {{0, null_fd.get()}, {1, log_fd.get()}, {2, log_fd.get()}};
  auto child = sys::spawn(spec);
  if (!child) return fail("cannot start " + executable.string() + ": " + child.error().to_string());
  return std::move(*child);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs a command to its end; its output in `log`; an error with that output unless it exits 0.
Result<void, std::string> run(const fs::path& executable, const std::vector<std::string>& args, const fs::path& log) {
  auto child = start(executable, args, log);
  if (!child) return fail(child.error());
  auto status = child->wait();
  if (!status || !status->success()) {
    std::string cmd = executable.filename().string();
    for (const std::string& a : args) cmd += " " + a;
    return fail(cmd + " failed: " + slurp(log));
  }
  return {};
}

// The two namespaces and the veth pair between them; deleted when dropped (deleting a namespace deletes the veth
// end in it, and with it the pair).
class Namespaces {
 public:
  explicit Namespaces(fs::path dir)
      : dir_(std::move(dir)),
        vehicle_("rjP_v" + std::to_string(::getpid())),
        companion_("rjP_c" + std::to_string(::getpid())) {}
  Namespaces(const Namespaces&) = delete;
  Namespaces& operator=(const Namespaces&) = delete;
  ~Namespaces() {
    // A namespace's file can stay busy for a moment after the link runs' kernels ended (their services' mount
    // namespaces hold a copy of the mount until their last process is gone): tried again for up to 5 s.
    for (const std::string& ns : made_) {
      for (int attempt = 0; attempt < 50 && fs::exists(fs::path("/run/netns") / ns); ++attempt) {
        if (run(kIp, {"netns", "delete", ns}, dir_ / ("ip_delete_" + ns + ".log"))) break;
        ::usleep(100'000);
      }
    }
  }
  // The namespaces of a bench that did not live to delete them (killed: SIGKILL, a test's timeout), named
  // rjP_v<pid> and rjP_c<pid> by a pid no process has now: deleted, with the veth end in each.
  void delete_stale() const {
    std::error_code ec;
    for (const fs::directory_entry& e : fs::directory_iterator("/run/netns", ec)) {
      const std::string name = e.path().filename().string();
      if (name.size() <= 5 || name.rfind("rjP_", 0) != 0 || (name[4] != 'v' && name[4] != 'c')) continue;
      char* end = nullptr;
      const long pid = std::strtol(name.c_str() + 5, &end, 10);
      if (end == nullptr || *end != '\0' || pid <= 0 || pid == ::getpid()) continue;
      if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // its bench still runs
      (void)run(kIp, {"netns", "delete", name}, dir_ / ("ip_delete_" + name + ".log"));
    }
  }
  Result<void, std::string> make() {
    delete_stale();
    const std::string id = std::to_string(::getpid());
    const std::string veth_v = "rjPv" + id, veth_c = "rjPc" + id;  // ≤ 15 characters
    for (const std::string& ns : {vehicle_, companion_}) {
      if (auto ok = run(kIp, {"netns", "add", ns}, dir_ / "ip.log"); !ok) return ok;
      made_.push_back(ns);
    }
    for (const std::vector<std::string>& cmd :
         {std::vector<std::string>{"link", "add", veth_v, "type", "veth", "peer", "name", veth_c},
          {"link", "set", veth_v, "netns", vehicle_}, {"link", "set", veth_c, "netns", companion_},
          {"-n", vehicle_, "addr", "add", std::string(kVehicleAddress) + "/24", "dev", veth_v},
          {"-n", companion_, "addr", "add", std::string(kCompanionAddress) + "/24", "dev", veth_c},
          {"-n", vehicle_, "link", "set", veth_v, "up"}, {"-n", companion_, "link", "set", veth_c, "up"},
          {"-n", vehicle_, "link", "set", "lo", "up"}, {"-n", companion_, "link", "set", "lo", "up"}}) {
      if (auto ok = run(kIp, cmd, dir_ / "ip.log"); !ok) return ok;
    }
    return {};
  }
  [[nodiscard]] const std::string& vehicle() const { return vehicle_; }
  [[nodiscard]] const std::string& companion() const { return companion_; }

 private:
  fs::path dir_;
  std::string vehicle_, companion_;
  std::vector<std::string> made_;
};

// The Cyclone XML of one participant, the shape of tests/across_hosts: its own address, both hosts as unicast
// peers, no multicast and, for a secure one, the enclave of `enclave` in `keys` ("" = no security).
fs::path write_config(const fs::path& file, const char* address, const fs::path& keys, const std::string& enclave) {
  std::ofstream(file) << cyclone::config_xml(cyclone::ParticipantConfig{
                             .address = address,
                             .peers = {kVehicleAddress, kCompanionAddress},
                             .enclave = enclave.empty() ? fs::path() : keys::enclave_dir(keys, enclave)})
                      << "\n";
  return file;
}

// The keystore as a user makes it: `rejuv keys init KEYS` (once: a second run into one --out keeps its CA), then
// `rejuv keys hosts KEYS --launch GRAPH --domain DOMAIN`.
Result<void, std::string> make_keystore(const fs::path& self, const fs::path& keys, const fs::path& graph,
                                        const std::string& domain, const fs::path& log) {
  if (!fs::exists(keys::enclave_dir(keys, "vehicle"))) {
    if (auto ok = run(self, {"keys", "init", keys.string()}, log); !ok) return ok;
  }
  return run(self, {"keys", "hosts", keys.string(), "--launch", graph.string(), "--domain", domain}, log);
}

struct Row {
  std::string name, what;
  std::string vehicle_enclave, companion_enclave;  // "" = no security
  std::vector<double> latencies_us;
  std::uint64_t sent = 0;
  std::string error;
};

// Waits until `log` holds `line` or the child ended; true if it does.
bool printed(sys::ChildProcess& child, const fs::path& log, const std::string& line) {
  for (;;) {
    if (slurp(log).find(line) != std::string::npos) return true;
    auto ended = child.try_wait();
    if (!ended || *ended) return slurp(log).find(line) != std::string::npos;
    ::usleep(10'000);
  }
}

// One round of `row`: the companion's subscriber, then the vehicle's publisher; their latencies added to the row.
void measure(Row& row, const Namespaces& ns, const fs::path& peer, const fs::path& dir, const fs::path& keys,
             std::uint64_t samples, int round) {
  const std::string tag = row.name + "_" + std::to_string(round);
  const fs::path sub_cfg = write_config(dir / (tag + "_companion.xml"), kCompanionAddress, keys, row.companion_enclave);
  const fs::path pub_cfg = write_config(dir / (tag + "_vehicle.xml"), kVehicleAddress, keys, row.vehicle_enclave);
  const fs::path out = dir / (tag + "_latency_ns.txt");
  const std::string n = std::to_string(samples);
  const std::string seconds = std::to_string(60 + samples / kRateHz * 2);
  auto sub = start(kIp, {"netns", "exec", ns.companion(), peer.string(), "subscribe", kTopic, "--domain",
                         std::to_string(kDomain), "--config", sub_cfg.string(), "--samples", n, "--seconds", seconds,
                         "--out", out.string()}, dir / (tag + "_companion.log"));
  if (!sub) { row.error = sub.error(); return; }
  if (!printed(*sub, dir / (tag + "_companion.log"), "reading")) {
    row.error = "the companion's reader: " + slurp(dir / (tag + "_companion.log"));
    return;
  }
  auto pub = start(kIp, {"netns", "exec", ns.vehicle(), peer.string(), "publish", kTopic, "--domain",
                         std::to_string(kDomain), "--config", pub_cfg.string(), "--samples", n, "--rate-hz",
                         std::to_string(kRateHz), "--seconds", seconds}, dir / (tag + "_vehicle.log"));
  if (!pub) { row.error = pub.error(); return; }
  auto pub_status = pub->wait();
  auto sub_status = sub->wait();
  if (!pub_status || !pub_status->success() || !sub_status || !sub_status->success()) {
    row.error = "round " + std::to_string(round) + ": vehicle: " + slurp(dir / (tag + "_vehicle.log")) +
                " companion: " + slurp(dir / (tag + "_companion.log"));
    return;
  }
  row.sent += samples;
  std::ifstream in(out);
  for (long long ns_value = 0; in >> ns_value;) row.latencies_us.push_back(static_cast<double>(ns_value) / 1000.0);
}

// ---- the link rows: the square on two `rejuv run --host` kernels, the probe (link_probe.cpp) on both hosts ----

// What both link flights share: the graph (the square, the probe on both hosts, the hosts in the bench's
// namespaces), its keystore, and a DDS domain for each host's kernel and plant (they talk on the loopback).
struct LinkSetup {
  sys::DdsDomainLease lease;
  std::string domain;
  fs::path graph, keys;
};

Result<LinkSetup, std::string> set_up_link(const Namespaces& ns, const fs::path& dir, const fs::path& self) {
  auto lease = sys::lease_dds_domain_for_worker(1);
  if (!lease) return fail("no free DDS domain: " + lease.error().to_string());
  const std::string domain = std::to_string(lease->slot());
  const fs::path graph = dir / "link_probe.launch.pbtxt";
  std::ofstream(graph) << "include: \"" REJUV_SOURCE_DIR "/launch/quad_square.launch.pbtxt\"\n"
                       << "policy_include: \"" REJUV_SOURCE_DIR "/bench/across_hosts/link_probe.policy.pbtxt\"\n"
                       << "hosts { name: \"vehicle\" address: \"" << kVehicleAddress << "\" netns: \""
                       << ns.vehicle() << "\" }\n"
                       << "hosts { name: \"companion\" address: \"" << kCompanionAddress << "\" netns: \""
                       << ns.companion() << "\" }\n"
                       << "services { name: \"probe_pub\" executable: \"rejuv_link_probe_pub\" host: \"vehicle\"\n"
                       << "  uses { object: \"link_probe\" rights: \"W\" } }\n"
                       << "services { name: \"probe_sub\" executable: \"rejuv_link_probe_sub\" host: \"companion\"\n"
                       << "  uses { object: \"link_probe\" rights: \"R\" } }\n";
  const fs::path keys = dir / "link_keys";
  if (auto ok = make_keystore(self, keys, graph, domain, dir / "link_keys.log"); !ok) return fail(ok.error());
  return LinkSetup{.lease = std::move(*lease), .domain = domain, .graph = graph, .keys = keys};
}

// The vehicle's SR in a link flight: off for the latencies (the link open throughout), on for its reopening.
enum class Sr : std::uint8_t { Off, On };

// One flight of both hosts' kernels, into DIR/<tag>_vehicle.log and DIR/<tag>_companion.log; `vehicle_options`
// added to the vehicle's `rejuv run`. The vehicle aligns (20 s) before its flight; the companion, without a
// plant, outlasts it.
Result<void, std::string> fly_hosts(const LinkSetup& link, const fs::path& dir, const std::string& tag,
                                    std::uint64_t flight_s, Sr sr, const std::vector<std::string>& vehicle_options) {
  const auto host_run = [&](const std::string& host, std::uint64_t seconds, const std::vector<std::string>& more) {
    std::vector<std::string> args{link.graph.string(), "--host", host, "--keys", link.keys.string(), "--domain",
                                  link.domain, "--duration", std::to_string(seconds), "--no-attack", "--net-port",
                                  "0"};
    if (sr == Sr::Off) args.emplace_back("--no-sr");
    args.insert(args.end(), more.begin(), more.end());
    return start_rejuv_run(args, dir / (tag + "_" + host + ".log"));
  };
  auto companion = host_run("companion", flight_s + 35, {});
  if (!companion) return fail(companion.error());
  auto vehicle = host_run("vehicle", flight_s, vehicle_options);
  if (!vehicle) return fail(vehicle.error());
  auto v = vehicle->wait();
  auto c = companion->wait();
  if (!v || !v->success() || !c || !c->success()) {
    return fail("the hosts' runs (" + (dir / (tag + "_vehicle.log")).string() + ", " + tag +
                "_companion.log) did not end cleanly");
  }
  return {};
}

// What the companion's probe logged, in the order it received the samples: each one's publish → deliver
// latency and the CLOCK_MONOTONIC at which it was received [ns] (link_probe.cpp).
struct ProbeLog {
  std::vector<std::int64_t> latency_ns, received_ns;
};

std::vector<std::int64_t> logged_values(const std::string& log, const std::string& tag) {
  std::vector<std::int64_t> out;
  std::istringstream lines(log);
  for (std::string line; std::getline(lines, line);) {
    const auto at = line.find(tag);
    if (at == std::string::npos) continue;
    std::istringstream values(line.substr(at + tag.size()));
    for (long long value = 0; values >> value;) out.push_back(value);
  }
  return out;
}

ProbeLog read_probe_log(const fs::path& log) {
  const std::string text = slurp(log);
  return ProbeLog{.latency_ns = logged_values(text, "link probe latencies [ns]:"),
                  .received_ns = logged_values(text, "link probe received [ns]:")};
}

// The link's row: the square without SR. Samples of its first second (kRateHz) are left out: they waited for
// discovery.
void measure_link(Row& row, const LinkSetup& link, const fs::path& dir, std::uint64_t samples) {
  const std::uint64_t flight_s = std::max<std::uint64_t>(5, samples / kRateHz);
  if (auto flown = fly_hosts(link, dir, "link", flight_s, Sr::Off, {}); !flown) {
    row.error = flown.error();
    return;
  }
  const ProbeLog probe = read_probe_log(dir / "link_companion.log");
  for (std::size_t i = kRateHz; i < probe.latency_ns.size(); ++i) {
    row.latencies_us.push_back(static_cast<double>(probe.latency_ns[i]) / 1000.0);
  }
  row.sent = row.latencies_us.size();  // received; what was sent is not counted
}

// An MC window of the vehicle's flight with SR, on CLOCK_MONOTONIC [ns]: from CP → MC (its link opened) to the
// next change out of MC (closed), and the first probe samples the companion received in it, as times since
// CP → MC.
struct ReopenWindow {
  std::int64_t opened_ns = 0, closed_ns = 0;
  std::optional<std::int64_t> first_ns;      // the first sample received (none: nullopt)
  std::optional<std::int64_t> first_new_ns;  // the first one published after CP → MC
  bool first_held = false;  // the first one received was published before CP → MC: held over the closure and
                            // delivered after it
};

// The reopening's measurement: the windows of the flight in order. The windows until the first that carried a
// sample — the two links meeting (discovery and the DDS Security handshake, which run only while the vehicle's
// link is open) — are left out of the statistics; `met` is that window's index.
struct Reopen {
  std::uint64_t flight_s = 0;
  std::vector<ReopenWindow> windows;
  std::size_t met = 0;
  std::string error;
};

// The vehicle's MC windows from its events.csv (t_s,wall_s,kind,epoch,generation,mode,…: the rows of kind
// "mode", wall_s CLOCK_MONOTONIC [s]): each CP → MC until the next mode that is not MC. One still open when the
// run stops is left out.
std::vector<ReopenWindow> mc_windows(const fs::path& events) {
  std::vector<ReopenWindow> out;
  std::istringstream lines(slurp(events));
  std::string line, previous;
  std::getline(lines, line);  // the header
  bool open = false;  // in an MC window entered from CP at opened_ns
  std::int64_t opened_ns = 0;
  while (std::getline(lines, line)) {
    std::vector<std::string> f;
    std::istringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    if (f.size() < 6 || f[2] != "mode") continue;
    const std::int64_t wall_ns = std::llround(std::strtod(f[1].c_str(), nullptr) * 1e9);
    if (f[5] == "MC" && previous == "CP") {
      open = true;
      opened_ns = wall_ns;
    } else if (f[5] != "MC" && open) {
      out.push_back(ReopenWindow{
          .opened_ns = opened_ns, .closed_ns = wall_ns, .first_ns = {}, .first_new_ns = {}, .first_held = false});
      open = false;
    }
    previous = f[5];
  }
  return out;
}

// For each window, the first sample the companion received in it and the first one published in it (received
// − latency ≥ CP → MC). `probe`'s samples are in the order received, so their receive times are sorted.
void find_first_samples(std::vector<ReopenWindow>& windows, const ProbeLog& probe) {
  const auto& received = probe.received_ns;
  for (ReopenWindow& w : windows) {
    for (auto it = std::lower_bound(received.begin(), received.end(), w.opened_ns);
         it != received.end() && *it < w.closed_ns; ++it) {
      const std::int64_t published_ns = *it - probe.latency_ns[static_cast<std::size_t>(it - received.begin())];
      const bool published_after = published_ns >= w.opened_ns;
      if (!w.first_ns) {
        w.first_ns = *it - w.opened_ns;
        w.first_held = !published_after;
      }
      if (published_after) {
        w.first_new_ns = *it - w.opened_ns;
        break;
      }
    }
  }
}

// The link's reopening: the square with SR (its MC windows from the vehicle's events.csv, `rejuv run --out`),
// and for each CP → MC the first probe sample the companion received after it.
void measure_reopen(Reopen& reopen, const LinkSetup& link, const fs::path& dir) {
  const fs::path out = dir / "reopen_vehicle_out";
  if (auto flown = fly_hosts(link, dir, "reopen", reopen.flight_s, Sr::On, {"--out", out.string(), "--no-figures"});
      !flown) {
    reopen.error = flown.error();
    return;
  }
  const ProbeLog probe = read_probe_log(dir / "reopen_companion.log");
  if (probe.latency_ns.size() != probe.received_ns.size()) {
    reopen.error = "the companion's probe logged " + std::to_string(probe.latency_ns.size()) + " latencies but " +
                   std::to_string(probe.received_ns.size()) + " receive times (lines lost to the log's rate limit?)";
    return;
  }
  reopen.windows = mc_windows(out / "events.csv");
  if (reopen.windows.empty()) {
    reopen.error = "no CP -> MC in " + (out / "events.csv").string();
    return;
  }
  find_first_samples(reopen.windows, probe);
  const auto met = std::find_if(reopen.windows.begin(), reopen.windows.end(),
                                [](const ReopenWindow& w) { return w.first_ns.has_value(); });
  if (met == reopen.windows.end()) {
    reopen.error = "the links did not meet: no sample reached the companion in any of the flight's " +
                   std::to_string(reopen.windows.size()) + " MC windows (discovery and the DDS Security handshake "
                   "run only while the vehicle's link is open; a longer --reopen-seconds gives them more windows)";
    return;
  }
  reopen.met = static_cast<std::size_t>(met - reopen.windows.begin());
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

// A row left out on purpose says "not measured (…)"; any other error is a failure.
bool is_failure(const std::string& error) { return !error.empty() && error.rfind("not measured", 0) != 0; }
const char* row_failure(const std::string& error) { return is_failure(error) ? "failed: " : ""; }

void print_table(const std::vector<Row>& rows, std::uint64_t samples, std::uint64_t rounds) {
  std::printf("publish -> deliver, rejuv::msg::VehicleStateEstimate (216 B) on %s at %d Hz, vehicle namespace -> "
              "companion namespace over a veth pair; %llu samples x %llu round%s per row, alternated\n",
              kTopic, kRateHz, static_cast<unsigned long long>(samples), static_cast<unsigned long long>(rounds),
              rounds == 1 ? "" : "s");
  std::printf("  %-8s %-62s %9s %9s %9s %9s %9s %10s\n", "row", "path", "p50 [us]", "p99 [us]", "max [us]",
              "p50/raw", "p99/raw", "delivered");
  const Row& raw = rows.front();
  const double raw50 = percentile(raw.latencies_us, 0.5), raw99 = percentile(raw.latencies_us, 0.99);
  for (const Row& r : rows) {
    if (!r.error.empty() || r.latencies_us.empty()) {
      std::printf("  %-8s %-62s %s%s\n", r.name.c_str(), r.what.c_str(), row_failure(r.error),
                  r.error.empty() ? "no sample delivered" : r.error.c_str());
      continue;
    }
    const double p50 = percentile(r.latencies_us, 0.5), p99 = percentile(r.latencies_us, 0.99);
    char delivered[32];
    if (r.name == "link") {
      std::snprintf(delivered, sizeof delivered, "%zu", r.latencies_us.size());
    } else {
      std::snprintf(delivered, sizeof delivered, "%zu/%llu", r.latencies_us.size(),
                    static_cast<unsigned long long>(r.sent));
    }
    std::printf("  %-8s %-62s %9.1f %9.1f %9.1f %9.2f %9.2f %10s\n", r.name.c_str(), r.what.c_str(), p50, p99,
                percentile(r.latencies_us, 1.0), raw50 > 0 ? p50 / raw50 : 0.0, raw99 > 0 ? p99 / raw99 : 0.0,
                delivered);
  }
}

// One line of the reopening's table: p50/p99/max [ms] of `ms`, and how many windows had a sample and had none.
void print_reopen_row(const char* name, const char* what, const std::vector<double>& ms, std::size_t none) {
  char windows[48];
  std::snprintf(windows, sizeof windows, "%zu (%zu none)", ms.size(), none);
  if (ms.empty()) {
    std::printf("  %-8s %-62s %9s %9s %9s  %s\n", name, what, "-", "-", "-", windows);
    return;
  }
  std::printf("  %-8s %-62s %9.1f %9.1f %9.1f  %s\n", name, what, percentile(ms, 0.5), percentile(ms, 0.99),
              percentile(ms, 1.0), windows);
}

// The reopening beside what one would expect of it: the probe's period, and one crossing (the link row's p50).
void print_reopen(const Reopen& reopen, const Row& link) {
  std::printf("\nCP -> MC (the vehicle's link opened) until the first link_probe sample on the companion: the square "
              "with SR, %llu s of flight on the link row's two hosts\n",
              static_cast<unsigned long long>(reopen.flight_s));
  std::printf("  %-8s %-62s %9s %9s %9s  %s\n", "row", "what", "p50 [ms]", "p99 [ms]", "max [ms]", "MC windows");
  if (!reopen.error.empty()) {
    std::printf("  %-8s %-62s %s%s\n", "reopen", "CP -> MC > the first sample delivered", row_failure(reopen.error),
                reopen.error.c_str());
    return;
  }
  std::vector<double> first_ms, new_ms;
  std::size_t held = 0;
  const auto to_ms = [](std::int64_t ns) { return static_cast<double>(ns) / 1e6; };
  for (std::size_t i = reopen.met + 1; i < reopen.windows.size(); ++i) {  // after the links met
    const ReopenWindow& w = reopen.windows[i];
    if (w.first_ns) first_ms.push_back(to_ms(*w.first_ns));
    if (w.first_new_ns) new_ms.push_back(to_ms(*w.first_new_ns));
    held += w.first_held ? 1 : 0;
  }
  const std::size_t measured = reopen.windows.size() - reopen.met - 1;
  print_reopen_row("reopen", "CP -> MC > the first sample delivered", first_ms, measured - first_ms.size());
  print_reopen_row("new", "CP -> MC > the first sample published after it, delivered", new_ms,
                   measured - new_ms.size());
  const double period_ms = 1000.0 / kRateHz;  // link_probe.cpp publishes at the control rate
  std::printf("  %-8s %-62s %9.1f\n", "period", "the probe's publish period", period_ms);
  if (!link.latencies_us.empty()) {
    const double crossing_ms = percentile(link.latencies_us, 0.5) / 1000.0;
    std::printf("  %-8s %-62s %9.1f\n", "link", "publish -> deliver through the links (the link row's p50)",
                crossing_ms);
    std::printf("  %-8s %-62s %9.1f\n", "sum", "one period + one crossing", period_ms + crossing_ms);
  }
  std::printf("  %zu of the first samples were published before CP -> MC (held over the closure); left out: the "
              "links met in MC window %zu of %zu, %.1f ms after its CP -> MC\n",
              held, reopen.met + 1, reopen.windows.size(), to_ms(*reopen.windows[reopen.met].first_ns));
}

// The files of --out: every sample of the latency rows, and every MC window of the reopening (empty: none).
void write_files(const fs::path& dir, const std::vector<Row>& rows, const Reopen& reopen) {
  std::ofstream csv(dir / "latency.csv");
  csv << "row,latency_us\n";
  for (const Row& row : rows) {
    for (const double us : row.latencies_us) csv << row.name << ',' << us << '\n';
  }
  std::ofstream windows(dir / "reopen.csv");
  windows << "opened_s,closed_s,first_ms,first_new_ms,first_published_before,discovery\n";
  const auto ms = [](const std::optional<std::int64_t>& ns) {
    return ns ? std::to_string(static_cast<double>(*ns) / 1e6) : std::string();
  };
  for (std::size_t i = 0; i < reopen.windows.size(); ++i) {
    const ReopenWindow& w = reopen.windows[i];
    windows << std::to_string(static_cast<double>(w.opened_ns) / 1e9) << ','
            << std::to_string(static_cast<double>(w.closed_ns) / 1e9) << ',' << ms(w.first_ns) << ','
            << ms(w.first_new_ns) << ',' << (w.first_held ? 1 : 0) << ',' << (i <= reopen.met ? 1 : 0) << '\n';
  }
}

// The link rows once each (two kernels and a 20 s alignment per flight: they are not alternated with the others).
void measure_links(Row& row, Reopen& reopen, const Namespaces& ns, const fs::path& dir, const fs::path& self,
                   std::uint64_t samples) {
  auto link = set_up_link(ns, dir, self);
  if (!link) {
    row.error = reopen.error = link.error();
    return;
  }
  measure_link(row, *link, dir, samples);
  measure_reopen(reopen, *link, dir);
}

}  // namespace

int run_bench_across_hosts(const AcrossHostsBench& bench) {
  if (::geteuid() != 0) {
    std::fprintf(stderr, "rejuv bench across-hosts: needs root: it makes two network namespaces and a veth pair "
                         "(ip netns); nothing measured\n");
    return static_cast<int>(Exit::Findings);
  }
  const fs::path peer = service_dir() / "rejuv_dds_latency_peer";
  if (!fs::exists(peer)) {
    return refuse("rejuv bench across-hosts: " + peer.string() +
                  " is not built (cmake --build … --target rejuv_dds_latency_peer; REJUV_BUILD_BENCH)");
  }
  std::error_code ec;
  const fs::path dir =
      bench.out.value_or(fs::temp_directory_path(ec) / ("rejuv-bench-across-hosts-" + std::to_string(::getpid())));
  fs::create_directories(dir, ec);
  if (ec) return refuse("rejuv bench across-hosts: --out: cannot create '" + dir.string() + "': " + ec.message());
  // The keystore as a user makes it: `rejuv keys init` and `rejuv keys hosts` on the companion graph.
  const fs::path keys = dir / "keys";
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  const std::string graph = std::string(REJUV_SOURCE_DIR) + "/tests/across_hosts/companion.launch.pbtxt";
  if (auto ok = make_keystore(self, keys, graph, std::to_string(kDomain), dir / "keys.log"); !ok) {
    std::fprintf(stderr, "rejuv bench across-hosts: %s\n", ok.error().c_str());
    return static_cast<int>(Exit::Findings);
  }
  Namespaces ns(dir);
  if (auto made = ns.make(); !made) {
    std::fprintf(stderr, "rejuv bench across-hosts: %s\n", made.error().c_str());
    return static_cast<int>(Exit::Findings);
  }
  std::fprintf(stderr, "rejuv bench across-hosts: namespaces %s and %s, %llu samples at %d Hz per row and round; "
               "files in %s\n", ns.vehicle().c_str(), ns.companion().c_str(),
               static_cast<unsigned long long>(bench.samples), kRateHz, dir.c_str());
  std::vector<Row> rows{
      Row{.name = "raw", .what = "Cyclone DDS, no security", .vehicle_enclave = "", .companion_enclave = "",
          .latencies_us = {}, .sent = 0, .error = ""},
      Row{.name = "secure", .what = "Cyclone DDS + DDS Security (rejuv keys: auth, access, encrypt)",
          .vehicle_enclave = "vehicle", .companion_enclave = "companion", .latencies_us = {}, .sent = 0, .error = ""}};
  for (std::uint64_t r = 0; r < bench.rounds; ++r) {
    for (Row& row : rows) {
      if (row.error.empty()) measure(row, ns, peer, dir, keys, bench.samples, static_cast<int>(r));
    }
  }
  rows.push_back(Row{.name = "link", .what = "service > kernel > link > DDS (secure) > link > kernel > service",
                     .vehicle_enclave = "vehicle", .companion_enclave = "companion", .latencies_us = {}, .sent = 0,
                     .error = ""});
  Reopen reopen{.flight_s = bench.reopen_seconds, .windows = {}, .met = 0, .error = ""};
  if (bench.link == LinkRow::Measure) measure_links(rows.back(), reopen, ns, dir, self, bench.samples);
  else rows.back().error = reopen.error = "not measured (--no-link)";
  write_files(dir, rows, reopen);
  print_table(rows, bench.samples, bench.rounds);
  print_reopen(reopen, rows.back());
  const bool failed = is_failure(reopen.error) ||
                      std::any_of(rows.begin(), rows.end(), [](const Row& r) { return is_failure(r.error); });
  return static_cast<int>(failed ? Exit::Findings : Exit::Ok);
}

}  // namespace rejuv::cli
