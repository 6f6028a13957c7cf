// The kernel's event loop (docs/design.md §5, §6): one epoll set for every source — service channels, pidfds, the
// signal fd, the realtime timerfd, the DDS bridge's readers, the network gate, seccomp listeners and service
// output — dispatched by pump(); the wall-clock deadlines it sleeps until; kernel timers; the realtime clock;
// and the kernel's logging. The lockstep steps that run on top of it are in lockstep.cpp.
#include <algorithm>
#include <csignal>
#include <cstdarg>

#include "impl.hpp"

namespace rejuv::kernel {

// ---- logging and time ----

void Kernel::Impl::log(const char* format, ...) {
  if (options.log == nullptr && observer == nullptr) return;
  va_list args;
  va_start(args, format);
  const std::string line = log_line(format, args);
  va_end(args);
  if (observer != nullptr) {
    observer->on_log(LogLine{.t = now(), .source = "kernel", .level = LogLine::Level::Info, .text = line});
  }
  if (options.log == nullptr) return;
  std::fprintf(options.log, "[kernel %8.3f] %s\n", to_seconds(now()).count(), line.c_str());
}

bool LogLimiter::allow(Nanos wall_now) {
  // 50 lines of burst, 20 lines per second sustained.
  constexpr double kBurst = 50;
  constexpr double kPerSecond = 20;
  tokens = std::min(kBurst, tokens + to_seconds(wall_now - last).count() * kPerSecond);
  last = wall_now;
  if (tokens >= 1) {
    tokens -= 1;
    return true;
  }
  return false;
}

namespace {
// What may reach the user's terminal, the ULog and the summary of a line a service wrote (stdout, stderr or a
// Log frame alike): printable ASCII, tabs and UTF-8 bytes; control characters — a newline that would start a
// forged '[kernel …]' line, a carriage return that would overwrite one, escape sequences — as '?'.
std::string printable(std::string_view line) {
  std::string out(line);
  for (char& c : out) {
    const auto u = static_cast<unsigned char>(c);
    if ((u < 0x20 && c != '\t') || u == 0x7F) c = '?';
  }
  return out;
}
}  // namespace

void Kernel::Impl::service_log(ServiceRuntime& s, wire::LogLevel level, std::string_view raw) {
  if (level == wire::LogLevel::Debug && !options.verbose) return;  // before the copy: most lines end here
  const std::string text = printable(raw);
  if (level == wire::LogLevel::Error) s.proc.last_error.assign(text);  // kept even when the line is rate-limited
  if (!s.sandbox.limiter.allow(wall())) {
    ++s.stats.log_suppressed;
    ++s.sandbox.limiter.suppressed_since_print;
    return;
  }
  if (observer != nullptr) {
    LogLine::Level l = LogLine::Level::Info;
    switch (level) {
      case wire::LogLevel::Debug: l = LogLine::Level::Debug; break;
      case wire::LogLevel::Info: l = LogLine::Level::Info; break;
      case wire::LogLevel::Warn: l = LogLine::Level::Warning; break;
      case wire::LogLevel::Error: l = LogLine::Level::Error; break;
    }
    observer->on_log(LogLine{.t = now(), .source = s.name, .level = l, .text = text});
  }
  if (options.log == nullptr) return;
  if (s.sandbox.limiter.suppressed_since_print > 0) {
    std::fprintf(options.log, "[%s] (%llu lines suppressed by the rate limit)\n", s.name.c_str(),
                 static_cast<unsigned long long>(s.sandbox.limiter.suppressed_since_print));
    s.sandbox.limiter.suppressed_since_print = 0;
  }
  const char* tag = "";
  switch (level) {
    case wire::LogLevel::Debug: tag = "debug: "; break;
    case wire::LogLevel::Info: break;
    case wire::LogLevel::Warn: tag = "warning: "; break;
    case wire::LogLevel::Error: tag = "error: "; break;
  }
  std::fprintf(options.log, "[%s] %s%s\n", s.name.c_str(), tag, text.c_str());
}

void Kernel::Impl::refuse(ServiceRuntime& s, std::string_view what) {
  ++s.stats.bad_frames;
  ++kernel_bad_frames;
  if (s.sandbox.limiter.allow(wall())) {
    log("refused a frame from '%s': %.*s", s.name.c_str(), static_cast<int>(what.size()), what.data());
  } else {
    ++s.stats.log_suppressed;
  }
}

void Kernel::Impl::set_now(Nanos t) {
  kernel_clock.advance(t);
  caps.set_time(t);
}

Nanos Kernel::Impl::wall() const { return sys::monotonic_now(); }

void Kernel::Impl::stop_run(StopReason reason, std::string detail) {
  if (stop) return;
  stop = reason;
  stop_detail = std::move(detail);
  log("stopping: %s%s%s", std::string(to_string(reason)).c_str(), stop_detail.empty() ? "" : ": ",
      stop_detail.c_str());
}

// ---- the event loop ----

Result<void, KernelError> Kernel::Impl::pump(std::optional<Nanos> max_wait) {
  std::optional<Nanos> timeout = max_wait;
  input.resume_paused(wall());  // channels of services over their publication budget (real time)
  if (const auto deadline = next_wall_deadline()) {
    const Nanos left = std::max(Nanos{0}, *deadline - wall());
    timeout = timeout ? std::min(*timeout, left) : left;
  }
  std::array<sys::Event, 64> events{};
  auto n = epoll.wait(events, timeout);
  if (!n) return fail(kernel_error(KernelError::Kind::System, n.error().to_string()));
  if (clock_mode == ClockMode::Realtime && booted && clock_synced) set_now(sys::monotonic_now() - run_start_mono);
  for (std::size_t i = 0; i < *n; ++i) {
    const sys::Event& e = events[i];
    const auto source = static_cast<Source>(e.token >> 56U);
    const std::size_t index = e.token & ((std::uint64_t{1} << 56U) - 1U);
    switch (source) {
      case Source::Channel: {
        ServiceRuntime& s = services[index];
        if (!s.live() || !s.proc.channel.valid()) break;
        if (e.writable) router.drain(s);
        if (e.readable || e.hangup || e.error) input.read_channel(s);
        break;
      }
      case Source::Pidfd: supervisor.on_child_exit(services[index]); break;
      case Source::Plant: supervisor.on_plant_exit(); break;
      case Source::Signal: {
        auto sig = signals->read();
        if (sig && *sig) stop_run(StopReason::Signal, *sig == SIGINT ? "SIGINT" : "SIGTERM");
        break;
      }
      case Source::Timer:
        (void)timerfd->consume();
        rejuvenator.fire_rejuvenation();
        fire_timers();
        arm_timerfd();
        break;
      case Source::Dds: on_dds_ready(index); break;
      case Source::Net: net_poll(); break;  // realtime only; lockstep polls at the start of a step
      case Source::Seccomp: {
        ServiceRuntime& s = services[index];
        warden.on_seccomp_notice(s);
        // No process uses the filter any more (the service and its images are gone): nothing more can come.
        if (e.hangup && !e.readable && s.sandbox.seccomp.valid()) {
          (void)epoll.remove(s.sandbox.seccomp.fd());
          s.sandbox.seccomp.close();
        }
        break;
      }
      case Source::Output: warden.on_service_output(services[index]); break;
    }
  }
  router.drain_denials();
  supervisor.check_deadlines();
  return {};
}

void Kernel::Impl::on_dds_ready(std::size_t index) {
  if (!bridge) return;
  if (bridge->is_step_input(index)) {
    lockstep.take_steps();  // lockstep.cpp
    return;
  }
  dds::Bridge::Input& in = bridge->readers()[index];
  if (!in.topic) {
    // The lockstep adapter's count-only reader: samples that did not fit their SimStep on a topic the graph
    // does not bridge in, dropped but counted toward SimStep.samples_published.
    auto n = in.reader.take([](std::span<const std::byte>) {});
    if (n) lockstep.count_samples(*n);
    return;
  }
  const ObjectId topic = *in.topic;
  auto n = in.reader.take([&](std::span<const std::byte> bytes) {
    lockstep.count_samples(1);
    if (stopping) return;
    if (clock_mode == ClockMode::Realtime) {
      if (!booted) return;
      if (!clock_synced) sync_realtime_clock(bytes);
      router.publish_as_kernel(topic, bytes, Router::From::Bridge);
      return;
    }
    lockstep.stage_sample(index, bytes);
  });
  if (!n) log("DDS take %s: %s", in.reader.topic_name().c_str(), n.error().to_string().c_str());
}

void Kernel::Impl::sync_realtime_clock(std::span<const std::byte> first_sample) {
  // The plant stamps its samples with its own monotonic time since it started (idl/sensors.idl), which began
  // after the kernel's: move the kernel's origin so that both clocks agree from the first sample on (the
  // transport delay, microseconds, is not corrected). Timers keep their kernel-clock expiries.
  clock_synced = true;
  const auto stamp = dds::plant_topics::stamp_of(first_sample);
  if (!stamp) return;
  // Until now the kernel clock stood at 0 (no sensor data, no timer fired), so this only moves it forward.
  const Nanos plant_now = std::max(Nanos{static_cast<std::int64_t>(*stamp)}, now());
  run_start_mono = sys::monotonic_now() - plant_now;
  set_now(plant_now);
  arm_timerfd();
  log("realtime clock follows the plant's from t = %.3f s", to_seconds(plant_now).count());
}

void Kernel::Impl::fire_timers() {
  timers.fire_due(now(), [&](const clock::KernelTimer& t) {
    ServiceRuntime& s = services[t.service.value()];
    if (!s.live()) return;
    if (tx.build(wire::FrameKind::TimerFired, 0, 0, t.id)) router.send_control(s, tx.bytes());
  });
}

void Kernel::Impl::arm_timerfd() {
  if (!timerfd || !clock_synced) return;
  auto due = timers.next_due();
  if (const auto timer = rejuvenator.coordinator().timer_due()) due = due ? std::min(*due, *timer) : *timer;
  (void)timerfd->arm_at(due ? std::optional<Nanos>(*due + run_start_mono) : std::nullopt);
}

bool Kernel::Impl::all_idle() const {
  return std::all_of(services.begin(), services.end(), [](const ServiceRuntime& s) { return s.idle(); });
}

bool Kernel::Impl::all_ready() const {
  return std::all_of(services.begin(), services.end(),
                     [](const ServiceRuntime& s) { return s.config.skip || s.proc.phase() == Phase::Ready; });
}

std::optional<Nanos> Kernel::Impl::next_wall_deadline() const {
  std::optional<Nanos> best;
  const auto consider = [&](Nanos t) { best = best ? std::min(*best, t) : t; };
  for (const ServiceRuntime& s : services) {
    if (s.proc.booting()) consider(s.proc.spawned_at + options.boot_deadline);
    if (s.live() && s.proc.channel_closed_at) consider(*s.proc.channel_closed_at + kChannelCloseGrace);
  }
  if (const auto at = lockstep.steps().idle_deadline(options.idle_deadline))
    consider(supervisor.idle_look(*at));
  if (const auto at = lockstep.steps().stall_deadline(); supervisor.plant_started() && at) consider(*at);
  if (const auto at = rejuvenator.coordinator().work_deadline()) consider(*at);
  if (const auto at = rejuvenator.image_work_wait_deadline()) consider(*at);
  if (const auto at = input.next_resume()) consider(*at);
  return best;
}

// Real time: the catch-up's replay (catch_up.hpp). The world goes on meanwhile, so the replay is handed on as fast
// as the chain's channels take it — a few sampling instants per round, corked into one datagram per service, the
// next round once nothing waits for the chain on the kernel's side (the broker's rings hold 8 per topic) — and
// ends when the chain has handled all of it: each of its services is sent a Sync after its last frame and
// answers Idle. Live samples wait behind the replay and are released at its end.
void Kernel::Impl::pace_catch_up() {
  if (rejuvenator.catch_up().draining()) {
    drain_catch_up();
    return;
  }
  if (!rejuvenator.catch_up().replaying()) return;
  static constexpr int kInstantsPerRound = 4;
  // A reader that does not keep up (hung, or starved of the CPU) must not hold the controllers' estimates back:
  // past the kernel's bound the replay stops where it is, the estimator re-arms and the live samples go out.
  if (rejuvenator.catch_up().past_bound(wall(), CatchUp::kReplayBoundRealtime)) {
    cut_catch_up_short();
    drain_catch_up();
    return;
  }
  if (rejuvenator.catch_up().replay_pending()) {
    const bool keeping_up = std::all_of(services.begin(), services.end(), [&](const ServiceRuntime& s) {
      return !rejuvenator.catch_up().in_chain(s.id) || !s.live() || s.flow().drained();
    });
    if (!keeping_up) return;
    router.cork();
    for (int i = 0; i < kInstantsPerRound && rejuvenator.catch_up().replay_pending(); ++i)
      (void)lockstep.replay_instant();
    router.uncork();
    return;
  }
  if (chain_answered()) (void)lockstep.replay_instant();  // nothing left: the replay ends, the live samples go out
}

bool Kernel::Impl::chain_answered() {
  bool answered = true;
  for (ServiceRuntime& s : services) {
    if (!rejuvenator.catch_up().in_chain(s.id) || !s.live() || s.idle()) continue;
    answered = false;
    if (rejuvenator.catch_up_sync_due(s.id, s.flow().frames_issued())) (void)ask_idle(s);
  }
  return answered;
}

// The replay is past the kernel's bound (catch_up.hpp): the rest is skipped, the estimator told to re-arm from
// the live samples (CATCH_UP_REARM, ahead of them), and the live samples that waited go out.
void Kernel::Impl::cut_catch_up_short() {
  // Who held it up: each service of the chain not idle yet, with the frames it has not reported and whether
  // anything still waits on the kernel's side of its channel.
  std::string behind;
  for (const ServiceRuntime& s : services) {
    if (!rejuvenator.catch_up().in_chain(s.id) || !s.live() || s.idle()) continue;
    behind += (behind.empty() ? "" : ", ") + s.name + " (" +
              std::to_string(s.flow().frames_issued() - std::min(s.flow().frames_issued(), s.flow().reported())) +
              " frames unreported" + (s.flow().drained() ? "" : ", some not yet sent") + ")";
  }
  log("estimate catch-up cut short after %.1f ms (%llu samples replayed, %s): the chain did not keep up (%s); "
      "the estimator re-arms from the live samples",
      to_seconds(wall() - rejuvenator.catch_up().began_at()).count() * 1e3,
      static_cast<unsigned long long>(rejuvenator.catch_up().replayed()),
      rejuvenator.catch_up().replay_pending() ? "more to hand on" : "all handed on",
      behind.empty() ? "every service idle" : behind.c_str());
  rejuvenator.signal_catch_up(rejuv_msg_CATCH_UP_REARM);
  rejuvenator.cut_replay_short([&](ObjectId topic, std::span<const std::byte> bytes) {
    router.publish_as_kernel(topic, bytes, Router::From::Held);
  });
}

bool Kernel::Impl::ask_idle(ServiceRuntime& s) {
  if (!tx.build(wire::FrameKind::Sync, 0, 0, 0)) return false;
  router.send_control(s, tx.bytes());
  return true;
}

// Real time, after a cut: the chain may still be busy with the replay it was handed. It stays SCHED_OTHER (its
// RLIMIT_RTTIME does not count replay work) until each of its services has answered a Sync sent after its last
// frame; then its real-time plan is back, and slow live work is the violation it always is.
void Kernel::Impl::drain_catch_up() {
  if (chain_answered()) rejuvenator.catch_up_drained();
}

// The realtime clock (docs/design.md §6): the kernel clock is CLOCK_MONOTONIC since the run started (or the plant's,
// from its first sample); timers fire from the timerfd; progress is reported every 100 ms of it.
Result<void, KernelError> Kernel::Impl::run_realtime() {
  run_start_mono = sys::monotonic_now();
  clock_synced = !graph.graph.has_plant() || options.time_master != TimeMaster::Plant;
  set_now(Nanos{0});
  router.publish_sr_mode();
  router.flush_staged();  // anything published during boot
  lockstep.request_priming();
  arm_timerfd();
  supervisor.start_realtime_plan();  // realtime.cpp
  // While the kernel hands the estimate catch-up's replay on, the loop only looks for events: the replay goes on
  // as soon as it can. Once all of it is handed on, the loop waits for the chain's answers (its channels wake it)
  // until the replay's bound: the chain runs SCHED_OTHER during the replay, and this SCHED_FIFO loop spinning
  // meanwhile would hold a CPU the chain needs (docs/control.md §6.3).
  const auto wait = [this]() -> Nanos {
    const CatchUp& c = rejuvenator.catch_up();
    if (!c.replaying()) return std::chrono::milliseconds{100};
    if (c.replay_pending()) return Nanos{0};
    return std::clamp<Nanos>(c.began_at() + CatchUp::kReplayBoundRealtime - wall(), Nanos{0},
                             std::chrono::milliseconds{100});
  };
  while (!stop) {
    if (auto ok = pump(wait()); !ok) return ok;
    while (rejuvenator.service_images()) {
    }
    pace_catch_up();
    if (now() - last_progress >= std::chrono::milliseconds{100}) {
      last_progress = now();
      if (observer != nullptr) observer->on_step(lockstep.steps().steps_done(), now(), caps.mode());
      lockstep.count_realtime_progress();
      supervisor.keep_realtime_plan();
    }
    supervisor.watch_liveness();  // it keeps its own pace
    lockstep.check_stop_conditions();
  }
  return {};
}

}  // namespace rejuv::kernel
