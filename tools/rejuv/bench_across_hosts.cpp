// `rejuv bench across-hosts [--samples N] [--rounds N] [--out DIR]` (docs/performance.md "Across hosts"): the
// baseline of a graph across hosts (docs/across_hosts.md). Two network namespaces joined by a veth pair stand for
// the vehicle and the companion of tests/across_hosts/companion.launch.pbtxt; in each, one Cyclone DDS
// participant (bench/across_hosts/latency_peer.cpp, `ip netns exec`). The vehicle publishes a vehicle_state-sized
// sample (rejuv::msg::VehicleStateEstimate, 216 B) at 250 Hz on the cross-host topic `rejuv/state`; the companion
// takes it and records the publish → deliver latency (CLOCK_MONOTONIC is one clock for all namespaces).
// Rows, side by side in one run and alternated round by round (a shared machine's slow spells fall on all alike):
//   raw         Cyclone DDS without security (the Cyclone XML shape of tests/across_hosts);
//   secure      the same with DDS Security, the enclaves of a keystore made by `rejuv keys init` and
//               `rejuv keys hosts --launch companion.launch.pbtxt` (authenticated, access-controlled, encrypted);
//   link        service → kernel → link → DDS (secure) → link → kernel → service: the square (launch/quad_square,
//               no SR) on the vehicle with the probe of bench/across_hosts/link_probe.cpp on both hosts, each
//               host under its own `rejuv run --host` kernel with its link process (rejuv_host_link) in its
//               namespace; the probe's topic `link_probe` crosses like any cross-host topic (keystore of
//               `rejuv keys hosts` on that graph). Its first second of samples is left out (discovery).
// Each row as p50/p99/max and as a ratio to the raw row. Root only (network namespaces): without root it says so
// and measures nothing. The namespaces (rjP_v<pid>, rjP_c<pid>) and the veth pair are removed on every exit path.
// Nothing here is asserted: the table says what this machine did.
#include <fcntl.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
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
      : dir_(std::move(dir)), vehicle_("rjP_v" + std::to_string(::getpid())), companion_("rjP_c" + std::to_string(::getpid())) {}
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
  Result<void, std::string> make() {
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

// The link's row: both hosts' kernels flown once (`rejuv run --host`), the companion's probe's latencies read
// from its kernel's log. Samples of its first second (kRateHz) are left out: they waited for discovery.
void measure_link(Row& row, const Namespaces& ns, const fs::path& dir, const fs::path& self, std::uint64_t samples) {
  auto lease = sys::lease_dds_domain_for_worker(1);  // the kernels and the plant talk on the machine's loopback
  if (!lease) { row.error = "no free DDS domain: " + lease.error().to_string(); return; }
  const std::string domain = std::to_string(lease->slot());
  const fs::path graph = dir / "link_probe.launch.pbtxt";
  std::ofstream(graph) << "include: \"" REJUV_SOURCE_DIR "/launch/quad_square.launch.pbtxt\"\n"
                       << "policy_include: \"" REJUV_SOURCE_DIR "/bench/across_hosts/link_probe.policy.pbtxt\"\n"
                       << "hosts { name: \"vehicle\" address: \"" << kVehicleAddress << "\" netns: \"" << ns.vehicle() << "\" }\n"
                       << "hosts { name: \"companion\" address: \"" << kCompanionAddress << "\" netns: \"" << ns.companion() << "\" }\n"
                       << "services { name: \"probe_pub\" executable: \"rejuv_link_probe_pub\" host: \"vehicle\"\n"
                       << "  uses { object: \"link_probe\" rights: \"W\" } }\n"
                       << "services { name: \"probe_sub\" executable: \"rejuv_link_probe_sub\" host: \"companion\"\n"
                       << "  uses { object: \"link_probe\" rights: \"R\" } }\n";
  const fs::path keys = dir / "link_keys";
  if (auto ok = make_keystore(self, keys, graph, domain, dir / "link_keys.log"); !ok) {
    row.error = ok.error();
    return;
  }
  // The vehicle aligns (20 s) before its flight; the companion, without a plant, outlasts it.
  const std::uint64_t flight_s = std::max<std::uint64_t>(5, samples / kRateHz);
  const auto host_run = [&](const std::string& host, std::uint64_t seconds) {
    return start_rejuv_run({graph.string(), "--host", host, "--keys", keys.string(), "--domain", domain, "--duration",
                            std::to_string(seconds), "--no-sr", "--no-attack", "--net-port", "0"},
                           dir / ("link_" + host + ".log"));
  };
  auto companion = host_run("companion", flight_s + 35);
  if (!companion) { row.error = companion.error(); return; }
  auto vehicle = host_run("vehicle", flight_s);
  if (!vehicle) { row.error = vehicle.error(); return; }
  auto v = vehicle->wait();
  auto c = companion->wait();
  if (!v || !v->success() || !c || !c->success()) {
    row.error = "the hosts' runs (" + (dir / "link_vehicle.log").string() + ", link_companion.log) did not end cleanly";
    return;
  }
  std::istringstream log(slurp(dir / "link_companion.log"));
  const std::string tag = "link probe latencies [ns]:";
  std::uint64_t seen = 0;
  for (std::string line; std::getline(log, line);) {
    const auto at = line.find(tag);
    if (at == std::string::npos) continue;
    std::istringstream values(line.substr(at + tag.size()));
    for (long long ns_value = 0; values >> ns_value;) {
      if (++seen > static_cast<std::uint64_t>(kRateHz)) row.latencies_us.push_back(static_cast<double>(ns_value) / 1000.0);
    }
  }
  row.sent = seen > static_cast<std::uint64_t>(kRateHz) ? seen - kRateHz : 0;  // received; what was sent is not counted
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

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
      std::printf("  %-8s %-62s %s\n", r.name.c_str(), r.what.c_str(),
                  r.error.empty()                           ? "no sample delivered"
                  : r.error.rfind("not measured", 0) == 0 ? r.error.c_str()
                                                            : ("failed: " + r.error).c_str());
      continue;
    }
    const double p50 = percentile(r.latencies_us, 0.5), p99 = percentile(r.latencies_us, 0.99);
    char delivered[32];
    if (r.name == "link") std::snprintf(delivered, sizeof delivered, "%zu", r.latencies_us.size());
    else std::snprintf(delivered, sizeof delivered, "%zu/%llu", r.latencies_us.size(), static_cast<unsigned long long>(r.sent));
    std::printf("  %-8s %-62s %9.1f %9.1f %9.1f %9.2f %9.2f %10s\n", r.name.c_str(), r.what.c_str(), p50, p99,
                percentile(r.latencies_us, 1.0), raw50 > 0 ? p50 / raw50 : 0.0, raw99 > 0 ? p99 / raw99 : 0.0, delivered);
  }
}

}  // namespace

int run_bench_across_hosts(std::uint64_t samples, std::uint64_t rounds, const std::optional<fs::path>& out_dir,
                           LinkRow link) {
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
      out_dir.value_or(fs::temp_directory_path(ec) / ("rejuv-bench-across-hosts-" + std::to_string(::getpid())));
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
               "files in %s\n", ns.vehicle().c_str(), ns.companion().c_str(), static_cast<unsigned long long>(samples),
               kRateHz, dir.c_str());
  std::vector<Row> rows{
      Row{.name = "raw", .what = "Cyclone DDS, no security", .vehicle_enclave = "", .companion_enclave = "",
          .latencies_us = {}, .sent = 0, .error = ""},
      Row{.name = "secure", .what = "Cyclone DDS + DDS Security (rejuv keys: auth, access, encrypt)",
          .vehicle_enclave = "vehicle", .companion_enclave = "companion", .latencies_us = {}, .sent = 0, .error = ""}};
  for (std::uint64_t r = 0; r < rounds; ++r) {
    for (Row& row : rows) {
      if (row.error.empty()) measure(row, ns, peer, dir, keys, samples, static_cast<int>(r));
    }
  }
  // The link's row once (two kernels and a 20 s alignment: it is not alternated with the others).
  rows.push_back(Row{.name = "link", .what = "service > kernel > link > DDS (secure) > link > kernel > service",
                     .vehicle_enclave = "vehicle", .companion_enclave = "companion", .latencies_us = {}, .sent = 0,
                     .error = ""});
  if (link == LinkRow::Measure) measure_link(rows.back(), ns, dir, self, samples);
  else rows.back().error = "not measured (--no-link)";
  std::ofstream csv(dir / "latency.csv");
  csv << "row,latency_us\n";
  for (const Row& row : rows) {
    for (const double us : row.latencies_us) csv << row.name << ',' << us << '\n';
  }
  print_table(rows, samples, rounds);
  const bool failed = std::any_of(rows.begin(), rows.end(), [](const Row& r) { return !r.error.empty(); });
  return static_cast<int>(failed ? Exit::Findings : Exit::Ok);
}

}  // namespace rejuv::cli
