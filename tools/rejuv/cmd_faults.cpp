// `rejuv faults GRAPH`: the fault campaign (DESIGN §11; fault_campaign.hpp). Plans the faults from the seed,
// runs the missions in --jobs processes (each its own DDS domain, --net-port 0, its own CPU), gathers the
// outcomes, prints the table by fault kind and phase and writes it with every injection as JSON.
// Exit 0 when every injection was recovered by a designed path with nothing unsafe, leaked or hung; 1 when
// not; 2 on bad input.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "args.hpp"
#include "common_options.hpp"
#include "rejuv/sys/lease.hpp"
#include "rejuv/sys/process.hpp"
#include "commands.hpp"
#include "fault_campaign.hpp"
#include "report.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::cli {
namespace {

namespace fs = std::filesystem;
using faults::Outcome;

std::string json_escape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += ' ';
    } else {
      out += c;
    }
  }
  return out;
}

struct Row {
  std::uint64_t injections = 0, recovered = 0, unsafe = 0, leaked = 0, hung = 0;
  std::map<std::string, std::uint64_t> paths;
};

}  // namespace

// Where the faults go: over the first 95 % of the flight, as long as the model (`rejuv sim`, a fraction of a second)
// flies this graph with its SR scheme and attacks (the paper's square: 230 of 243 s; launch/quad_square: 56 of
// 59 s), so that every fault lands in flight whatever the graph. The runtime flies a little longer than the model
// (docs/control.md), never shorter by much.
Result<Nanos, std::string> fault_window(const launch::LoadedLaunch& graph) {
  auto config = flight::config_from_launch(graph, flight::SimOverrides{});
  if (!config) return fail("the model cannot fly it: " + config.error().to_string());
  auto summary = flight::run_simulation(*config);
  if (!summary) return fail("the model cannot fly it: " + summary.error().to_string());
  if (!summary->mission_completed()) {
    return fail("the model does not complete its mission (" + std::to_string(summary->sim_time_s()) +
                " s flown): nothing to spread the faults over");
  }
  return std::chrono::round<Nanos>(Seconds(0.95 * summary->mission_time_s()));
}

int run_faults(std::span<const std::string_view> args) {
  std::string graph_path;
  std::uint64_t injections = 200, seed = 1, jobs = 1, per = 6, bound = 300;
  std::optional<std::uint64_t> domain, only;
  std::filesystem::path out_dir = "out/faults";
  Charge charge = Charge::Measured;
  Options opts("faults",
               "Fault campaign (DESIGN §7 \"Faults\", §11): flies GRAPH several times and injects, at moments and\n"
               "phases drawn from the seed, SIGKILL/SIGSTOP of a live service, of one image, of every image of a\n"
               "service, of a whole service group, a 1 s stall of the plant, and kills of output_driver and the\n"
               "plant, in MC, in the secure interval and exactly inside checkpoints and rollbacks. After each it\n"
               "records the recovery path, safety (max V < 1, mission completed), leaks and hangs; prints the\n"
               "table by kind and phase and writes it as JSON (DIR/faults.json; kernel logs in DIR/job-N.log).\n"
               "Exit 0 when nothing is unsafe, leaked, hung or unrecovered (a cold restart after the loss of one\n"
               "image counts as unrecovered: with two or more generations kept an intact one was left).");
  opts.positional("GRAPH", graph_path, "the launch graph (*.launch.pbtxt)")
      .integer("--injections", "N", injections, {1, 100000}, "faults to plan")
      .integer("--seed", "S", seed, {}, "seed of the plan")
      .integer("--jobs", "J", jobs, {1, 16}, "missions in J processes side by side")
      .integer("--per-mission", "K", per, {1, 50}, "faults per mission at most");
  domain_option(opts, domain, "DDS domain of job 0; job j uses N + j",
                "each job leases a free domain, as the tests do")
      .integer("--mission-timeout", "S", bound, {10}, "wall-clock bound of one mission [s]: the watchdog")
      .path("--out", "DIR", out_dir, "where faults.json and the logs go");
  charge_option(opts, charge, "\n('measured' here: a fault's recovery costs the flight its real time)")
      .integer("--mission", "M", only, {},
               "fly only mission M of the plan (the same seed, --injections and --per-mission): to reproduce one");
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (domain && *domain + jobs - 1 > launch::defaults::kMaxDdsDomainId) {
    return bad_input("rejuv faults: --domain " + std::to_string(*domain) + " + --jobs " + std::to_string(jobs) +
                     " - 1 is above the highest DDS domain " + std::to_string(launch::defaults::kMaxDdsDomainId));
  }
  // Without --domain each job holds a leased domain (sys/lease.hpp) for the campaign: two campaigns, a
  // campaign and the tests, or two checkouts' test suites on one machine never share a DDS domain.
  std::vector<sys::DdsDomainLease> leases;
  if (!domain) {
    for (std::uint64_t j = 0; j < jobs; ++j) {
      auto lease = sys::lease_dds_domain(static_cast<std::uint32_t>(::getpid() + j));
      if (!lease) return bad_input("rejuv faults: no free DDS domain (" + lease.error().to_string() + "): give --domain");
      leases.push_back(std::move(*lease));
    }
  }

  auto graph = launch::load_launch(graph_path);
  if (!graph) return bad_input(graph.error().to_string());
  std::vector<std::string> rejuvenated;
  for (const proto::ServiceSpec& s : graph->graph.services()) {
    if (!s.has_rejuvenate() || s.rejuvenate()) rejuvenated.push_back(s.name());
  }
  if (rejuvenated.empty() || !graph->graph.sr().enabled()) {
    return bad_input("rejuv faults: " + graph_path + ": the graph has no rejuvenated service or SR is off");
  }
  const auto window = fault_window(*graph);
  if (!window) return bad_input("rejuv faults: " + graph_path + ": " + window.error());
  std::vector<faults::Mission> missions =
      faults::plan(seed, static_cast<std::uint32_t>(injections), static_cast<std::uint32_t>(per), rejuvenated, *window);
  if (only) {
    std::erase_if(missions, [&](const faults::Mission& m) { return m.index != *only; });
    if (missions.empty()) return bad_input("rejuv faults: --mission: the plan has no mission " + std::to_string(*only));
  }
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return bad_input("rejuv faults: --out: cannot create '" + out_dir.string() + "': " + ec.message());
  std::fprintf(stderr, "rejuv faults: %llu faults in %zu missions, %llu job%s, seed %llu\n",
               static_cast<unsigned long long>(injections), missions.size(), static_cast<unsigned long long>(jobs),
               jobs == 1 ? "" : "s", static_cast<unsigned long long>(seed));

  // One process per job, forked while this one is still single-threaded.
  const long cpus = std::max(1L, ::sysconf(_SC_NPROCESSORS_ONLN));
  std::vector<pid_t> pids;
  std::fflush(nullptr);
  const pid_t campaign = ::getpid();
  for (std::uint64_t j = 0; j < jobs; ++j) {
    const pid_t pid = ::fork();
    if (pid < 0) return bad_input("rejuv faults: fork failed");
    if (pid == 0) {
      // A job never outlives the campaign (Ctrl-C, a kill): SIGTERM stops its kernel, which shuts its mission down.
      if (!sys::die_with_parent(campaign, SIGTERM)) ::_exit(1);
      std::vector<faults::Mission> mine;
      for (std::size_t m = j; m < missions.size(); m += jobs) mine.push_back(missions[m]);
      const faults::JobConfig config{.graph = graph_path,
                                     .dds_domain = domain ? static_cast<std::uint32_t>(*domain + j) : leases[j].slot(),
                                     .cpu = static_cast<int>(j % static_cast<std::uint64_t>(cpus)),
                                     .mission_wall_bound = std::chrono::seconds{bound},
                                     .log = out_dir / ("job-" + std::to_string(j) + ".log"),
                                     .charge = charge};
      const std::vector<Outcome> outcomes = faults::run_job(config, mine);
      std::ofstream f(out_dir / ("job-" + std::to_string(j) + ".tsv"));
      for (const Outcome& o : outcomes) f << faults::encode(o);
      f.close();
      std::fflush(nullptr);
      ::_exit(0);
    }
    pids.push_back(pid);
  }
  std::vector<Outcome> all;
  bool job_failed = false;
  for (std::size_t j = 0; j < pids.size(); ++j) {
    int status = 0;
    while (::waitpid(pids[j], &status, 0) < 0 && errno == EINTR) {
    }
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      job_failed = true;
      std::fprintf(stderr, "rejuv faults: job %zu ended abnormally (status %d): its missions count as hung\n", j, status);
    }
    std::ifstream f(out_dir / ("job-" + std::to_string(j) + ".tsv"));
    std::string line;
    while (std::getline(f, line)) {
      Outcome o;
      if (faults::decode(line, o)) all.push_back(std::move(o));
    }
  }
  // A job that died takes its missions' outcomes with it: they are hung.
  std::size_t missing = 0;
  for (const faults::Mission& m : missions) {
    for (const faults::Planned& p : m.faults) {
      const bool found = std::any_of(all.begin(), all.end(), [&](const Outcome& o) {
        return o.mission == m.index && o.fault.kind == p.kind && o.fault.where == p.where && o.fault.at == p.at;
      });
      if (!found) {
        all.push_back(Outcome{.mission = m.index, .fault = p, .fired = true, .hung = true, .note = "its job died"});
        ++missing;
      }
    }
  }

  std::map<std::pair<std::string, std::string>, Row> table;
  Row total;
  std::uint64_t not_fired = 0;
  for (const Outcome& o : all) {
    if (!o.fired) {
      ++not_fired;
      continue;
    }
    for (Row* r : {&table[{std::string(faults::to_string(o.fault.kind)), std::string(faults::to_string(o.fault.where))}],
                   &total}) {
      ++r->injections;
      r->recovered += o.recovered ? 1 : 0;
      r->unsafe += o.unsafe ? 1 : 0;
      r->leaked += o.leaked ? 1 : 0;
      r->hung += o.hung ? 1 : 0;
      std::string path = o.path.rfind("clean stop", 0) == 0 ? "clean stop" : o.path;
      ++r->paths[path.empty() ? "?" : path];
    }
  }
  const auto paths_text = [](const Row& r) {
    std::string s;
    for (const auto& [p, n] : r.paths) s += (s.empty() ? "" : ", ") + p + " " + std::to_string(n);
    return s;
  };
  std::printf("%-20s %-20s %5s %5s %5s %5s %5s  %s\n", "fault", "phase", "inj", "recov", "unsafe", "leak", "hung",
              "recovery paths");
  for (const auto& [key, r] : table) {
    std::printf("%-20s %-20s %5llu %5llu %5llu %5llu %5llu  %s\n", key.first.c_str(), key.second.c_str(),
                static_cast<unsigned long long>(r.injections), static_cast<unsigned long long>(r.recovered),
                static_cast<unsigned long long>(r.unsafe), static_cast<unsigned long long>(r.leaked),
                static_cast<unsigned long long>(r.hung), paths_text(r).c_str());
  }
  std::printf("%-20s %-20s %5llu %5llu %5llu %5llu %5llu  %s\n", "total", "", static_cast<unsigned long long>(total.injections),
              static_cast<unsigned long long>(total.recovered), static_cast<unsigned long long>(total.unsafe),
              static_cast<unsigned long long>(total.leaked), static_cast<unsigned long long>(total.hung),
              paths_text(total).c_str());
  if (not_fired > 0) std::printf("(%llu planned faults found no phase or target in their window: not injected)\n",
                                 static_cast<unsigned long long>(not_fired));
  for (const Outcome& o : all) {
    if (o.fired && (!o.recovered || o.unsafe || o.leaked || o.hung)) {
      std::printf("  exception: mission %u, %s at %s on %s at %.1f s: %s%s%s%s — %s; %s\n", o.mission,
                  std::string(faults::to_string(o.fault.kind)).c_str(), std::string(faults::to_string(o.fault.where)).c_str(),
                  o.fault.target.c_str(), o.fired_at_s, o.recovered ? "" : "NOT RECOVERED ", o.unsafe ? "UNSAFE " : "",
                  o.leaked ? "LEAKED " : "", o.hung ? "HUNG" : "", o.path.c_str(), o.note.c_str());
    }
  }

  std::ofstream json(out_dir / "faults.json");
  json << "{\n  \"graph\": \"" << json_escape(graph_path) << "\", \"seed\": " << seed << ", \"planned\": " << injections
       << ", \"injected\": " << total.injections << ", \"not_injected\": " << not_fired
       << ", \"recovered\": " << total.recovered << ", \"unsafe\": " << total.unsafe << ", \"leaked\": " << total.leaked
       << ", \"hung\": " << total.hung << ",\n  \"table\": [\n";
  bool first = true;
  for (const auto& [key, r] : table) {
    json << (first ? "" : ",\n") << "    {\"fault\": \"" << key.first << "\", \"phase\": \"" << key.second
         << "\", \"injections\": " << r.injections << ", \"recovered\": " << r.recovered << ", \"unsafe\": " << r.unsafe
         << ", \"leaked\": " << r.leaked << ", \"hung\": " << r.hung << ", \"paths\": {";
    bool fp = true;
    for (const auto& [p, n] : r.paths) {
      json << (fp ? "" : ", ") << "\"" << json_escape(p) << "\": " << n;
      fp = false;
    }
    json << "}}";
    first = false;
  }
  json << "\n  ],\n  \"injections\": [\n";
  first = true;
  for (const Outcome& o : all) {
    json << (first ? "" : ",\n") << "    {\"mission\": " << o.mission << ", \"fault\": \"" << faults::to_string(o.fault.kind)
         << "\", \"phase\": \"" << faults::to_string(o.fault.where) << "\", \"target\": \"" << json_escape(o.fault.target)
         << "\", \"armed_at_s\": " << to_seconds(o.fault.at).count() << ", \"injected\": " << (o.fired ? "true" : "false")
         << ", \"at_s\": " << o.fired_at_s << ", \"path\": \"" << json_escape(o.path)
         << "\", \"recovered\": " << (o.recovered ? "true" : "false") << ", \"unsafe\": " << (o.unsafe ? "true" : "false")
         << ", \"leaked\": " << (o.leaked ? "true" : "false") << ", \"hung\": " << (o.hung ? "true" : "false")
         << ", \"note\": \"" << json_escape(o.note) << "\"}";
    first = false;
  }
  json << "\n  ]\n}\n";
  json.close();
  std::printf("wrote %s\n", (out_dir / "faults.json").c_str());
  const bool good = !job_failed && missing == 0 && total.recovered == total.injections && total.unsafe == 0 &&
                    total.leaked == 0 && total.hung == 0;
  return static_cast<int>(good ? Exit::Ok : Exit::Findings);
}

}  // namespace rejuv::cli
