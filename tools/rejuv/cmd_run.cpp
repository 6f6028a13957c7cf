// `rejuv run GRAPH`: the multi-process runtime (docs/design.md §2, §10). Starts the kernel, which spawns every
// service of the graph and the plant as its children, runs the mission (lockstep by default: the plant is the
// time master; --realtime for wall-clock time), prints progress to stderr and the run summary at the end
// (proto::RunSummary, runner "run"). The metrics come from what the kernel routes — ground truth from the
// plant, the estimate, the setpoint, the actuator outputs — measured with the same path, ellipsoid P and
// control design as `rejuv sim` (rejuv_sr_sim / rejuv_control), so the two runners compare directly.
// A vehicle lost (V > 100, `rejuv sim`'s rule) ends the run at once. Exit 0 when the mission completes
// inside the safety set, 1 when it fails (or leaves the safety set, or a service fails at boot, or the policy
// fails its audit), 2 on input the loaders refuse (README "Exit codes").
#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "args.hpp"
#include "common_options.hpp"
#include "figures.hpp"
#include "host_part.hpp"
#include "attack_option.hpp"
#include "report.hpp"
#include "commands.hpp"
#include "run_recorder.hpp"
#include "run_summary.hpp"
#include "ulog_recorder.hpp"
#include "rejuv/cap/capability.hpp"
#include "rejuv/core/did_you_mean.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/flight_io/messages.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::cli {
namespace {

std::string describe_sandbox(const proto::SandboxViolations& v) {
  std::string out = v.isolation() + ", " + std::to_string(v.total()) + " violation" + (v.total() == 1 ? "" : "s");
  if (v.images_lost() > 0) out += ", " + std::to_string(v.images_lost()) + " image(s) lost in the store";
  if (v.total() == 0) return out;
  out += " (" + std::to_string(v.forbidden_calls()) + " forbidden calls, " + std::to_string(v.stray_processes()) +
         " stray processes";
  if (v.out_of_memory() > 0) out += ", " + std::to_string(v.out_of_memory()) + " out of memory";
  std::string calls;
  for (const auto& [name, n] : v.calls()) calls += (calls.empty() ? "" : ", ") + name + " " + std::to_string(n);
  if (!calls.empty()) out += ": " + calls;
  return out + ")";
}

// One line per service (ServiceSummary): its part in SR and on the data plane.
std::string describe_services(const proto::RunSummary& s) {
  if (s.services().empty()) return {};
  std::size_t width = 7;
  for (const proto::ServiceSummary& v : s.services()) width = std::max(width, v.name().size());
  char line[256];
  std::snprintf(line, sizeof line, "  services    %-*s %6s %7s %8s %10s %10s %6s %7s %10s\n", static_cast<int>(width), "",
                "spawns", "images", "restores", "published", "delivered", "lost", "denials", "violations");
  std::string out = line;
  for (const proto::ServiceSummary& v : s.services()) {
    std::snprintf(line, sizeof line, "              %-*s %6llu %7s %8s %10llu %10llu %6llu %7llu %10llu%s\n",
                  static_cast<int>(width), v.name().c_str(), static_cast<unsigned long long>(v.spawns()),
                  v.rejuvenated() ? std::to_string(v.images()).c_str() : "-",
                  v.rejuvenated() ? std::to_string(v.restores()).c_str() : "-",
                  static_cast<unsigned long long>(v.publishes()), static_cast<unsigned long long>(v.delivered()),
                  static_cast<unsigned long long>(v.lost()), static_cast<unsigned long long>(v.denials()),
                  static_cast<unsigned long long>(v.sandbox_violations()), v.hung() ? "  (hung: killed)" : "");
    out += line;
  }
  return out;
}

// One line per attack of the plan (AttackKindSummary): windows, denials, containment, max V in its spans.
std::string describe_attacks(const proto::RunSummary& s) {
  if (s.attacks_by_kind().empty()) return {};
  std::size_t kind_width = 4, service_width = 7;
  for (const proto::AttackKindSummary& a : s.attacks_by_kind()) {
    kind_width = std::max(kind_width, a.kind().size());
    service_width = std::max(service_width, a.service().size());
  }
  char line[256];
  std::snprintf(line, sizeof line, "  attacks     %-*s %-*s %7s %7s %9s %8s\n", static_cast<int>(kind_width),
                "kind", static_cast<int>(service_width), "service", "windows", "denied", "contained",
                "max V");
  std::string out = line;
  for (const proto::AttackKindSummary& a : s.attacks_by_kind()) {
    std::snprintf(line, sizeof line, "              %-*s %-*s %7llu %7llu %9llu %8.4f%s\n",
                  static_cast<int>(kind_width), a.kind().c_str(), static_cast<int>(service_width),
                  a.service().c_str(), static_cast<unsigned long long>(a.windows_fired()),
                  static_cast<unsigned long long>(a.denied()), static_cast<unsigned long long>(a.contained()),
                  a.max_v(), a.left_safety_set() ? "  LEFT THE SAFETY SET" : "");
    out += line;
  }
  return out;
}

std::string describe(const proto::RunSummary& s, const kernel::RunOutcome& outcome) {
  std::string denials;
  for (const auto& [kind, n] : s.denials()) {
    denials += (denials.empty() ? "" : ", ") + kind + " " + std::to_string(n);
  }
  const proto::ImagePhases& ph = s.image_phases();
  char phases[384] = "";
  if (s.checkpoints() + s.rollbacks() > 0) {
    std::snprintf(phases, sizeof phases,
                  "  phases      p50 [ms]: checkpoint snapshot %.3f, taken %.3f, save %.3f; rollback kill %.3f, "
                  "resume %.3f, restore %.3f; images %llu by written pages, %llu by fork\n",
                  ph.checkpoint_snapshot().p50(), ph.checkpoint_taken().p50(), ph.checkpoint_save().p50(),
                  ph.rollback_kill().p50(), ph.rollback_resume().p50(), ph.rollback_restore().p50(),
                  static_cast<unsigned long long>(ph.images_by_pages()),
                  static_cast<unsigned long long>(ph.images_by_fork()));
  }
  const proto::Charging& ch = s.charging();
  char charged[640] = "";
  if (s.checkpoints() + s.rollbacks() > 0 || ch.priming_images() > 0) {
    std::snprintf(charged, sizeof charged,
                  "  charged     %s: %.3f s of simulated time (real %.3f s); first checkpoint %.3f ms, p99 %.3f ms; "
                  "%llu images forked in the %.1f s alignment\n",
                  ch.charge() == "model" ? "model" : ch.charge().c_str(), ch.charged_s(), ch.measured_s(),
                  ch.first_checkpoint_ms(), ch.checkpoint_p99_ms(),
                  static_cast<unsigned long long>(ch.priming_images()), ch.alignment_s());
  }
  if (s.has_catch_up()) {  // appended to the charges' line group: the replay is charged with the rollback
    const proto::CatchUpSummary& c = s.catch_up();
    char line[320];
    std::snprintf(line, sizeof line,
                  "  catch-up    %llu replays of %llu samples (p50 %.3f ms, max %.3f ms real); %llu estimates held from "
                  "the controllers; %llu rollbacks not caught up, %llu replays cut short, %llu discarded (re-armed)\n",
                  static_cast<unsigned long long>(c.replays()), static_cast<unsigned long long>(c.samples()),
                  c.replay_ms().p50(), c.replay_ms().max(), static_cast<unsigned long long>(c.dropped()),
                  static_cast<unsigned long long>(c.without_log()), static_cast<unsigned long long>(c.cut_short()),
                  static_cast<unsigned long long>(c.discarded()));
    std::strncat(charged, line, sizeof charged - std::strlen(charged) - 1);
  }
  char buf[4096];
  std::snprintf(buf, sizeof buf,
                "%s (run): sr=%s attack=%s seed=%llu — %s%s%s\n"
                "  mission     %s in %.1f s (simulated %.1f s in %.1f s wall, %.1fx real time)\n"
                "  tracking    d_mean %.2f cm, d_max %.2f cm\n"
                "  safety      max V = %.4f (%s), max estimation error ||x - x_hat||^2_P = %.4f\n"
                "  control     max gap between actuator outputs %.1f ms; the interval holding a checkpoint p50 %.2f / "
                "p99 %.2f / max %.2f ms, a rollback %.2f / %.2f / %.2f ms\n"
                "  images      %llu checkpoints (p50 %.3f ms, max %.3f ms), %llu rollbacks (p50 %.3f ms, max %.3f ms)\n"
                "%s"
                "%s"
                "  attacks     %llu attacked MC windows\n"
                "  denials     %s\n"
                "  sandbox     %s\n"
                "  network     %s\n",
                s.graph().c_str(), s.sr() ? "on" : "off", s.attack() ? (s.attack_kind().empty() ? "on" : s.attack_kind().c_str()) : "off",
                static_cast<unsigned long long>(s.seed()), std::string(kernel::to_string(outcome.reason)).c_str(),
                outcome.detail.empty() ? "" : ": ", outcome.detail.c_str(),
                s.mission_completed()       ? "completed"
                : s.stopped_after_attacks() ? "stopped after the attacks (stop_after_attacks)"
                                            : "NOT COMPLETED",
                s.mission_time_s(), s.sim_time_s(),
                s.wall_time_s(), s.realtime_factor(), 100.0 * s.d_mean_m(), 100.0 * s.d_max_m(), s.max_v(),
                s.left_safety_set() ? "LEFT THE SAFETY SET" : "safe", s.max_est_err_p(), s.max_control_gap_ms(),
                s.control_interval_at_cp_ms().p50(), s.control_interval_at_cp_ms().p99(),
                s.control_interval_at_cp_ms().max(), s.control_interval_at_rb_ms().p50(),
                s.control_interval_at_rb_ms().p99(), s.control_interval_at_rb_ms().max(),
                static_cast<unsigned long long>(s.checkpoints()), s.checkpoint_ms().p50(), s.checkpoint_ms().max(),
                static_cast<unsigned long long>(s.rollbacks()), s.rollback_ms().p50(), s.rollback_ms().max(), phases, charged,
                static_cast<unsigned long long>(s.attacks()),
                denials.empty() ? "none" : denials.c_str(), describe_sandbox(s.sandbox_violations()).c_str(),
                describe_network(s.network()).c_str());
  return buf + describe_services(s) + describe_attacks(s);
}

std::vector<std::string> service_names(const kernel::Kernel& k) {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < k.service_count(); ++i) names.push_back(k.stats(ServiceId{static_cast<std::uint32_t>(i)}).name);
  return names;
}

// --cpu N|all (KernelOptions::placement).
struct CpuPlacement {
  kernel::KernelOptions::Placement placement;
  int cpu = 0;
};

Result<CpuPlacement, std::string> cpu_placement(std::string_view text) {
  if (text == "all") return CpuPlacement{.placement = kernel::KernelOptions::Placement::Spread};
  const auto c = to_u64(text, "--cpu");
  if (!c || *c >= 1024) return fail("--cpu: expected a CPU number or 'all', got '" + std::string(text) + "'");
  return CpuPlacement{.placement = kernel::KernelOptions::Placement::Cpu, .cpu = static_cast<int>(*c)};
}

// --skip a,b,c.
Result<std::vector<std::string>, std::string> service_names_of(std::string_view text) {
  std::vector<std::string> names;
  while (!text.empty()) {
    const auto comma = text.find(',');
    const std::string_view name = text.substr(0, comma);
    if (!name.empty()) names.emplace_back(name);
    text = comma == std::string_view::npos ? std::string_view{} : text.substr(comma + 1);
  }
  return names;
}

// `rejuv run --help-service NAME [GRAPH]`: the parameters service NAME declares (launch.hpp "declared parameters").
// With a graph, NAME is one of its services, found by its `executable`; without, NAME is an executable of the
// service folder, with or without its "rejuv_" prefix (rejuv_lqr_control or lqr_control).
int help_service(const std::string& name, const std::vector<std::string>& graph_paths) {
  std::filesystem::path executable;
  if (!graph_paths.empty()) {
    const std::vector<std::filesystem::path> files(graph_paths.begin(), graph_paths.end());
    auto loaded = launch::load_launch(std::span<const std::filesystem::path>(files));
    std::string graph_path;
    for (const std::string& p : graph_paths) graph_path += (graph_path.empty() ? "" : " + ") + p;
    if (!loaded) return refuse(loaded.error().to_string());
    const proto::ServiceSpec* spec = launch::find_service(loaded->graph, name);
    if (spec == nullptr) {
      std::vector<std::string> names;
      for (const proto::ServiceSpec& s : loaded->graph.services()) names.push_back(s.name());
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      return refuse("rejuv run: --help-service: " + graph_path + " has no service '" + name + "'" +
                       did_you_mean(name, names) + "; its services: " + list);
    }
    executable = launch::resolve_executable(spec->executable(), service_dir());
  } else {
    const std::filesystem::path dir = service_dir();
    const std::filesystem::path exe(name);
    std::error_code ec;
    executable = launch::resolve_executable(name, dir);
    if (!exe.is_absolute() && !std::filesystem::exists(executable, ec) &&
        std::filesystem::exists(dir / ("rejuv_" + name), ec)) {
      executable = dir / ("rejuv_" + name);
    }
    if (!std::filesystem::exists(executable, ec)) {
      return refuse("rejuv run: --help-service: no service executable '" + name + "' in " + dir.string() +
                       " (give a launch graph to name a service of it)");
    }
  }
  auto declared = launch::declared_params_of(executable);
  if (!declared) return refuse(declared.error().to_string());
  if (!*declared) {
    std::printf("%s declares no parameters (no %s): its params are not checked\n", executable.string().c_str(),
                launch::params_file_of(executable).string().c_str());
    return static_cast<int>(Exit::Ok);
  }
  const proto::ServiceParams& decls = (*declared)->decls;
  if (decls.params_size() == 0) {
    std::printf("%s declares no parameters (%s): a launch graph that sets any is refused\n",
                executable.filename().string().c_str(), (*declared)->path.string().c_str());
    return static_cast<int>(Exit::Ok);
  }
  std::printf("%s: %d declared parameter(s) (%s)\n", executable.filename().string().c_str(), decls.params_size(),
              (*declared)->path.string().c_str());
  std::fputs(launch::format_declared_params(decls).c_str(), stdout);
  return static_cast<int>(Exit::Ok);
}

// What `rejuv run` was asked for: its options as parsed (declare_run_options).
struct RunRequest {
  std::vector<std::string> graph_paths;  // one graph, or several composed into one
  KernelFlags flags;
  FlightSwitches switches;
  std::optional<double> duration, speed;
  std::optional<std::filesystem::path> json_path, csv_path, ulog_path;
  UlogProfile ulog_profile = UlogProfile::Default;
  std::uint64_t ulog_interval_ms = 20;
  std::uint64_t ulog_budget_kb_s = 2000;
  std::optional<CpuPlacement> cpu;
  std::optional<std::vector<std::string>> skip;
  std::optional<dds::RunId> run_id;
  OutFlags out;
  bool realtime = false, verbose = false;
  std::optional<std::string> help_service_name;
  std::optional<std::string> host;                 // --host: that host's part of a graph across hosts
  std::optional<std::filesystem::path> keys;       // --keys: the keystore its links take their enclave from
};

void declare_run_options(Options& opts, RunRequest& r) {
  opts.positionals("GRAPH", r.graph_paths,
                   "the launch graph (*.launch.pbtxt); several are composed into one graph in order, by the\n"
                   "rules of `include` (a field two of them set is refused at the second one's line)",
                   /*required=*/false)
      .text("--help-service", "NAME", r.help_service_name,
            "print the parameters service NAME declares (name, type, default, range, unit, help) and exit:\n"
            "a service of GRAPH, or without GRAPH an executable of the service folder (e.g. lqr_control)")
      .flag("--realtime", r.realtime, "wall-clock time (CLOCK_MONOTONIC) instead of lockstep with the plant")
      .real("--speed", "X", r.speed, {.min = 0.01, .max = 1000},
            "lockstep paced to X times real time (1: a ground station can follow the flight; deterministic\n"
            "as ever)", "as fast as it can");
  flight_options(opts, r.switches, "no rejuvenation: mission control only, checkpoint_p not started");
  seed_option(opts, r.flags.seed, "seed of the plant and the services")
      .real("--duration", "S", r.duration, {.min = 0, .max = launch::defaults::kMaxDurationS, .open_min = true, .open_max = true},
            "stop after S seconds of flight (kernel time after the plant's pre-flight alignment)",
            "the mission's end or timeout")
      .path("--summary-json", "FILE", r.json_path, "write the RunSummary as JSON")
      .path("--csv", "FILE", r.csv_path, "write a trace: t, x, x_hat, x_sp, mode, u, V per plant step");
  charge_option(opts, r.flags.charge);
  out_options(opts, r.out)
      .path("--ulog", "FILE", r.ulog_path,
            "write the run as a PX4 ULog file (every routed topic through --ulog-profile, parameters, log\n"
            "lines, SR events; PlotJuggler, Flight Review, Foxglove: docs/ulog.md)",
            "DIR/run.ulg with --out")
      .choice<UlogProfile>(
          "--ulog-profile", {{"default", UlogProfile::Default}, {"full", UlogProfile::Full}}, r.ulog_profile,
          "what the ULog writes of each topic: default, at most one message per --ulog-interval-ms\n"
          "(bursts of 16 pass); full, every routed message (docs/ulog.md)")
      .integer("--ulog-interval-ms", "MS", r.ulog_interval_ms, {.min = 1, .max = 10000},
               "the default profile's interval per topic [ms of kernel time]")
      .integer("--ulog-budget-kb-s", "KB", r.ulog_budget_kb_s, {.min = 10, .max = 1'000'000},
               "the ULog's size budget [kB per second of kernel time]: each topic's share is KB over the\n"
               "graph's topics; what a topic routes beyond its share is not logged, and the log says so");
  domain_option(opts, r.flags.domain, "DDS domain id", kLeasedDomainHelp)
      .custom<std::vector<std::string>>("--skip", "NAMES", r.skip, service_names_of,
                                        "comma-separated services not to start (e.g. not built yet)")
      .custom<dds::RunId>(
          "--run-id", "HEX", r.run_id,
          [](std::string_view text) { return dds::parse_run_id("--run-id", text); },
          "the run's id: the kernel's DDS bridge and its plant use the partition rejuv.HEX, which no other run\n"
          "on the domain hears (two runs given one id hear each other: for tests)",
          "64 random bits");
  net_port_option(opts, r.flags.net_port, "UDP port of the network gate; 0: any free port",
                  "the graph's network.bind_port or 14555")
      .custom<CpuPlacement>("--cpu", "N|all", r.cpu, cpu_placement, "kernel, services and plant on CPU N or on all",
                            "lockstep stays on the CPU it starts on")
      .flag("--insecure-sandbox", r.flags.insecure_sandbox,
            "run the services without their network and mount namespaces (where neither root nor unprivileged\n"
            "user namespaces are available); the allow-list, limits and sweeps still hold; the summary says so")
      .flag("--verbose", r.verbose, "also print the services' debug log lines")
      .text("--host", "NAME", r.host,
            "run host NAME's part of a graph across hosts (docs/across_hosts.md): its services and a link\n"
            "service per peer host under this kernel; the plant and SR only on the vehicle's host; wall clock",
            "the whole graph on this kernel")
      .path("--keys", "DIR", r.keys,
            "with --host: the keystore of `rejuv keys hosts DIR --launch GRAPH`; the links' DDS Security\n"
            "identity and permissions are DIR/enclaves/<host>");
}

// The kernel's options for the request; an error names flags that contradict each other.
Result<kernel::KernelOptions, std::string> kernel_options_for(const RunRequest& r) {
  kernel::KernelOptions options = kernel_options(r.flags);
  options.no_sr = r.switches.no_sr;
  options.no_attack = r.switches.no_attack;
  options.verbose = r.verbose;
  if (r.realtime) options.clock = kernel::ClockMode::Realtime;
  if (r.speed && r.realtime) return fail(std::string("--speed paces lockstep; --realtime runs at the wall clock already"));
  options.speed = r.speed;
  if (r.duration) {
    options.duration = to_nanos(Seconds{*r.duration});
    options.stop_on_mission_done = false;
  }
  if (r.cpu) {
    options.placement = r.cpu->placement;
    options.cpu = r.cpu->cpu;
  }
  if (r.skip) options.skip_services = *r.skip;
  options.run_id = r.run_id;
  return options;
}

// Where a run's records go: the summary JSON, the trace CSV and the --out directory.
struct RunOutputs {
  UniqueFile json, csv;
  std::optional<RunFiles> files;
};

// After the flight: the summary filled and finished (ULog, --out), printed and written; the exit code.
int finish_run(const RunRequest& r, kernel::Kernel& k, const kernel::KernelOptions& options, const RunRecorder& recorder,
               kernel::RunOutcome outcome, UlogRecorder* ulog, RunOutputs& outputs) {
  if (recorder.stopped_after_attacks()) {
    outcome.detail = std::to_string(k.graph().graph.stop_after_attacks()) + " attacked MC windows (stop_after_attacks)";
  }
  if (const auto& lost = recorder.lost()) {
    char why[128];
    std::snprintf(why, sizeof why, "vehicle lost at t = %.1f s (V = %.4g)", to_seconds(lost->t).count(), lost->V);
    outcome.detail = why;
  }
  proto::RunSummary s;
  fill_summary(s, k, recorder, outcome, facts_of(k, options));
  if (ulog != nullptr) {
    if (auto done = finish_ulog(*ulog, s); !done) {
      std::fprintf(stderr, "rejuv run: %s\n", done.error().c_str());
      return static_cast<int>(Exit::Findings);
    }
  }
  const bool out_ok = !outputs.files || finish_out_dir(*outputs.files, s, "rejuv run",
                                                       r.out.no_figures ? Figures::Skip : Figures::Draw);
  std::fputs(describe(s, outcome).c_str(), stdout);
  if (outputs.json) std::fputs((to_json(s) + "\n").c_str(), outputs.json.get());
  const bool completed_run = s.mission_completed() || outcome.reason == kernel::StopReason::Duration ||
                             s.stopped_after_attacks();
  const bool good = completed_run && !kernel::is_failure(outcome.reason) && !s.left_safety_set() &&
                    outcome.reason != kernel::StopReason::Signal && out_ok;
  return static_cast<int>(good ? Exit::Ok : Exit::Findings);
}

// The flight: the kernel made and run with the recorder (and the ULog) watching; then finish_run.
int fly(const RunRequest& r, const kernel::KernelOptions& options, launch::LoadedLaunch loaded, RunReference reference) {
  RunOutputs outputs;
  if (auto opened = open_outputs("rejuv run", r.json_path, r.csv_path, outputs.json, outputs.csv); !opened) {
    return refuse(opened.error());
  }
  RunRecorder recorder(std::move(reference), outputs.csv.get(),
                       isatty(STDERR_FILENO) == 1 ? RunRecorder::Progress::Every1s : RunRecorder::Progress::Every10s);
  if (r.out.dir) {
    auto opened = RunFiles::open(*r.out.dir, r.out.trace);
    if (!opened) return refuse("rejuv run: " + opened.error());
    outputs.files.emplace(std::move(*opened));
    recorder.record_to(&*outputs.files);
  }
  kernel::ObserverFanout observers;
  observers.add(&recorder);
  auto made = kernel::Kernel::create(std::move(loaded), options, &observers);
  if (!made) {
    std::fprintf(stderr, "rejuv run: %s\n", made.error().to_string().c_str());
    return static_cast<int>(made.error().is_bad_input() ? Exit::BadInput : Exit::Findings);
  }
  kernel::Kernel& k = **made;
  const RunFacts facts = facts_of(k, options);
  std::unique_ptr<UlogRecorder> ulog;
  if (r.ulog_path || r.out.dir) {  // --out DIR writes DIR/run.ulg too, unless --ulog names another file
    auto opened = write_ulog_to(r.ulog_path ? *r.ulog_path : *r.out.dir / "run.ulg", k,
                                {.seed = facts.seed, .sr = k.sr_enabled(), .attack = facts.attack},
                                UlogOptions{.profile = r.ulog_profile,
                                            .interval = std::chrono::milliseconds{r.ulog_interval_ms},
                                            .budget_bytes_per_s = r.ulog_budget_kb_s * 1000},
                                observers);
    if (!opened) return refuse("rejuv run: --ulog: " + opened.error());
    ulog = std::move(*opened);
  }
  recorder.on_vehicle_lost([&k] { k.request_stop(); });  // as `rejuv sim`: V > lost_V
  recorder.track_attacks(AttackLedger(k.graph().graph, facts.attack, k.sr_enabled() ? Rejuvenation::On : Rejuvenation::Off,
                                      k.flight_start(), [&k](std::string_view name) { return k.find_service(name); }));
  if (outputs.files) outputs.files->set_service_names(service_names(k));
  if (k.sr_enabled()) recorder.stop_after_attacks(k.graph().graph.stop_after_attacks(), [&k] { k.request_stop(); });
  // With ROS 2 names the run is in the default partition (docs/across_hosts.md "ROS 2 names").
  const std::string partition = launch::dds_naming(k.graph().graph.dds()) == DdsNaming::Ros2
                                    ? "the default one (ROS 2 names: rt/<topic>)"
                                    : dds::run_partition(k.run_id());
  std::fprintf(stderr, "rejuv run: %s, %s clock, SR %s, seed %llu, DDS partition %s\n", facts.graph.c_str(),
               std::string(kernel::to_string(k.clock_mode())).c_str(), k.sr_enabled() ? "on" : "off",
               static_cast<unsigned long long>(facts.seed), partition.c_str());
  auto outcome = k.run();
  if (!outcome) {
    std::fprintf(stderr, "rejuv run: %s\n", outcome.error().to_string().c_str());
    return static_cast<int>(outcome.error().is_bad_input() ? Exit::BadInput : Exit::Findings);
  }
  return finish_run(r, k, options, recorder, std::move(*outcome), ulog.get(), outputs);
}

}  // namespace

int run_run(std::span<const std::string_view> args) {
  RunRequest r;
  Options opts("run", R"(Run a launch graph on the multi-process runtime: the kernel spawns every service and the plant,
routes every message through the capability check and the broker, and keeps time (lockstep with
the plant as time master unless --realtime). Without --duration the run ends at mission end or
the mission timeout; with it, the run lasts exactly that long (e.g. a hover).
With the graph's sr.enabled (and without --no-sr) the services are checkpointed and rolled back
by the image store (docs/design.md §7) on the rejuvenation timer; checkpoint_p drives the SR cycle.
The run stops when the vehicle is lost (V = ||x - x_sp||^2_P > 100, as `rejuv sim`).
Exit 0 when the mission completes inside the safety set (or the duration passes cleanly), 1 when
it fails, a service fails at boot or the graph's policy fails its audit (as `rejuv audit`), 2 on
bad flags or a file the loaders refuse (README "Exit codes").)");
  declare_run_options(opts, r);
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (r.help_service_name) return help_service(*r.help_service_name, r.graph_paths);
  if (r.graph_paths.empty()) return refuse("rejuv run: missing argument GRAPH (see 'rejuv run --help')");
  if (auto ok = check_out_options(opts, r.out); !ok) return refuse("rejuv run: " + ok.error());
  auto options = kernel_options_for(r);
  if (!options) return refuse("rejuv run: " + options.error());
  auto domain = lease_domain(*options);  // held until the run has ended
  if (!domain) {
    std::fprintf(stderr, "rejuv run: %s\n", domain.error().c_str());
    return 1;
  }

  auto loaded = load_with_attack(r.graph_paths, r.switches.attack, "rejuv run");
  if (!loaded) return refuse(loaded.error());
  for (const std::string& name : options->skip_services) {
    if (launch::find_service(loaded->graph, name) == nullptr) {
      return refuse("rejuv run: --skip: the graph has no service '" + name + "'");
    }
  }
  // The reference for the metrics: the same path, control design and P as `rejuv sim` (services/flight/sim).
  auto reference = run_reference(*loaded, options->seed);
  if (!reference) return refuse(reference.error());
  if (r.switches.no_attack) reference->library_attack.reset();
  // The plant aligns as long as `rejuv sim` does (launch lockstep.alignment_s, passed by the kernel), so that both
  // fly from a converged estimate; --duration counts from the end of it.
  if (options->duration) *options->duration += reference->alignment;
  std::optional<HostPart> part;  // its folder (the links' policy fragment) kept until the kernel has ended
  if (r.host) {
    if (r.speed) return refuse("rejuv run: --speed paces lockstep; --host runs at the wall clock");
    auto cut = host_part(*loaded, *options, *r.host, r.keys);
    if (!cut) return refuse("rejuv run: " + cut.error());
    part.emplace(std::move(*cut));
  } else if (r.keys) {
    return refuse("rejuv run: --keys is the keystore of --host's links; give --host NAME");
  }
  // Every attack's start_s is flight time: the kernel adds the alignment to the boot param (supervisor.cpp), so the
  // attack library's laws (a drift, a moving x_sp, a gyro bias the EKF would learn) start with the flight.
  return fly(r, *options, std::move(*loaded), std::move(*reference));
}

}  // namespace rejuv::cli
