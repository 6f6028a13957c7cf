// The kernel's public API (kernel.hpp): boot, run, manual steps, stop, injection, the image operations of
// tests and benchmarks, and what a run reports. The kernel itself is in its component files: creation in
// create.cpp, the event loop in loop.cpp, lockstep steps in lockstep.cpp, routing in router.cpp, channel
// requests in channel_input.cpp, processes in supervisor.cpp, images in rejuvenator.cpp, the DDS bridge in
// bridge.cpp, containment in warden.cpp, the network gate in netgate.cpp; vocabulary.cpp names its enums.
#include <algorithm>
#include <string>

#include "impl.hpp"

namespace rejuv::kernel {

Kernel::Kernel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Kernel::~Kernel() { shutdown(); }
// ---- public API ----

Result<void, KernelError> Kernel::boot() {
  Impl& k = *impl_;
  if (k.booted) return {};
  if (k.shut_down) return fail(kernel_error(KernelError::Kind::Boot, "the kernel has been shut down"));
  k.wall_start = k.wall();
  for (const ServiceRuntime& s : k.services) {
    if (s.config.skip) k.log("not starting '%s': %s", s.name.c_str(), s.config.skip_reason.c_str());
  }
  if (auto ok = k.supervisor.spawn_all(); !ok) {
    k.supervisor.shutdown_all();
    return ok;
  }
  // Bounded in every path: a service that is not Ready by its boot deadline is killed (check_deadlines) and
  // a loss before the graph is booted stops the run (lose_service); this is the backstop behind both.
  const Nanos boot_limit = k.wall() + k.options.boot_deadline + k.options.shutdown_grace + kChannelCloseGrace;
  while (!k.all_ready()) {
    if (k.stop) break;
    if (k.wall() >= boot_limit) {
      std::string waiting;
      for (const ServiceRuntime& s : k.services) {
        if (!s.config.skip && s.proc.phase() != Phase::Ready) waiting += (waiting.empty() ? "'" : ", '") + s.name + "'";
      }
      k.stop_run(StopReason::ServiceFailed, "the graph did not boot within " +
                                                std::to_string(to_seconds(k.options.boot_deadline).count()) +
                                                " s; not ready: " + waiting);
      break;
    }
    if (auto ok = k.pump(boot_limit - k.wall()); !ok) {
      k.supervisor.shutdown_all();
      return ok;
    }
  }
  if (k.stop) {
    KernelError e = kernel_error(KernelError::Kind::Boot, k.stop_detail.empty() ? std::string(to_string(*k.stop)) : k.stop_detail);
    k.supervisor.shutdown_all();
    return fail(std::move(e));
  }
  k.booted = true;
  const std::string where = k.pinned_cpu ? ", on CPU " + std::to_string(*k.pinned_cpu) : std::string();
  k.log("%zu services ready (%s clock%s%s)", static_cast<std::size_t>(std::count_if(
                                                 k.services.begin(), k.services.end(),
                                                 [](const ServiceRuntime& s) { return !s.config.skip; })),
        std::string(to_string(k.clock_mode)).c_str(), k.sr ? ", SR on" : ", SR off", where.c_str());
  if (k.options.time_master == TimeMaster::Plant && k.graph.graph.has_plant()) {
    if (auto ok = k.supervisor.spawn_plant(); !ok) {
      k.supervisor.shutdown_all();
      return ok;
    }
  }
  return {};
}

Result<StepReport, KernelError> Kernel::step(Nanos t) {
  Impl& k = *impl_;
  if (k.options.time_master != TimeMaster::Manual) {
    return fail(kernel_error(KernelError::Kind::Config, "step() is for TimeMaster::Manual"));
  }
  if (!k.booted || k.shut_down) return fail(kernel_error(KernelError::Kind::Boot, "not booted"));
  const std::uint64_t target = k.lockstep.steps().steps_done() + 1;
  k.lockstep.offer_manual_step(t);
  StepReport report;
  std::uint32_t rounds = 0;
  while (k.lockstep.steps().steps_done() < target) {
    if (k.stop && !graceful(*k.stop) && !k.lockstep.steps().active()) break;
    if (const auto next = k.lockstep.begin_next_step()) {
      report.step = next->step;
      report.t = next->t;
    }
    if (k.lockstep.steps().active() && k.lockstep.advance_step()) {
      rounds = k.lockstep.steps().rounds();
      report.hung = k.lockstep.steps().hung();
      k.lockstep.finish_step();
      break;
    }
    if (auto ok = k.pump(std::nullopt); !ok) return fail(ok.error());
  }
  report.rounds = rounds;
  return report;
}
Result<RunOutcome, KernelError> Kernel::run() {
  Impl& k = *impl_;
  if (!k.booted) {
    if (auto ok = boot(); !ok) return fail(ok.error());
  }
  if (k.options.time_master == TimeMaster::Manual) {
    return fail(kernel_error(KernelError::Kind::Config, "run() needs a time master: use step() in manual mode"));
  }
  k.wall_start = k.wall();
  k.last_progress = Nanos{0};
  Result<void, KernelError> ran;
  switch (k.clock_mode) {
    case ClockMode::Lockstep: ran = k.lockstep.run_lockstep(); break;  // lockstep.cpp
    case ClockMode::Realtime: ran = k.run_realtime(); break;   // loop.cpp
  }
  if (!ran) {
    k.supervisor.shutdown_all();
    return fail(ran.error());
  }
  RunOutcome outcome{.reason = k.stop.value_or(StopReason::Requested),
                     .detail = k.stop_detail,
                     .steps = k.lockstep.steps().steps_done(),
                     .sim_time = k.now(),
                     .wall_time = k.wall() - k.wall_start};
  shutdown();
  return outcome;
}

void Kernel::shutdown() {
  impl_->supervisor.shutdown_all();
}

void Kernel::request_stop() { impl_->stop_run(StopReason::Requested, "requested"); }

Result<void, KernelError> Kernel::inject(std::string_view topic, std::span<const std::byte> payload) {
  Impl& k = *impl_;
  const auto object = k.policy.find_object(topic);
  if (!object || k.objects[object->value()].type == nullptr) {
    return fail(kernel_error(KernelError::Kind::Config, "no topic '" + std::string(topic) + "'"));
  }
  if (payload.size() != k.objects[object->value()].type->size) {
    return fail(kernel_error(KernelError::Kind::Config, "payload size differs from the topic's"));
  }
  k.router.publish_as_kernel(*object, payload, Router::From::Bridge);
  return {};
}

std::optional<StopReason> Kernel::stop_reason() const { return impl_->stop; }
const std::string& Kernel::stop_detail() const { return impl_->stop_detail; }
Nanos Kernel::now() const { return impl_->now(); }
SrMode Kernel::mode() const { return impl_->caps.mode(); }
ClockMode Kernel::clock_mode() const { return impl_->clock_mode; }
dds::RunId Kernel::run_id() const { return impl_->run_id; }
bool Kernel::sr_enabled() const { return impl_->sr; }
bool Kernel::image_work_pending() const {
  return impl_->rejuvenator.coordinator().work_left();
}
const cap::CapSystem& Kernel::caps() const { return impl_->caps; }
const broker::Broker& Kernel::broker() const { return impl_->broker; }
std::size_t Kernel::service_count() const { return impl_->services.size(); }
const launch::LoadedLaunch& Kernel::graph() const { return impl_->graph; }
std::vector<Kernel::TopicInfo> Kernel::topics() const {
  std::vector<TopicInfo> out;
  for (const ObjectInfo& o : impl_->objects) {
    if (o.kind != ObjectKind::Topic || o.type == nullptr) continue;
    out.push_back({.id = o.id, .name = o.name, .type = o.type->name, .size = o.type->size});
  }
  return out;
}
std::uint64_t Kernel::bad_frames_total() const { return impl_->kernel_bad_frames; }
const SrStats& Kernel::sr_stats() const {
  return impl_->rejuvenator.sr_stats();
}
const CatchUpStats& Kernel::catch_up_stats() const {
  return impl_->rejuvenator.catch_up().stats();
}

Result<Generation, KernelError> Kernel::checkpoint_now() {
  Impl& k = *impl_;
  if (!k.sr || !k.booted || k.lockstep.steps().active() ||
      k.rejuvenator.coordinator().checkpoint() != ImageCoordinator::Checkpoint::None) {
    return fail(kernel_error(KernelError::Kind::Config, "checkpoint_now: needs SR on, a booted kernel and no step in progress"));
  }
  const std::uint64_t before = k.rejuvenator.sr_stats().checkpoints;
  (void)k.rejuvenator.request_checkpoint(std::nullopt, 0);
  if (auto ok = k.rejuvenator.finish_image_requests(); !ok) return fail(ok.error());
  if (k.rejuvenator.sr_stats().checkpoints == before)
    return fail(kernel_error(KernelError::Kind::Boot, "the checkpoint was abandoned"));
  return k.rejuvenator.images().newest()->g;
}

Result<void, KernelError> Kernel::rollback_now(bool cold) {
  Impl& k = *impl_;
  if (!k.sr || !k.booted || k.lockstep.steps().active()) {
    return fail(kernel_error(KernelError::Kind::Config, "rollback_now: needs SR on, a booted kernel and no step in progress"));
  }
  if (cold) {
    k.rejuvenator.cold_restart("requested");
    return {};
  }
  k.rejuvenator.request_rollback("requested");
  return k.rejuvenator.finish_image_requests();
}
Epoch Kernel::epoch() const { return impl_->kernel_clock.epoch(); }
Nanos Kernel::flight_start() const {
  return impl_->rejuvenator.flight_start();
}
void Kernel::settle_images() {
  Impl& k = *impl_;
  const Nanos deadline = k.wall() + std::chrono::milliseconds{500};
  for (;;) {
    k.rejuvenator.refresh_images();
    k.rejuvenator.trim_images(true);
    k.rejuvenator.finish_retiring(false);
    bool pending = !k.rejuvenator.retiring().empty();
    if (k.rejuvenator.images().spares_pending() > 0) pending = true;
    if (!k.warden.placements_idle()) pending = true;  // a move holds its cgroup.procs fds until it is done
    if (!pending || k.wall() > deadline) break;
    (void)sys::wait_fd(k.epoll.fd(), sys::WaitFor::Readable, std::chrono::milliseconds{1});
  }
  k.rejuvenator.kill_and_reap_all();
}

std::vector<int> Kernel::image_pids(ServiceId service) {
  impl_->rejuvenator.refresh_images();
  return impl_->rejuvenator.images().image_pids(service);
}
std::vector<int> Kernel::image_pids(ServiceId service, Generation g) {
  impl_->rejuvenator.refresh_images();
  return impl_->rejuvenator.images().image_pids(service, g);
}
std::vector<Generation> Kernel::generations() const {
  return impl_->rejuvenator.images().generations();
}
std::optional<int> Kernel::plant_pid() const {
  return impl_->supervisor.plant_pid();
}

std::optional<ServiceId> Kernel::find_service(std::string_view name) const {
  for (const ServiceRuntime& s : impl_->services) {
    if (s.name == name) return s.id;
  }
  return std::nullopt;
}

ServiceStats Kernel::stats(ServiceId service) const {
  const ServiceRuntime& s = impl_->services.at(service.value());
  ServiceStats out = s.stats;
  out.frames_out = s.flow().frames_out();
  out.started = !s.config.skip && s.proc.phase() != Phase::NotStarted;
  out.alive = s.live();
  out.ready = s.proc.phase() == Phase::Ready;
  out.pid = s.proc.process.pid();
  out.exit = s.proc.process.status();
  out.cgroup = s.sandbox.cgroup_note;
  for (std::size_t o = 0; o < s.published.size(); ++o) {
    if (s.published[o] > 0) out.publishes_by_topic.emplace_back(impl_->objects[o].name, s.published[o]);
  }
  // Messages routed to it that it will never get: skipped by the broker, or overrun while it stays blocked.
  // s.stats.lost has what next() already skipped; add what is overrun but not yet skipped.
  for (const SubscriptionRecord& r : s.subscriptions) {
    const std::optional<std::uint64_t> routed_to = impl_->router.routed_to(r.id);
    if (!routed_to) continue;
    const std::uint64_t routed = *routed_to;
    const auto st = impl_->broker.subscriber_stats(r.id);
    const auto pending = impl_->broker.pending(r.id);
    if (!st || !pending) {
      continue;  // removed (the service died): its loss is what the broker counted before
    }
    const std::uint64_t accounted = st->delivered + st->lost + *pending;
    out.lost += routed > accounted ? routed - accounted : 0;
  }
  return out;
}

}  // namespace rejuv::kernel
