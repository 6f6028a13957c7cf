// `rejuv faults GRAPH`: the fault campaign (docs/design.md §11; fault_campaign.hpp). Plans the faults from the seed,
// runs the missions in --jobs processes (each its own DDS domain, --net-port 0, its own CPU), gathers the
// outcomes, prints the table by fault kind and phase and writes it with every injection as JSON.
// Exit 0 when every injection was recovered by a designed path with nothing unsafe, leaked or hung; 1 when
// not; 2 on bad input.
#include <signal.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "args.hpp"
#include "background_load.hpp"
#include "common_options.hpp"
#include "rejuv/sys/event.hpp"
#include "commands.hpp"
#include "fault_campaign.hpp"
#include "job_pool.hpp"
#include "faults.pb.h"
#include "report.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::cli {
namespace {

namespace fs = std::filesystem;
using faults::Outcome;

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

namespace {

// What `rejuv faults` was asked for.
struct CampaignRequest {
  std::string graph_path;
  std::uint64_t injections = 200, seed = 1, jobs = 1, per = 6, bound = 300;
  std::optional<std::uint64_t> domain, only;
  std::filesystem::path out_dir = "out/faults";
  Charge charge = Charge::Measured;
  bool realtime = false;
  std::optional<LoadSpec> load;
};

void declare_campaign_options(Options& opts, CampaignRequest& r) {
  opts.positional("GRAPH", r.graph_path, "the launch graph (*.launch.pbtxt)")
      .integer("--injections", "N", r.injections, {1, 100000}, "faults to plan")
      .integer("--seed", "S", r.seed, {}, "seed of the plan")
      .integer("--jobs", "J", r.jobs, {1, 16}, "missions in J processes side by side")
      .integer("--per-mission", "K", r.per, {1, 50}, "faults per mission at most");
  domain_option(opts, r.domain, "DDS domain of job 0; job j uses N + j",
                "each job leases a free domain, as the tests do")
      .integer("--mission-timeout", "S", r.bound, {10}, "wall-clock bound of one mission [s]: the watchdog")
      .path("--out", "DIR", r.out_dir, "where faults.json and the logs go");
  charge_option(opts, r.charge, "\n('measured' here: a fault's recovery costs the flight its real time)")
      .integer("--mission", "M", r.only, {},
               "fly only mission M of the plan (the same seed, --injections and --per-mission): to reproduce one")
      .flag("--realtime", r.realtime,
            "fly the missions in real time (the wall clock) with the graph's real-time plan (its `realtime`\n"
            "section: SCHED_FIFO, pinning; docs/realtime.md), as `rejuv run --realtime`: a recovery costs the\n"
            "vehicle what it lasts on this machine; --jobs 1 is meant (each job is a real-time graph)")
      .custom<LoadSpec>("--load", "cpu:N", r.load, parse_load,
                        "beside the campaign, N processes of a companion-like load (each keeps 64 MiB of memory\n"
                        "busy, never sleeping, at SCHED_OTHER), started before the first mission and stopped after\n"
                        "the last (on every exit, Ctrl-C too)",
                        "none");
}

// The missions of the plan (all, or --mission's), their faults spread over the model's flight of the graph.
Result<std::vector<faults::Mission>, std::string> plan_campaign(const CampaignRequest& r) {
  auto graph = launch::load_launch(r.graph_path);
  if (!graph) return fail(graph.error().to_string());
  std::vector<std::string> rejuvenated;
  for (const proto::ServiceSpec& s : graph->graph.services()) {
    if (!s.has_rejuvenate() || s.rejuvenate()) rejuvenated.push_back(s.name());
  }
  if (rejuvenated.empty() || !graph->graph.sr().enabled()) {
    return fail(r.graph_path + ": the graph has no rejuvenated service or SR is off");
  }
  const auto window = fault_window(*graph);
  if (!window) return fail(r.graph_path + ": " + window.error());
  std::vector<faults::Mission> missions = faults::plan(r.seed, static_cast<std::uint32_t>(r.injections),
                                                       static_cast<std::uint32_t>(r.per), rejuvenated, *window, r.realtime);
  if (r.only) {
    std::erase_if(missions, [&](const faults::Mission& m) { return m.index != *r.only; });
    if (missions.empty()) return fail("--mission: the plan has no mission " + std::to_string(*r.only));
  }
  return missions;
}

// What the jobs reported: every outcome, and whether a job ended abnormally.
struct JobsDone {
  std::vector<Outcome> outcomes;
  bool job_failed = false;
  std::size_t missing = 0;  // planned faults no job reported (its job died): counted as hung
};

// Job j's process: flies every jobs-th mission from the j-th in its slot (DDS domain, CPU) and writes its
// outcomes to DIR/job-j.tsv.
int fly_job(const CampaignRequest& r, const std::vector<faults::Mission>& missions, std::size_t j,
            const WorkerSlot& slot) {
  std::vector<faults::Mission> mine;
  for (std::size_t m = j; m < missions.size(); m += r.jobs) mine.push_back(missions[m]);
  const faults::JobConfig config{.graph = r.graph_path,
                                 .dds_domain = slot.dds_domain,
                                 .cpu = slot.cpu,
                                 .mission_wall_bound = std::chrono::seconds{r.bound},
                                 .log = r.out_dir / ("job-" + std::to_string(j) + ".log"),
                                 .charge = r.charge,
                                 .realtime = r.realtime};
  const std::vector<Outcome> outcomes = faults::run_job(config, mine);
  std::ofstream f(r.out_dir / ("job-" + std::to_string(j) + ".tsv"));
  for (const Outcome& o : outcomes) f << faults::encode(o);
  return f.good() ? 0 : 1;
}

// Every planned fault no job reported (its job died) as a hung outcome.
void count_missing(const std::vector<faults::Mission>& missions, JobsDone& done) {
  for (const faults::Mission& m : missions) {
    for (const faults::Planned& p : m.faults) {
      const bool found = std::any_of(done.outcomes.begin(), done.outcomes.end(), [&](const Outcome& o) {
        return o.mission == m.index && o.fault.kind == p.kind && o.fault.where == p.where && o.fault.at == p.at;
      });
      if (!found) {
        done.outcomes.push_back(Outcome{.mission = m.index, .fault = p, .fired = true, .hung = true, .note = "its job died"});
        ++done.missing;
      }
    }
  }
}

// One worker per job in the pool (all at once, forked while this process is still single-threaded); the
// outcomes read back from the jobs' DIR/job-N.tsv. An error when the campaign was interrupted.
Result<JobsDone, std::string> run_jobs(const CampaignRequest& r, const std::vector<faults::Mission>& missions,
                                       JobPool& pool) {
  JobsDone done;
  const auto ended = [&](const TaskEnd& end) -> Result<void, std::string> {
    if (!end.status.success()) {
      done.job_failed = true;
      std::fprintf(stderr, "rejuv faults: job %zu ended abnormally (%s): its missions count as hung\n", end.task,
                   end.status.to_string().c_str());
    }
    return {};
  };
  const auto job = [&](std::size_t j, const WorkerSlot& slot) { return fly_job(r, missions, j, slot); };
  const auto outcome = pool.run(r.jobs, forked(job), PoolHooks{.ended = ended});
  if (!outcome) return fail(outcome.error());
  if (*outcome == PoolOutcome::Interrupted) {
    return fail("interrupted: no table (the kernels' logs are in " + r.out_dir.string() + "/job-N.log)");
  }
  for (std::uint64_t j = 0; j < r.jobs; ++j) {
    std::ifstream f(r.out_dir / ("job-" + std::to_string(j) + ".tsv"));
    for (std::string line; std::getline(f, line);) {
      Outcome o;
      if (faults::decode(line, o)) done.outcomes.push_back(std::move(o));
    }
  }
  count_missing(missions, done);  // a job that died takes its missions' outcomes with it: they are hung
  return done;
}

void count(proto::FaultRow& row, const Outcome& o) {
  row.set_injections(row.injections() + 1);
  row.set_recovered(row.recovered() + (o.recovered ? 1 : 0));
  row.set_unsafe(row.unsafe() + (o.unsafe ? 1 : 0));
  row.set_leaked(row.leaked() + (o.leaked ? 1 : 0));
  row.set_hung(row.hung() + (o.hung ? 1 : 0));
  row.set_not_judged(row.not_judged() + (o.not_judged.empty() ? 0 : 1));
  const std::string path = o.path.rfind("clean stop", 0) == 0 ? "clean stop" : o.path;
  ++(*row.mutable_paths())[path.empty() ? "?" : path];
}

// The campaign's result: the table by fault kind and phase, the totals and every injection.
proto::FaultCampaign tally(const CampaignRequest& r, const std::vector<Outcome>& outcomes) {
  proto::FaultCampaign c;
  c.set_graph(r.graph_path);
  c.set_seed(r.seed);
  c.set_planned(static_cast<std::uint32_t>(r.injections));
  c.set_realtime(r.realtime);
  if (r.load) c.set_load(r.load->to_string());
  std::map<std::pair<std::string, std::string>, proto::FaultRow> table;
  proto::FaultRow& total = *c.mutable_total();
  for (const Outcome& o : outcomes) {
    proto::FaultInjection& i = *c.add_injections();
    i.set_mission(o.mission);
    i.set_fault(std::string(faults::to_string(o.fault.kind)));
    i.set_phase(std::string(faults::to_string(o.fault.where)));
    i.set_target(o.fault.target);
    i.set_armed_at_s(to_seconds(o.fault.at).count());
    i.set_injected(o.fired);
    i.set_at_s(o.fired_at_s);
    i.set_path(o.path);
    i.set_recovered(o.recovered);
    i.set_unsafe(o.unsafe);
    i.set_leaked(o.leaked);
    i.set_hung(o.hung);
    i.set_note(o.note);
    i.set_recovery_ms(o.recovery_ms);
    i.set_not_judged(o.not_judged);
    if (!o.fired) {
      c.set_not_injected(c.not_injected() + 1);
      continue;
    }
    proto::FaultRow& row = table[{i.fault(), i.phase()}];
    row.set_fault(i.fault());
    row.set_phase(i.phase());
    count(row, o);
    count(total, o);
  }
  for (auto& [key, row] : table) *c.add_table() = std::move(row);
  return c;
}

std::string paths_text(const google::protobuf::Map<std::string, std::uint32_t>& paths) {
  std::map<std::string, std::uint32_t> sorted(paths.begin(), paths.end());
  std::string s;
  for (const auto& [p, n] : sorted) s += (s.empty() ? "" : ", ") + p + " " + std::to_string(n);
  return s;
}

// The real durations of the recoveries of a row's injections (all of them for the total): "p50/max ms", or "-".
std::string recovery_text(const proto::FaultCampaign& c, const proto::FaultRow* row) {
  std::vector<double> ms;
  for (const proto::FaultInjection& o : c.injections()) {
    if (!o.injected() || o.recovery_ms() < 0) continue;
    if (row != nullptr && (o.fault() != row->fault() || o.phase() != row->phase())) continue;
    ms.push_back(o.recovery_ms());
  }
  if (ms.empty()) return "-";
  std::sort(ms.begin(), ms.end());
  char text[48];
  std::snprintf(text, sizeof text, "%.1f/%.1f", ms[(ms.size() - 1) / 2], ms.back());
  return text;
}

// One row of the table: `label` for the total, the row's own fault and phase otherwise.
void print_row(const proto::FaultCampaign& c, const proto::FaultRow& r, const char* label = nullptr) {
  std::printf("%-20s %-20s %5u %5u %5u %5u %5u %5u %13s  %s\n", label != nullptr ? label : r.fault().c_str(),
              label != nullptr ? "" : r.phase().c_str(), r.injections(), r.recovered(), r.not_judged(), r.unsafe(),
              r.leaked(), r.hung(), recovery_text(c, label != nullptr ? nullptr : &r).c_str(), paths_text(r.paths()).c_str());
}

// The table by kind and phase, the total, and each injection that was not survived.
void print_campaign(const proto::FaultCampaign& c) {
  if (c.realtime()) {
    std::printf("flown in real time with the graph's real-time plan%s%s\n", c.load().empty() ? "" : ", beside --load ",
                c.load().c_str());
  }
  std::printf("%-20s %-20s %5s %5s %5s %5s %5s %5s %13s  %s\n", "fault", "phase", "inj", "recov", "unjdg", "unsafe",
              "leak", "hung", "recovery ms", "recovery paths");
  for (const proto::FaultRow& r : c.table()) print_row(c, r);
  print_row(c, c.total(), "total");
  std::printf("(recovery ms: p50/max of the real time from an injection to the first controls routed after the\n"
              " rollback or cold restart that followed it, where one did)\n");
  if (c.not_injected() > 0) {
    std::printf("(%u planned faults found no phase or target in their window: not injected)\n", c.not_injected());
  }
  for (const proto::FaultInjection& o : c.injections()) {
    if (o.injected() && (!o.recovered() || o.unsafe() || o.leaked() || o.hung())) {
      const std::string verdict = o.recovered()             ? ""
                                  : o.not_judged().empty() ? "NOT RECOVERED "
                                                           : "NOT JUDGED (" + o.not_judged() + ") ";
      std::printf("  exception: mission %u, %s at %s on %s at %.1f s: %s%s%s%s — %s (recovery %.1f ms); %s\n",
                  o.mission(), o.fault().c_str(), o.phase().c_str(), o.target().c_str(), o.at_s(),
                  verdict.c_str(), o.unsafe() ? "UNSAFE " : "", o.leaked() ? "LEAKED " : "",
                  o.hung() ? "HUNG" : "", o.path().c_str(), o.recovery_ms(), o.note().c_str());
    }
  }
}

}  // namespace

int run_faults(std::span<const std::string_view> args) {
  CampaignRequest r;
  Options opts("faults",
               "Fault campaign (docs/design.md §7 \"Faults\", §11): flies GRAPH several times and injects, at moments and\n"
               "phases drawn from the seed, SIGKILL/SIGSTOP of a live service, of one image, of every image of a\n"
               "service, of a whole service group, a 1 s stall of the plant, and kills of output_driver and the\n"
               "plant, in MC, in the secure interval and exactly inside checkpoints and rollbacks. After each it\n"
               "records the recovery path, safety (max V < 1, mission completed), leaks and hangs; prints the\n"
               "table by kind and phase and writes it as JSON (DIR/faults.json; kernel logs in DIR/job-N.log).\n"
               "A fault is judged once its target is seen back (an incarnation the fault did not hit, alive); one\n"
               "whose next fault or mission end comes first is 'not judged' (column unjdg), with the reason.\n"
               "Exit 0 when nothing is unsafe, leaked, hung or unrecovered (a cold restart after the loss of one\n"
               "image counts as unrecovered when the store held another generation: that one was intact).");
  declare_campaign_options(opts, r);
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (r.domain && *r.domain + r.jobs - 1 > launch::defaults::kMaxDdsDomainId) {
    return refuse("rejuv faults: --domain " + std::to_string(*r.domain) + " + --jobs " + std::to_string(r.jobs) +
                     " - 1 is above the highest DDS domain " + std::to_string(launch::defaults::kMaxDdsDomainId));
  }
  if (r.realtime && opts.given("--charge")) {
    return refuse("rejuv faults: --charge is lockstep's: in real time nothing is charged, a recovery lasts what it lasts");
  }
  const auto missions = plan_campaign(r);
  if (!missions) return refuse("rejuv faults: " + missions.error());
  std::error_code ec;
  fs::create_directories(r.out_dir, ec);
  if (ec) return refuse("rejuv faults: --out: cannot create '" + r.out_dir.string() + "': " + ec.message());
  // The jobs' DDS domains (job_pool.hpp) held for the campaign, and SIGINT/SIGTERM to stop it.
  auto signals = sys::SignalFd::create({SIGINT, SIGTERM});
  if (!signals) return refuse("rejuv faults: signalfd: " + signals.error().to_string());
  auto pool = JobPool::create(PoolConfig{.workers = static_cast<unsigned>(r.jobs),
                                         .first_domain = r.domain ? std::optional(static_cast<std::uint32_t>(*r.domain))
                                                                  : std::nullopt,
                                         .signals = &*signals});
  if (!pool) return refuse("rejuv faults: no free DDS domain (" + pool.error() + "): give --domain");
  std::fprintf(stderr, "rejuv faults: %llu faults in %zu missions, %llu job%s, seed %llu%s%s\n",
               static_cast<unsigned long long>(r.injections), missions->size(), static_cast<unsigned long long>(r.jobs),
               r.jobs == 1 ? "" : "s", static_cast<unsigned long long>(r.seed), r.realtime ? ", real time" : "",
               r.load ? (", load " + r.load->to_string()).c_str() : "");
  // The background load lives from here to the table: its workers are this process's children, killed and
  // reaped on every return below (and dying with this process if it is killed).
  std::optional<BackgroundLoad> load;
  if (r.load) {
    auto started = BackgroundLoad::start(*r.load);
    if (!started) return refuse("rejuv faults: " + started.error());
    load.emplace(std::move(*started));
  }
  const auto done = run_jobs(r, *missions, *pool);
  const std::size_t load_ended = load ? load->ended() : 0;
  if (load) load->stop();
  if (load_ended > 0) {
    std::fprintf(stderr, "rejuv faults: %zu of %u load workers ended before the campaign did: the load was not there "
                 "throughout\n", load_ended, r.load->cpu_workers);
  }
  if (!done) {
    std::fprintf(stderr, "rejuv faults: %s\n", done.error().c_str());
    return static_cast<int>(Exit::Findings);
  }
  const proto::FaultCampaign campaign = tally(r, done->outcomes);
  print_campaign(campaign);
  std::ofstream json(r.out_dir / "faults.json");
  json << to_json(campaign) << "\n";
  json.close();
  if (!json) {
    std::fprintf(stderr, "rejuv faults: cannot write %s\n", (r.out_dir / "faults.json").c_str());
    return static_cast<int>(Exit::Findings);
  }
  std::printf("wrote %s\n", (r.out_dir / "faults.json").c_str());
  const proto::FaultRow& total = campaign.total();
  // Nothing injected is no evidence: a campaign that injected nothing fails.
  const bool good = !done->job_failed && done->missing == 0 && load_ended == 0 && total.injections() > 0 &&
                    total.recovered() + total.not_judged() == total.injections() &&
                    total.unsafe() == 0 && total.leaked() == 0 && total.hung() == 0;
  return static_cast<int>(good ? Exit::Ok : Exit::Findings);
}

}  // namespace rejuv::cli
