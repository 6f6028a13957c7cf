// The run summary of a finished run, filled in one place (run_summary.hpp).
#include "run_summary.hpp"

#include <utility>

#include "rejuv/cap/capability.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/sys/event.hpp"
#include "attack_option.hpp"
#include "report.hpp"

namespace rejuv::cli {

namespace {

void fill_sandbox(proto::SandboxViolations& out, const kernel::Kernel& k, bool insecure) {
  // Without root the insecure sandbox also has no uid of its own per service (docs/sandbox.md): said here too.
  out.set_isolation(!insecure                 ? "namespaces, a uid per service"
                    : sys::running_as_root() ? "none (--insecure-sandbox); a uid per service"
                                             : "none (--insecure-sandbox): every service runs as the kernel's uid, "
                                               "which can read the kernel user's files and signal the kernel");
  for (std::size_t i = 0; i < k.service_count(); ++i) {
    const kernel::ServiceStats st = k.stats(ServiceId{static_cast<std::uint32_t>(i)});
    out.set_total(out.total() + st.sandbox_violations);
    out.set_forbidden_calls(out.forbidden_calls() + st.forbidden_calls);
    out.set_stray_processes(out.stray_processes() + st.stray_processes);
    out.set_out_of_memory(out.out_of_memory() + st.out_of_memory);
    out.set_images_lost(out.images_lost() + st.images_lost);
    if (out.cgroup().empty() && !st.cgroup.empty()) out.set_cgroup(st.cgroup);
    if (st.sandbox_violations > 0) (*out.mutable_by_service())[st.name] = st.sandbox_violations;
    for (const auto& [name, n] : st.calls_refused) (*out.mutable_calls())[name] += n;
  }
}

// Each service's evidence (ServiceSummary), in the policy's order.
void fill_services(proto::RunSummary& out, const kernel::Kernel& k) {
  for (std::size_t i = 0; i < k.service_count(); ++i) {
    const kernel::ServiceStats st = k.stats(ServiceId{static_cast<std::uint32_t>(i)});
    proto::ServiceSummary& s = *out.add_services();
    s.set_name(st.name);
    const proto::ServiceSpec* spec = launch::find_service(k.graph().graph, st.name);
    s.set_rejuvenated(spec != nullptr && launch::rejuvenate(*spec));
    s.set_spawns(st.spawns);
    s.set_images(st.images);
    s.set_restores(st.restores);
    s.set_publishes(st.publishes);
    for (const auto& [topic, n] : st.publishes_by_topic) (*s.mutable_publishes_by_topic())[topic] = n;
    s.set_delivered(st.delivered);
    s.set_lost(st.lost);
    s.set_denials(st.denials);
    s.set_sandbox_violations(st.sandbox_violations);
    s.set_images_lost(st.images_lost);
    s.set_hung(st.hung);
    s.set_publications_over_budget(st.publications_over_budget);
  }
}

// The estimate catch-up after each rollback (docs/control.md §6.3).
void fill_catch_up(proto::CatchUpSummary& out, const kernel::Kernel& k) {
  const kernel::CatchUpStats& c = k.catch_up_stats();
  out.set_replays(c.replays);
  out.set_samples(c.samples);
  out.set_dropped(c.dropped);
  out.set_without_log(c.without_log);
  out.set_cut_short(c.cut_short);
  out.set_discarded(c.discarded);
  fill_percentiles(*out.mutable_replay_ms(), k.sr_stats().catch_up_ms);
}

// docs/design.md §6: what was charged to simulated time, and the real durations beside it (wall-clock fields).
void fill_charging(proto::Charging& out, const kernel::Kernel& k, kernel::KernelOptions::Charge charge) {
  const kernel::SrStats& sr = k.sr_stats();
  const bool lockstep = k.clock_mode() == kernel::ClockMode::Lockstep;
  out.set_charge(lockstep ? std::string(to_string(charge)) : "none");
  if (lockstep && charge == kernel::KernelOptions::Charge::Model) {
    const proto::LockstepTiming& timing = k.graph().graph.lockstep();
    out.set_checkpoint_charge_ms(launch::checkpoint_charge(timing).count() * 1e3);
    out.set_rollback_charge_ms(launch::rollback_charge(timing).count() * 1e3);
  }
  out.set_charged_s(to_seconds(sr.charged).count());
  out.set_measured_s(to_seconds(sr.measured).count());
  out.set_first_checkpoint_ms(sr.first_checkpoint_ms.value_or(0.0));
  out.set_checkpoint_p99_ms(sr.checkpoint_ms.quantile(0.99));
  out.set_rollback_p99_ms(sr.rollback_ms.quantile(0.99));
  out.set_alignment_s(to_seconds(k.flight_start()).count());
  out.set_priming_images(sr.priming_images);
}

}  // namespace

std::string_view to_string(kernel::KernelOptions::Charge charge) {
  return charge == kernel::KernelOptions::Charge::Model ? "model" : "measured";
}

RunFacts facts_of(const kernel::Kernel& k, const kernel::KernelOptions& options) {
  const proto::Launch& graph = k.graph().graph;
  const bool attack = graph.attack().enabled() && !options.no_attack;
  return RunFacts{.graph = graph.name(), .runner = "run", .attack = attack,
                  .attack_kind = attack ? vehicle_attack_kind(graph) : std::string(),
                  .seed = options.seed.value_or(graph.seed()),
                  .insecure_sandbox = options.sandbox == kernel::KernelOptions::Sandbox::Insecure,
                  .charge = options.charge};
}

void fill_summary(proto::RunSummary& s, const kernel::Kernel& k, const RunRecorder& recorder,
                  const kernel::RunOutcome& outcome, const RunFacts& facts) {
  s.set_graph(facts.graph);
  s.set_runner(facts.runner);
  s.set_sr(k.sr_enabled());
  s.set_attack(facts.attack);
  s.set_attack_kind(facts.attack_kind);
  s.set_seed(facts.seed);
  recorder.fill(s, outcome.sim_time);
  // Denials by kind, from the capability kernel's counters (docs/design.md §3); frames refused before any cap
  // check (framing, protocol) as "BadFrame".
  const cap::DenialCounters& counters = k.caps().denials();
  for (const cap::CapError e : cap::kAllCapErrors) {
    if (const std::uint64_t n = counters.by_error(e); n > 0) (*s.mutable_denials())[std::string(cap::to_string(e))] = n;
  }
  if (const std::uint64_t bad = k.bad_frames_total(); bad > 0) (*s.mutable_denials())["BadFrame"] = bad;
  // Contained below the cap check (docs/design.md §11): sandbox violations (the seccomp filter ended the process),
  // publications over the per-step bound or of the wrong size, and messages overrun in the rings.
  std::uint64_t flood = 0, over_budget = 0, wrong_size = 0, overrun = 0;
  for (std::size_t i = 0; i < k.service_count(); ++i) {
    const kernel::ServiceStats st = k.stats(ServiceId{static_cast<std::uint32_t>(i)});
    flood += st.flood_dropped;
    over_budget += st.publications_over_budget;
    wrong_size += st.wrong_size;
    overrun += st.lost;
  }
  fill_sandbox(*s.mutable_sandbox_violations(), k, facts.insecure_sandbox);
  fill_services(s, k);
  for (const auto& [kind, n] : {std::pair{"SandboxViolation", s.sandbox_violations().total()}, std::pair{"FloodDropped", flood},
                                std::pair{"PublicationsOverBudget", over_budget},
                                std::pair{"WrongSize", wrong_size}, std::pair{"RingOverrun", overrun}}) {
    if (n > 0) (*s.mutable_denials())[kind] = n;
  }
  const double sim_s = to_seconds(outcome.sim_time).count();
  const double wall_s = to_seconds(outcome.wall_time).count();
  s.set_sim_time_s(sim_s);
  s.set_wall_time_s(wall_s);
  s.set_realtime_factor(wall_s > 0 ? sim_s / wall_s : 0.0);
  fill_network(*s.mutable_network(), k.net_stats(), k.network_port());
  // The image store (docs/design.md §7): counts and the real duration of every checkpoint and rollback.
  const kernel::SrStats& sr = k.sr_stats();
  s.set_checkpoints(sr.checkpoints);
  s.set_rollbacks(sr.rollbacks);
  fill_percentiles(*s.mutable_checkpoint_ms(), sr.checkpoint_ms);
  fill_percentiles(*s.mutable_rollback_ms(), sr.rollback_ms);
  fill_image_phases(*s.mutable_image_phases(), sr);
  fill_charging(*s.mutable_charging(), k, facts.charge);
  if (s.sr() && k.graph().graph.sr().estimate_catch_up()) fill_catch_up(*s.mutable_catch_up(), k);
  if (sr.timer_arm_refused > 0) (*s.mutable_denials())["TimerArmedTwice"] = sr.timer_arm_refused;
}

}  // namespace rejuv::cli
