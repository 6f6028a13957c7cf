// The kernel: creation (policy, audit, capability system, broker, time page, DDS bridge), the event loop
// and the clock (lockstep steps and realtime). Routing is in router.cpp, channel requests in requests.cpp,
// processes in supervisor.cpp.
#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdarg>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iterator>

#include "impl.hpp"
#include "rejuv/policy/audit.hpp"

namespace rejuv::kernel {

// ---- vocabulary ----

std::string_view to_string(ClockMode mode) {
  switch (mode) {
    case ClockMode::Lockstep: return "lockstep";
    case ClockMode::Realtime: return "realtime";
  }
  return "?";
}

std::string_view to_string(StopReason reason) {
  switch (reason) {
    case StopReason::MissionDone: return "mission completed";
    case StopReason::MissionTimeout: return "mission timeout";
    case StopReason::Duration: return "duration reached";
    case StopReason::Signal: return "signal";
    case StopReason::ServiceFailed: return "service failed";
    case StopReason::PlantExited: return "plant exited";
    case StopReason::Requested: return "stop requested";
  }
  return "?";
}

std::string_view to_string(ImagePhase phase) {
  switch (phase) {
    case ImagePhase::CheckpointSnapshotsSent: return "checkpoint:snapshots-sent";
    case ImagePhase::CheckpointTaken: return "checkpoint:taken";
    case ImagePhase::RollbackKilled: return "rollback:killed";
    case ImagePhase::RollbackResumesSent: return "rollback:resumes-sent";
  }
  return "?";
}

bool is_failure(StopReason reason) {
  switch (reason) {
    case StopReason::MissionDone:
    case StopReason::Duration:
    case StopReason::Signal:
    case StopReason::Requested: return false;
    case StopReason::MissionTimeout:
    case StopReason::ServiceFailed:
    case StopReason::PlantExited: return true;
  }
  return true;
}

namespace {
bool graceful(StopReason reason) {
  // These wait for the step in progress to be acknowledged; the others end the loop at once.
  switch (reason) {
    case StopReason::MissionDone:
    case StopReason::MissionTimeout:
    case StopReason::Duration:
    case StopReason::Requested: return true;
    case StopReason::Signal:
    case StopReason::ServiceFailed:
    case StopReason::PlantExited: return false;
  }
  return false;
}

std::string_view kind_name(KernelError::Kind kind) {
  switch (kind) {
    case KernelError::Kind::Policy: return "policy";
    case KernelError::Kind::Audit: return "policy audit failed";
    case KernelError::Kind::Config: return "configuration";
    case KernelError::Kind::Dds: return "DDS";
    case KernelError::Kind::System: return "system";
    case KernelError::Kind::Boot: return "boot";
  }
  return "?";
}

KernelError kernel_error(KernelError::Kind kind, std::string message) {
  return KernelError{.kind = kind, .message = std::move(message), .findings = {}};
}
}  // namespace

std::string KernelError::to_string() const {
  std::string out = std::string(kind_name(kind)) + ": " + message;
  for (const std::string& f : findings) out += "\n  " + f;
  return out;
}

bool KernelError::is_bad_input() const {
  // README "Exit codes": an audit finding is a verdict on a well-formed policy (exit 1, as `rejuv audit`
  // gives it), not a file the loader refused (exit 2).
  switch (kind) {
    case Kind::Policy:
    case Kind::Config: return true;
    case Kind::Audit:
    case Kind::Dds:
    case Kind::System:
    case Kind::Boot: return false;
  }
  return false;
}

// ---- creation ----

Result<std::unique_ptr<Kernel>, KernelError> Kernel::create(launch::LoadedLaunch graph, KernelOptions options,
                                                            Observer* observer) {
  using K = KernelError::Kind;
  auto policy = policy::load_policy(graph.policy_path);
  if (!policy) return fail(kernel_error(K::Policy, policy.error().to_string()));
  // DESIGN §4: the kernel refuses to start a graph whose policy fails the audit.
  if (const auto findings = policy::audit(*policy, graph); !findings.empty()) {
    KernelError e = kernel_error(K::Audit, std::to_string(findings.size()) + " finding(s) in " +
                                               graph.policy_path.string() + "; the kernel refuses to start");
    for (const policy::Finding& f : findings) e.findings.push_back(f.to_string());
    return fail(std::move(e));
  }
  const proto::Launch& g = graph.graph;
  const bool sr_requested = g.sr().enabled() && !options.no_sr;
  const ClockMode clock_mode =
      options.clock.value_or(g.clock() == proto::REALTIME ? ClockMode::Realtime : ClockMode::Lockstep);
  if (options.time_master == TimeMaster::Plant && clock_mode == ClockMode::Lockstep && !g.has_plant()) {
    return fail(kernel_error(K::Config, graph.path.string() + ": the graph has no plant; in lockstep nothing would keep time"));
  }
  if (options.time_master == TimeMaster::Manual && clock_mode == ClockMode::Realtime) {
    return fail(kernel_error(K::Config, "manual stepping needs the lockstep clock"));
  }

  // Capabilities: start in MC without SR (the mode never changes), in SC (safe) with it (DESIGN §7 Faults).
  const cap::ModeTable table = policy::compile(*policy);
  auto caps = cap::CapSystem::create(table, cap::CapSystemConfig{.cspace_slots = wire::kCSpaceSlots,
                                                                 .audit_capacity = 4096,
                                                                 .initial_mode = sr_requested ? SrMode::SC : SrMode::MC});
  if (!caps) return fail(kernel_error(K::Config, "capability table: " + caps.error().to_string()));

  // Objects and topics (one broker topic per policy Topic object, DESIGN §5).
  std::vector<ObjectInfo> objects;
  std::vector<broker::TopicConfig> topics;
  // The policy's own topic types (`types`, SDK rejuv_add_topics): no DDS descriptor. Reserved whole, so that
  // the ObjectInfo pointers into it stay valid (the vector moves into the kernel with its buffer).
  std::vector<msgs::TopicType> declared_types;
  declared_types.reserve(policy->types().size());
  for (const policy::DeclaredType& t : policy->types()) {
    declared_types.push_back(msgs::TopicType{.name = t.name, .size = t.size_bytes, .align = t.align_bytes, .descriptor = nullptr});
  }
  const auto topic_type = [&](std::string_view name) -> const msgs::TopicType* {
    if (const msgs::TopicType* t = msgs::find_topic_type(name)) return t;
    const auto it = std::find_if(declared_types.begin(), declared_types.end(),
                                 [&](const msgs::TopicType& t) { return t.name == name; });
    return it == declared_types.end() ? nullptr : &*it;
  };
  for (const policy::Object& o : policy->objects()) {
    ObjectInfo info{.id = o.id, .name = o.name, .kind = o.kind, .type = nullptr, .kernel = o.kernel,
                    .is_setpoint = false, .is_actuator_outputs = false, .persistent = {}, .limits = {}};
    if (o.kind == ObjectKind::Topic) {
      info.type = topic_type(o.type);
      if (info.type == nullptr) {
        return fail(kernel_error(K::Config, o.where.to_string() + ": topic '" + o.name + "' has type '" + o.type +
                                                "', which is neither a topic type of idl/ nor declared in the policy's `types`"));
      }
      info.is_setpoint = info.type->name == msgs::TopicTraits<rejuv_msg_Setpoint>::name;
      info.is_actuator_outputs = info.type->name == msgs::TopicTraits<rejuv_msg_ActuatorOutputs>::name;
      topics.push_back(broker::TopicConfig{.object = o.id, .name = o.name, .payload_size = info.type->size,
                                           .depth = o.queue_depth == 0 ? policy::kDefaultQueueDepth : o.queue_depth});
    }
    if (o.kind == ObjectKind::Persistent) info.persistent.assign(o.size_bytes, std::byte{0});
    objects.push_back(std::move(info));
  }
  auto broker = broker::Broker::create(topics);
  if (!broker) return fail(kernel_error(K::Config, "broker: " + broker.error().to_string()));

  // Signals first: Cyclone's threads (started by the bridge below) must inherit the blocked mask.
  auto signals = sys::SignalFd::create({SIGINT, SIGTERM});
  if (!signals) return fail(kernel_error(K::System, signals.error().to_string()));
  auto page = clock::TimePageWriter::create();
  if (!page) return fail(kernel_error(K::System, "time page: " + page.error().to_string()));
  auto epoll = sys::Epoll::create();
  if (!epoll) return fail(kernel_error(K::System, epoll.error().to_string()));
  // Built before any fork (libseccomp allocates); loaded in each child between fork and exec.
  auto seccomp = sys::SeccompProgram::service_policy(sys::Enforcement::Supervised);
  if (!seccomp) return fail(kernel_error(K::System, "seccomp: " + seccomp.error().to_string()));

  const std::size_t service_count = policy->services().size();
  {
    // File descriptors (issue 19: exhaustion reported, not met in flight): each process the kernel watches
    // holds a few (channel, pidfd, output pipe, seccomp listener), and each generation of images a resume
    // socket and the pidfds of an image and its spare per service. Measured: 131 at K = 2 and 456 at K = 16
    // for the square's 9 services and the plant; this bound is above both.
    const std::uint64_t generations = launch::keep_generations(graph.graph.sr()) + 1;  // + the one being taken
    const std::uint64_t wanted = 40 + 8 * (service_count + 1) + 3 * service_count * generations;
    auto limit = sys::ensure_open_files(wanted);
    if (!limit) return fail(kernel_error(K::System, limit.error().to_string()));
    if (*limit < wanted) {
      return fail(kernel_error(K::System, "keep_generations " + std::to_string(generations - 1) + " with " +
                                              std::to_string(service_count) + " services needs about " +
                                              std::to_string(wanted) + " file descriptors; this process may open " +
                                              std::to_string(*limit) + " (ulimit -n): raise the limit or lower keep_generations"));
    }
  }
  // Service uids of their own (docs/sandbox.md), not shared with another kernel of this machine.
  std::optional<sys::Lease> uid_block;
  if (sys::running_as_root()) {
    if (service_count > sys::kUidsPerBlock) {
      return fail(kernel_error(K::Config, std::to_string(service_count) + " services: a kernel runs at most " +
                                              std::to_string(sys::kUidsPerBlock) + " (one uid each)"));
    }
    auto block = sys::lease_uid_block(static_cast<std::uint32_t>(::getpid()));
    if (!block) return fail(kernel_error(K::System, "a block of service uids: " + block.error().to_string()));
    uid_block.emplace(std::move(*block));
  }
  auto impl = std::make_unique<Impl>(std::move(graph), std::move(options), observer, std::move(*policy),
                                     std::move(*caps), std::move(*broker), std::move(*page), service_count,
                                     std::move(*epoll));
  Impl& k = *impl;
  k.declared_types = std::move(declared_types);
  if (uid_block) k.service_uid_base = sys::kServiceUidBase + uid_block->slot() * sys::kUidsPerBlock;
  k.uid_block = std::move(uid_block);
  k.objects = std::move(objects);
  k.clock_mode = clock_mode;
  k.sr = sr_requested;
  k.images = image::ImageStore(launch::keep_generations(k.graph.graph.sr()));
  k.seed = k.options.seed.value_or(k.graph.graph.seed());
  const proto::LockstepTiming& timing = k.graph.graph.lockstep();
  k.checkpoint_charge = std::chrono::round<Nanos>(launch::checkpoint_charge(timing));
  k.rollback_charge = std::chrono::round<Nanos>(launch::rollback_charge(timing));
  // The plant aligns (held at rest) before the mission's t = 0; without a plant there is no alignment.
  if (k.options.time_master == TimeMaster::Plant && k.graph.graph.has_plant()) {
    k.flight_start = std::chrono::round<Nanos>(launch::alignment(timing));
  }
  k.domain = k.options.dds_domain.value_or(k.graph.graph.dds().domain_id());
  k.signals.emplace(std::move(*signals));
  k.seccomp = std::move(*seccomp);
  k.time_page.write(clock::TimeSample{.now = Nanos{0}, .mode = k.caps.mode(), .epoch = Epoch{0}});
  k.caps.set_time(Nanos{0});

  // Services, by policy order (ServiceId = policy declaration order = CSpace index).
  const std::filesystem::path service_dir = k.options.service_dir;
  for (const policy::Service& ps : k.policy.services()) {
    ServiceRuntime s;
    s.id = ps.id;
    s.name = ps.name;
    s.stats.name = ps.name;
    s.spec = launch::find_service(k.graph.graph, ps.name);
    REJUV_ASSERT(s.spec != nullptr, "the audit checked that every policy service is in the graph");
    s.rejuvenate = launch::rejuvenate(*s.spec);
    if (std::find(k.options.skip_services.begin(), k.options.skip_services.end(), ps.name) != k.options.skip_services.end()) {
      s.skip = true;
      s.skip_reason = "skipped on request";
    } else if (ps.rejuvenation && !k.sr) {
      s.skip = true;
      s.skip_reason = "the rejuvenation service has nothing to do without SR";
    }
    const std::filesystem::path exe(s.spec->executable());
    s.executable = (exe.is_absolute() ? exe : service_dir / exe).string();
    if (!s.skip) {
      std::error_code ec;
      if (!std::filesystem::is_regular_file(s.executable, ec)) {
        int index = 0;
        const proto::Launch& graph_now = k.graph.graph;  // `g` was moved into k
        while (index < graph_now.services_size() && graph_now.services(index).name() != s.name) ++index;
        return fail(kernel_error(K::Config, k.graph.locations.locate({{"services", index}}, "executable").to_string() +
                                                ": error: service '" + s.name + "': executable " + s.executable +
                                                " not found (not built yet? skip it with --skip " + s.name + ")"));
      }
    }
    auto boot = k.caps.boot_info(s.id);
    REJUV_ASSERT(boot.has_value(), "every policy service has boot info");
    s.boot = std::move(*boot);
    s.control_pool.reserve(kControlPoolCapacity);
    s.held.reserve(wire::kMaxFrameBytes);
    k.services.push_back(std::move(s));
  }
  for (ServiceRuntime& s : k.services) s.params = build_params(k, s);

  if (k.options.time_master == TimeMaster::Plant && k.graph.graph.has_plant()) {
    std::error_code ec;
    const std::filesystem::path exe(k.graph.graph.plant().executable());
    const std::filesystem::path path = exe.is_absolute() ? exe : service_dir / exe;
    if (!std::filesystem::is_regular_file(path, ec)) {
      return fail(kernel_error(K::Config, k.graph.locations.locate({{"plant", -1}}, "executable").to_string() +
                                              ": error: plant executable " + path.string() + " not found (not built yet?)"));
    }
  }

  // DDS bridge (DESIGN §5): Cyclone reads CYCLONEDDS_URI; default to the graph's config file.
  std::vector<BridgeSpec> bridges;
  for (int i = 0; i < k.graph.graph.dds().bridges_size(); ++i) {
    const proto::Bridge& b = k.graph.graph.dds().bridges(i);
    const auto object = k.policy.find_object(b.topic());
    REJUV_ASSERT(object.has_value(), "the audit checked that every bridge names a topic");
    if (k.objects[object->value()].type->descriptor == nullptr) {
      return fail(kernel_error(K::Config, k.graph.locations.locate({{"dds", -1}, {"bridges", i}}, "topic").to_string() +
                                              ": error: topic '" + b.topic() + "' is of the policy's own type '" +
                                              std::string(k.objects[object->value()].type->name) +
                                              "', which has no DDS type descriptor: such a topic is routed between services, not bridged"));
    }
    bridges.push_back(BridgeSpec{.topic = *object, .dds_name = launch::dds_name(b),
                                 .type = k.objects[object->value()].type,
                                 .inbound = b.direction() == proto::BRIDGE_IN});
  }
  // Before the bridge: Cyclone's threads, the services and the plant inherit the CPU mask (KernelOptions).
  using Placement = KernelOptions::Placement;
  const Placement placement = k.options.placement;
  if (placement == Placement::Cpu || (placement == Placement::Auto && clock_mode == ClockMode::Lockstep)) {
    auto cpu = sys::pin_to_one_cpu(placement == Placement::Cpu ? std::optional<int>(k.options.cpu) : std::nullopt);
    if (!cpu && placement == Placement::Cpu && cpu.error().error == EINVAL) {
      return fail(kernel_error(K::Config, "CPU " + std::to_string(k.options.cpu) + " is not available to this process"));
    }
    if (!cpu) return fail(kernel_error(K::System, "pinning to one CPU: " + cpu.error().to_string()));
    k.pinned_cpu = *cpu;
  }
  const bool plant_lockstep = k.options.time_master == TimeMaster::Plant && clock_mode == ClockMode::Lockstep;
  if (!bridges.empty() || plant_lockstep) {
    if (std::getenv("CYCLONEDDS_URI") == nullptr) {
      const std::string uri = "file://" + launch::dds_config(k.graph, k.options.repo_root).string();
      ::setenv("CYCLONEDDS_URI", uri.c_str(), 0);  // also what the plant inherits
    }
    auto bridge = DdsBridge::open(k.domain, bridges, plant_lockstep, k.objects.size());
    if (!bridge) return fail(kernel_error(K::Dds, bridge.error()));
    k.bridge = std::move(*bridge);
  }

  // Event sources.
  const auto add = [&](int fd, std::uint64_t tok) -> Result<void, KernelError> {
    if (auto ok = k.epoll.add(fd, tok); !ok) return fail(kernel_error(K::System, ok.error().to_string()));
    return {};
  };
  if (auto ok = add(k.signals->fd(), token(Source::Signal, 0)); !ok) return fail(ok.error());
  if (clock_mode == ClockMode::Realtime) {
    auto tfd = sys::TimerFd::create();
    if (!tfd) return fail(kernel_error(K::System, tfd.error().to_string()));
    k.timerfd = std::move(*tfd);
    if (auto ok = add(k.timerfd->fd(), token(Source::Timer, 0)); !ok) return fail(ok.error());
  }
  if (k.bridge) {
    for (std::size_t i = 0; i < k.bridge->readers().size(); ++i) {
      // Lockstep with the plant: the samples of a step are taken when its SimStep arrives (they were
      // published before it), so only the step reader wakes the kernel — one wakeup per step, not per sample.
      if (plant_lockstep && k.bridge->readers()[i].role != DdsBridge::Role::Step) {
        k.bridge->readers()[i].reader.set_signalling(false);  // until a step is short of samples
        continue;
      }
      if (auto ok = add(k.bridge->readers()[i].reader.ready_fd(), token(Source::Dds, i)); !ok) return fail(ok.error());
    }
  }
  k.samples_on_step = plant_lockstep;
  if (auto ok = k.net_open(); !ok) return fail(ok.error());  // the network gate (netgate.cpp)
  return std::unique_ptr<Kernel>(new Kernel(std::move(impl)));
}

Kernel::Kernel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Kernel::~Kernel() { shutdown(); }

// ---- logging and time ----

void Kernel::Impl::log(const char* format, ...) {
  if (options.log == nullptr && observer == nullptr) return;
  std::array<char, 2048> buf{};
  va_list args;
  va_start(args, format);
  std::vsnprintf(buf.data(), buf.size(), format, args);
  va_end(args);
  if (observer != nullptr) {
    observer->on_log(LogLine{.t = now(), .source = "kernel", .level = LogLine::Level::Info, .text = buf.data()});
  }
  if (options.log == nullptr) return;
  std::fprintf(options.log, "[kernel %8.3f] %s\n", to_seconds(now()).count(), buf.data());
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

void Kernel::Impl::service_log(ServiceRuntime& s, wire::LogLevel level, std::string_view text) {
  if (level == wire::LogLevel::Error) s.last_error.assign(text);  // kept even when the line is rate-limited
  if (level == wire::LogLevel::Debug && !options.verbose) return;
  if (!s.limiter.allow(wall())) {
    ++s.stats.log_suppressed;
    ++s.limiter.suppressed_since_print;
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
  if (s.limiter.suppressed_since_print > 0) {
    std::fprintf(options.log, "[%s] (%llu lines suppressed by the rate limit)\n", s.name.c_str(),
                 static_cast<unsigned long long>(s.limiter.suppressed_since_print));
    s.limiter.suppressed_since_print = 0;
  }
  const char* tag = "";
  switch (level) {
    case wire::LogLevel::Debug: tag = "debug: "; break;
    case wire::LogLevel::Info: break;
    case wire::LogLevel::Warn: tag = "warning: "; break;
    case wire::LogLevel::Error: tag = "error: "; break;
  }
  std::fprintf(options.log, "[%s] %s%.*s\n", s.name.c_str(), tag, static_cast<int>(text.size()), text.data());
}

void Kernel::Impl::refuse(ServiceRuntime& s, std::string_view what) {
  ++s.stats.bad_frames;
  ++kernel_bad_frames;
  if (s.limiter.allow(wall())) {
    log("refused a frame from '%s': %.*s", s.name.c_str(), static_cast<int>(what.size()), what.data());
  } else {
    ++s.stats.log_suppressed;
  }
}

void Kernel::Impl::set_now(Nanos t) {
  time_page.set_now(t);
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
        if (!s.live() || !s.channel.valid()) break;
        if (e.writable) drain(s);
        if (e.readable || e.hangup || e.error) read_channel(s);
        break;
      }
      case Source::Pidfd: on_child_exit(services[index]); break;
      case Source::Plant: on_plant_exit(); break;
      case Source::Signal: {
        auto sig = signals->read();
        if (sig && *sig) stop_run(StopReason::Signal, *sig == SIGINT ? "SIGINT" : "SIGTERM");
        break;
      }
      case Source::Timer:
        (void)timerfd->consume();
        fire_rejuvenation();
        fire_timers();
        arm_timerfd();
        break;
      case Source::Dds: on_dds_ready(index); break;
      case Source::Net: net_poll(); break;  // realtime only; lockstep polls at the start of a step
      case Source::Seccomp: {
        ServiceRuntime& s = services[index];
        on_seccomp_notice(s);
        // No process uses the filter any more (the service and its images are gone): nothing more can come.
        if (e.hangup && !e.readable && s.seccomp.valid()) {
          (void)epoll.remove(s.seccomp.fd());
          s.seccomp.close();
        }
        break;
      }
      case Source::Output: on_service_output(services[index]); break;
    }
  }
  drain_denials();
  check_deadlines();
  return {};
}

void Kernel::Impl::on_dds_ready(std::size_t index) {
  if (!bridge) return;
  DdsBridge::In& in = bridge->readers()[index];
  switch (in.role) {
    case DdsBridge::Role::Step: {
      auto n = in.reader.take_as<rejuv_msg_SimStep>([&](const rejuv_msg_SimStep& step) {
        pending_steps.push_back(PendingStep{.step = step.step,
                                            .t = Nanos{static_cast<std::int64_t>(step.time_ns)},
                                            .samples_needed = step.samples_published});
        stage_step_samples(step);
      });
      if (!n) log("DDS take sim_step: %s", n.error().to_string().c_str());
      if (samples_on_step && n && *n > 0) collect_samples();
      break;
    }
    case DdsBridge::Role::CountOnly: {
      auto n = in.reader.take([](std::span<const std::byte>) {});
      if (n) samples_received += *n;
      break;
    }
    case DdsBridge::Role::Sample: {
      const ObjectId topic = *in.topic;
      auto n = in.reader.take([&](std::span<const std::byte> bytes) {
        ++samples_received;
        if (stopping) return;
        if (clock_mode == ClockMode::Realtime) {
          if (!booted) return;
          if (!clock_synced) sync_realtime_clock(bytes);
          publish_as_kernel(topic, bytes, From::Bridge);
          return;
        }
        stage_sample(index, bytes);
      });
      if (!n) log("DDS take %s: %s", in.reader.topic_name().c_str(), n.error().to_string().c_str());
      break;
    }
  }
}

// Lockstep: a sample is held for the step that covers it, then routed in canonical order (route_samples).
void Kernel::Impl::stage_sample(std::size_t reader, std::span<const std::byte> bytes) {
  std::uint64_t stamp = 0;
  if (bytes.size() >= sizeof(stamp)) std::memcpy(&stamp, bytes.data(), sizeof(stamp));
  samples.push_back(StagedSample{.reader = static_cast<std::uint32_t>(reader), .timestamp = stamp,
                                 .offset = static_cast<std::uint32_t>(sample_bytes.size()),
                                 .size = static_cast<std::uint32_t>(bytes.size())});
  sample_bytes.insert(sample_bytes.end(), bytes.begin(), bytes.end());
}

// The samples a SimStep carries (idl/sim.idl), staged as if the reader that bridges their topic had taken
// them: the same canonical order as samples that came on their own topics, and the same routes.
void Kernel::Impl::stage_step_samples(const rejuv_msg_SimStep& step) {
  if (stopping) return;
  const DdsBridge::StepReaders& r = bridge->step_readers();
  const auto stage_all = [&](int reader, const auto& array, std::uint8_t count) {
    if (reader < 0) return;  // not bridged: dropped, as the count-only readers drop theirs
    for (std::size_t i = 0; i < std::min<std::size_t>(count, std::size(array)); ++i) {
      stage_sample(static_cast<std::size_t>(reader), std::as_bytes(std::span(&array[i], 1)));
    }
  };
  stage_all(r.gyro, step.gyro, step.gyro_count);
  stage_all(r.accel, step.accel, step.accel_count);
  stage_all(r.mag, step.mag, step.mag_count);
  stage_all(r.baro, step.baro, step.baro_count);
  stage_all(r.gps, step.gps, step.gps_count);
  if (r.ground_truth >= 0) {
    stage_sample(static_cast<std::size_t>(r.ground_truth), std::as_bytes(std::span(&step.ground_truth, 1)));
  }
}

void Kernel::Impl::sync_realtime_clock(std::span<const std::byte> first_sample) {
  // The plant stamps its samples with its own monotonic time since it started (idl/sensors.idl), which began
  // after the kernel's: move the kernel's origin so that both clocks agree from the first sample on (the
  // transport delay, microseconds, is not corrected). Timers keep their kernel-clock expiries.
  clock_synced = true;
  std::uint64_t stamp = 0;
  if (first_sample.size() < sizeof(stamp)) return;
  std::memcpy(&stamp, first_sample.data(), sizeof(stamp));
  // Until now the kernel clock stood at 0 (no sensor data, no timer fired), so this only moves it forward.
  const Nanos plant_now = std::max(Nanos{static_cast<std::int64_t>(stamp)}, now());
  run_start_mono = sys::monotonic_now() - plant_now;
  set_now(plant_now);
  arm_timerfd();
  log("realtime clock follows the plant's from t = %.3f s", to_seconds(plant_now).count());
}

void Kernel::Impl::collect_samples() {
  if (!bridge) return;
  for (std::size_t i = 0; i < bridge->readers().size(); ++i) {
    if (bridge->readers()[i].role != DdsBridge::Role::Step) on_dds_ready(i);
  }
}

void Kernel::Impl::watch_sample_readers(bool watch) {
  if (!bridge || !samples_on_step || watch == watching_samples) return;
  watching_samples = watch;
  for (std::size_t i = 0; i < bridge->readers().size(); ++i) {
    if (bridge->readers()[i].role == DdsBridge::Role::Step) continue;
    dds::Reader& reader = bridge->readers()[i].reader;
    reader.set_signalling(watch);  // on before the fd is watched; the collect_samples below takes the rest
    if (watch) {
      (void)epoll.add(reader.ready_fd(), token(Source::Dds, i));
    } else {
      (void)epoll.remove(reader.ready_fd());
    }
  }
  if (watch) collect_samples();
}

void Kernel::Impl::fire_timers() {
  timers.fire_due(now(), [&](const clock::KernelTimer& t) {
    ServiceRuntime& s = services[t.service.value()];
    if (!s.live()) return;
    if (tx.build(wire::FrameKind::TimerFired, 0, 0, t.id)) send_control(s, tx.bytes());
  });
}

void Kernel::Impl::arm_timerfd() {
  if (!timerfd || !clock_synced) return;
  auto due = timers.next_due();
  if (rejuvenation.due) due = due ? std::min(*due, *rejuvenation.due) : *rejuvenation.due;
  (void)timerfd->arm_at(due ? std::optional<Nanos>(*due + run_start_mono) : std::nullopt);
}

bool Kernel::Impl::all_idle() const {
  return std::all_of(services.begin(), services.end(), [](const ServiceRuntime& s) { return s.idle(); });
}

bool Kernel::Impl::all_ready() const {
  return std::all_of(services.begin(), services.end(),
                     [](const ServiceRuntime& s) { return s.skip || s.phase == Phase::Ready; });
}

std::optional<Nanos> Kernel::Impl::next_wall_deadline() const {
  std::optional<Nanos> best;
  const auto consider = [&](Nanos t) { best = best ? std::min(*best, t) : t; };
  for (const ServiceRuntime& s : services) {
    if (s.phase == Phase::Spawned || s.phase == Phase::Booted) consider(s.spawned_at + options.boot_deadline);
    if (s.live() && s.channel_closed_at) consider(*s.channel_closed_at + kChannelCloseGrace);
  }
  if (active_step) consider(step_started_wall + options.idle_deadline);
  if (plant_started && !stall_reported && last_step_done_wall > Nanos{0}) consider(last_step_done_wall + std::chrono::seconds{3});
  return best;
}

void Kernel::Impl::begin_step(const PendingStep& step) {
  active_step = step;
  rounds = 0;
  step_started_wall = wall();
  hung_this_step.clear();
  for (ServiceRuntime& s : services) s.staged_this_step = 0;
  set_now(step.t);
  if (!sr_mode_announced) publish_sr_mode();
  request_priming();
  fire_rejuvenation();  // DESIGN §7: a due rejuvenation timer rolls back before anything else of the step
  (void)service_images();
  // DESIGN §6: set the clock, fire due timers, route the step's samples; then rounds until idle. Each
  // service gets the round's frames in one batch (router.cpp, cork).
  cork();
  fire_timers();
  route_samples();
  uncork();
  net_poll();  // datagrams that arrived before the step: handed over at its start (netgate.cpp)
}

bool Kernel::Impl::advance_step() {
  for (;;) {
    if (service_images()) continue;  // a pending rollback, or a checkpoint once quiescent (images.cpp)
    if (!all_idle()) return false;
    if (rounds >= kMaxRoundsPerStep) {
      log("step %llu did not settle after %u routing rounds; ending it", static_cast<unsigned long long>(active_step->step),
          rounds);
      return true;
    }
    if (!staged.empty()) {
      ++rounds;
      cork();
      flush_staged();
      uncork();
      continue;
    }
    // Timers armed during this step that are already due (e.g. after(0)).
    if (timers.next_due() && *timers.next_due() <= now()) {
      ++rounds;
      cork();
      fire_timers();
      uncork();
      continue;
    }
    return true;
  }
}

void Kernel::Impl::finish_step() {
  const PendingStep step = *active_step;
  active_step.reset();
  ++steps_done;
  if (bridge && bridge->has_step_reader() && options.time_master == TimeMaster::Plant) {
    if (auto ok = bridge->write_ack(step.step, static_cast<std::uint64_t>(step.t.count()),
                                    static_cast<std::uint64_t>(charge.count()));  // DESIGN §6
        !ok) {
      log("%s", ok.error().c_str());
      stop_run(StopReason::PlantExited, ok.error());
    }
  }
  charge = Nanos{0};
  last_step_done_wall = wall();
  stall_reported = false;
  if (observer != nullptr) observer->on_step(step.step, step.t, caps.mode());
  check_stop_conditions();
}

// DESIGN §6: the first images of every service are forked during the alignment, untimed, so that the
// checkpoints of the flight all take theirs by written pages. Once, at the first step of a run with a plant
// (lockstep or realtime); never in manual stepping, whose tests count their generations.
void Kernel::Impl::request_priming() {
  if (primed || !sr || options.time_master != TimeMaster::Plant || !graph.graph.has_plant() || checkpoint_request ||
      rollback_request) {
    return;
  }
  primed = true;
  priming_request = true;
  checkpoint_request = std::pair(std::optional<ServiceId>{}, std::uint32_t{0});
}

void Kernel::Impl::check_stop_conditions() {
  if (options.duration && now() >= *options.duration) {
    stop_run(StopReason::Duration, "t = " + std::to_string(to_seconds(now()).count()) + " s");
  }
  const Seconds timeout = launch::mission_timeout(graph.graph.mission());  // of the flight, after the alignment
  if (timeout.count() > 0 && now() >= flight_start + to_nanos(timeout)) {
    stop_run(StopReason::MissionTimeout, "mission not completed within " + std::to_string(timeout.count()) + " s");
  }
}

// ---- public API ----

Result<void, KernelError> Kernel::boot() {
  Impl& k = *impl_;
  if (k.booted) return {};
  if (k.shut_down) return fail(kernel_error(KernelError::Kind::Boot, "the kernel has been shut down"));
  k.wall_start = k.wall();
  for (const ServiceRuntime& s : k.services) {
    if (s.skip) k.log("not starting '%s': %s", s.name.c_str(), s.skip_reason.c_str());
  }
  if (auto ok = k.spawn_all(); !ok) {
    k.shutdown_all();
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
        if (!s.skip && s.phase != Phase::Ready) waiting += (waiting.empty() ? "'" : ", '") + s.name + "'";
      }
      k.stop_run(StopReason::ServiceFailed, "the graph did not boot within " +
                                                std::to_string(to_seconds(k.options.boot_deadline).count()) +
                                                " s; not ready: " + waiting);
      break;
    }
    if (auto ok = k.pump(boot_limit - k.wall()); !ok) {
      k.shutdown_all();
      return ok;
    }
  }
  if (k.stop) {
    KernelError e = kernel_error(KernelError::Kind::Boot, k.stop_detail.empty() ? std::string(to_string(*k.stop)) : k.stop_detail);
    k.shutdown_all();
    return fail(std::move(e));
  }
  k.booted = true;
  const std::string where = k.pinned_cpu ? ", on CPU " + std::to_string(*k.pinned_cpu) : std::string();
  k.log("%zu services ready (%s clock%s%s)", static_cast<std::size_t>(std::count_if(
                                                 k.services.begin(), k.services.end(),
                                                 [](const ServiceRuntime& s) { return !s.skip; })),
        std::string(to_string(k.clock_mode)).c_str(), k.sr ? ", SR on" : ", SR off", where.c_str());
  if (k.options.time_master == TimeMaster::Plant && k.graph.graph.has_plant()) {
    if (auto ok = k.spawn_plant(); !ok) {
      k.shutdown_all();
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
  const std::uint64_t target = k.steps_done + 1;
  k.pending_steps.push_back(PendingStep{.step = k.next_manual_step++, .t = t, .samples_needed = 0});
  StepReport report;
  std::uint32_t rounds = 0;
  while (k.steps_done < target) {
    if (k.stop && !graceful(*k.stop) && !k.active_step) break;
    if (!k.active_step && !k.pending_steps.empty()) {
      const PendingStep next = k.pending_steps.front();
      k.pending_steps.erase(k.pending_steps.begin());
      k.begin_step(next);
      report.step = next.step;
      report.t = next.t;
    }
    if (k.active_step && k.advance_step()) {
      rounds = k.rounds;
      report.hung = k.hung_this_step;
      k.finish_step();
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
  switch (k.clock_mode) {
    case ClockMode::Lockstep:
      for (;;) {
        if (k.stop && (!graceful(*k.stop) || !k.active_step)) break;
        // A sample DDS never delivers must not stall the run: after a second the step goes on without it
        // (logged; the counts are re-synchronised so that the next steps do not wait for it either).
        if (!k.active_step && !k.pending_steps.empty() && k.samples_received < k.pending_steps.front().samples_needed) {
          if (!k.short_of_samples_since) k.short_of_samples_since = k.wall();
          if (k.wall() - *k.short_of_samples_since > std::chrono::seconds{1}) {
            k.log("step %llu: %llu sensor sample(s) never arrived; the step goes on without them",
                  static_cast<unsigned long long>(k.pending_steps.front().step),
                  static_cast<unsigned long long>(k.pending_steps.front().samples_needed - k.samples_received));
            k.samples_received = k.pending_steps.front().samples_needed;
          }
        }
        if (!k.active_step && !k.pending_steps.empty() && !k.stop &&
            k.samples_received >= k.pending_steps.front().samples_needed) {
          k.short_of_samples_since.reset();
          const PendingStep next = k.pending_steps.front();
          k.pending_steps.erase(k.pending_steps.begin());
          k.begin_step(next);
        }
        if (k.active_step && k.advance_step()) {
          k.finish_step();
          continue;  // the next step may already be waiting
        }
        // A step whose samples are not all in yet (DDS orders per writer only): wake on the sample readers
        // too until they are.
        const bool short_of_samples = !k.active_step && !k.pending_steps.empty() &&
                                      k.samples_received < k.pending_steps.front().samples_needed;
        k.watch_sample_readers(short_of_samples);
        if (auto ok = k.pump(short_of_samples ? std::optional<Nanos>(std::chrono::milliseconds{100}) : std::nullopt); !ok) {
          k.shutdown_all();
          return fail(ok.error());
        }
      }
      break;
    case ClockMode::Realtime: {
      k.run_start_mono = sys::monotonic_now();
      k.clock_synced = !k.graph.graph.has_plant() || k.options.time_master != TimeMaster::Plant;
      k.set_now(Nanos{0});
      k.publish_sr_mode();
      k.flush_staged();  // anything published during boot
      k.request_priming();
      k.arm_timerfd();
      std::uint64_t ticks = 0;
      while (!k.stop) {
        if (auto ok = k.pump(std::chrono::milliseconds{100}); !ok) {
          k.shutdown_all();
          return fail(ok.error());
        }
        while (k.service_images()) {
        }
        if (k.now() - k.last_progress >= std::chrono::milliseconds{100}) {
          k.last_progress = k.now();
          if (k.observer != nullptr) k.observer->on_step(ticks++, k.now(), k.caps.mode());
        }
        k.check_stop_conditions();
      }
      k.steps_done = ticks;
      break;
    }
  }
  RunOutcome outcome{.reason = k.stop.value_or(StopReason::Requested),
                     .detail = k.stop_detail,
                     .steps = k.steps_done,
                     .sim_time = k.now(),
                     .wall_time = k.wall() - k.wall_start};
  shutdown();
  return outcome;
}

void Kernel::shutdown() { impl_->shutdown_all(); }

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
  k.publish_as_kernel(*object, payload, Impl::From::Bridge);
  return {};
}

std::optional<StopReason> Kernel::stop_reason() const { return impl_->stop; }
const std::string& Kernel::stop_detail() const { return impl_->stop_detail; }
Nanos Kernel::now() const { return impl_->now(); }
SrMode Kernel::mode() const { return impl_->caps.mode(); }
ClockMode Kernel::clock_mode() const { return impl_->clock_mode; }
bool Kernel::sr_enabled() const { return impl_->sr; }
const cap::CapSystem& Kernel::caps() const { return impl_->caps; }
const broker::Broker& Kernel::broker() const { return impl_->broker; }
std::size_t Kernel::service_count() const { return impl_->services.size(); }
const launch::LoadedLaunch& Kernel::graph() const { return impl_->graph; }
std::vector<Kernel::TopicInfo> Kernel::topics() const {
  std::vector<TopicInfo> out;
  for (const ObjectInfo& o : impl_->objects) {
    if (o.kind == ObjectKind::Topic && o.type != nullptr) out.push_back({.id = o.id, .name = o.name, .type = o.type->name});
  }
  return out;
}
std::uint64_t Kernel::bad_frames_total() const { return impl_->kernel_bad_frames; }
const SrStats& Kernel::sr_stats() const { return impl_->sr_stats; }

Result<Generation, KernelError> Kernel::checkpoint_now() {
  Impl& k = *impl_;
  if (!k.sr || !k.booted || k.active_step || k.checkpoint_request) {
    return fail(kernel_error(KernelError::Kind::Config, "checkpoint_now: needs SR on, a booted kernel and no step in progress"));
  }
  const std::uint64_t before = k.sr_stats.checkpoints;
  k.checkpoint_request = std::pair(std::optional<ServiceId>{}, std::uint32_t{0});
  if (auto ok = k.settle_images(); !ok) return fail(ok.error());
  if (k.sr_stats.checkpoints == before) return fail(kernel_error(KernelError::Kind::Boot, "the checkpoint was abandoned"));
  return k.images.newest()->g;
}

Result<void, KernelError> Kernel::rollback_now(bool cold) {
  Impl& k = *impl_;
  if (!k.sr || !k.booted || k.active_step) {
    return fail(kernel_error(KernelError::Kind::Config, "rollback_now: needs SR on, a booted kernel and no step in progress"));
  }
  if (cold) {
    k.cold_restart("requested");
    return {};
  }
  k.request_rollback("requested");
  return k.settle_images();
}
Epoch Kernel::epoch() const { return impl_->time_page.current().epoch; }
Nanos Kernel::flight_start() const { return impl_->flight_start; }
void Kernel::settle_images() {
  Impl& k = *impl_;
  const Nanos deadline = k.wall() + std::chrono::milliseconds{500};
  for (;;) {
    k.images.refresh_all();
    k.finish_retiring(false);
    bool pending = !k.retiring.empty();
    if (k.images.spares_pending() > 0) pending = true;
    if (!pending || k.wall() > deadline) break;
    (void)sys::wait_fd(k.epoll.fd(), sys::WaitFor::Readable, std::chrono::milliseconds{1});
  }
  k.kill_retired();
  for (sys::ChildProcess& p : k.reaping) p.kill_and_reap();
  k.reaping.clear();
}

std::vector<int> Kernel::image_pids(ServiceId service) {
  impl_->images.refresh_all();
  return impl_->images.image_pids(service);
}
std::vector<int> Kernel::image_pids(ServiceId service, Generation g) {
  impl_->images.refresh_all();
  return impl_->images.image_pids(service, g);
}
std::vector<Generation> Kernel::generations() const { return impl_->images.generations(); }
std::optional<int> Kernel::plant_pid() const {
  if (!impl_->plant_started || impl_->plant.pid() <= 0) return std::nullopt;
  return impl_->plant.pid();
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
  out.started = !s.skip && s.phase != Phase::NotStarted;
  out.alive = s.live();
  out.ready = s.phase == Phase::Ready;
  out.pid = s.process.pid();
  out.exit = s.process.status();
  // Messages routed to it that it will never get: skipped by the broker, or overrun while it stays blocked.
  // s.stats.lost has what next() already skipped; add what is overrun but not yet skipped.
  for (const SubscriptionRecord& r : s.subscriptions) {
    if (r.id.value() >= impl_->subscribers.size()) continue;
    const std::uint64_t routed = impl_->subscribers[r.id.value()].routed;
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
