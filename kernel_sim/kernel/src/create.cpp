// Kernel::create (docs/design.md §2, §4–§6): a launch graph becomes a kernel ready to boot, in named steps — the
// services' params against their declarations, the audited policy, the clock, the capability system, the objects
// and the broker, the kernel's own descriptors, the descriptor limit, the service uid block, then on the kernel:
// its configuration, the services, the plant's executable, the CPU placement, the DDS bridge, the event sources
// and the network gate. Each step checks before it changes anything; the first that fails ends creation with
// its KernelError.
#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <filesystem>

#include "impl.hpp"
#include "rejuv/core/host_link_params.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/hosts.hpp"

namespace rejuv::kernel {

namespace {

using K = KernelError::Kind;

// ---- before the kernel exists ----

// docs/design.md §4: the kernel refuses to start a graph whose policy fails the audit.
Result<policy::Policy, KernelError> load_audited_policy(const launch::LoadedLaunch& graph) {
  auto policy = policy::load_policy(graph.policy_path, graph.policy_includes);
  if (!policy) return fail(kernel_error(K::Policy, policy.error().to_string()));
  if (const auto findings = policy::audit(*policy, graph); !findings.empty()) {
    // A finding is in the policy or in the launch graph (each says its file:line): name both.
    KernelError e = kernel_error(K::Audit, std::to_string(findings.size()) + " finding(s) in " +
                                               graph.path.string() + " and its policy " + graph.policy_path.string() +
                                               "; the kernel refuses to start");
    for (const policy::Finding& f : findings) e.findings.push_back(f.to_string());
    return fail(std::move(e));
  }
  return std::move(*policy);
}

// Each service's `params` against the parameters it declares beside its executable (launch.hpp "declared
// parameters"): a misspelt name or a value out of range is refused at the launch file's line, not flown with the
// service's default.
Result<void, KernelError> check_params(const launch::LoadedLaunch& graph, const KernelOptions& options) {
  if (auto ok = launch::check_declared_params(graph, options.service_dir); !ok) {
    return fail(kernel_error(K::Config, ok.error().to_string()));
  }
  return {};
}

// The options' clock, else the graph's; refused when nothing could keep its time.
Result<ClockMode, KernelError> choose_clock(const launch::LoadedLaunch& graph, const KernelOptions& options) {
  const ClockMode clock_mode =
      options.clock.value_or(graph.graph.clock() == proto::REALTIME ? ClockMode::Realtime : ClockMode::Lockstep);
  if (options.time_master == TimeMaster::Plant && clock_mode == ClockMode::Lockstep && !graph.graph.has_plant()) {
    return fail(kernel_error(K::Config, graph.path.string() + ": the graph has no plant; in lockstep nothing would keep time"));
  }
  if (options.time_master == TimeMaster::Manual && clock_mode == ClockMode::Realtime) {
    return fail(kernel_error(K::Config, "manual stepping needs the lockstep clock"));
  }
  return clock_mode;
}

// Capabilities: start in MC without SR (the mode never changes), in SC (safe) with it (docs/design.md §7 Faults).
Result<cap::CapSystem, KernelError> make_caps(const policy::Policy& policy, bool sr) {
  const cap::ModeTable table = policy::compile(policy);
  auto caps = cap::CapSystem::create(table, cap::CapSystemConfig{.cspace_slots = wire::kCSpaceSlots,
                                                                 .audit_capacity = 4096,
                                                                 .initial_mode = sr ? SrMode::SC : SrMode::MC});
  if (!caps) return fail(kernel_error(K::Config, "capability table: " + caps.error().to_string()));
  return std::move(*caps);
}

// Objects and topics: one broker topic per policy Topic object (docs/design.md §5), of an IDL type compiled in or
// one the policy declares (`types`, SDK rejuv_add_topics: no DDS descriptor).
struct Objects {
  std::vector<ObjectInfo> objects;  // by ObjectId
  broker::Broker broker;
  // The declared types the objects point to: reserved whole, and moved into the kernel with their buffer, so
  // that those pointers stay valid (their names view the policy's, which the kernel keeps too).
  std::vector<msgs::TopicType> declared_types;
};
Result<Objects, KernelError> make_objects(const policy::Policy& policy) {
  std::vector<ObjectInfo> objects;
  std::vector<broker::TopicConfig> topics;
  std::vector<msgs::TopicType> declared;
  declared.reserve(policy.types().size());
  for (const policy::DeclaredType& t : policy.types()) {
    declared.push_back(msgs::TopicType{.name = t.name, .size = t.size_bytes, .align = t.align_bytes, .descriptor = nullptr});
  }
  const auto topic_type = [&](std::string_view name) -> const msgs::TopicType* {
    if (const msgs::TopicType* t = msgs::find_topic_type(name)) return t;
    const auto it = std::find_if(declared.begin(), declared.end(), [&](const msgs::TopicType& t) { return t.name == name; });
    return it == declared.end() ? nullptr : &*it;
  };
  for (const policy::Object& o : policy.objects()) {
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
  return Objects{.objects = std::move(objects), .broker = std::move(*broker), .declared_types = std::move(declared)};
}

// The kernel's own descriptors. Signals first: Cyclone's threads (started by the bridge) must inherit the
// blocked mask. The seccomp program is built before any fork (libseccomp allocates) and loaded in each child
// between fork and exec.
struct KernelFds {
  sys::SignalFd signals;
  clock::TimePageWriter page;
  sys::Epoll epoll;
  sys::SeccompProgram seccomp;
};
Result<KernelFds, KernelError> open_kernel_fds() {
  auto signals = sys::SignalFd::create({SIGINT, SIGTERM});
  if (!signals) return fail(kernel_error(K::System, signals.error().to_string()));
  auto page = clock::TimePageWriter::create();
  if (!page) return fail(kernel_error(K::System, "time page: " + page.error().to_string()));
  auto epoll = sys::Epoll::create();
  if (!epoll) return fail(kernel_error(K::System, epoll.error().to_string()));
  auto seccomp = sys::SeccompProgram::service_policy(sys::Enforcement::Supervised);
  if (!seccomp) return fail(kernel_error(K::System, "seccomp: " + seccomp.error().to_string()));
  return KernelFds{.signals = std::move(*signals), .page = std::move(*page), .epoll = std::move(*epoll),
                   .seccomp = std::move(*seccomp)};
}

// File descriptors (their exhaustion is reported before the flight, never met in it): each process the kernel watches holds
// a few (channel, pidfd, output pipe, seccomp listener), and each generation of images a resume socket and the
// pidfds of an image and its spare per service. Measured: 131 at K = 2 and 456 at K = 16 for the square's 9
// services and the plant; this bound is above both.
Result<void, KernelError> ensure_fd_limit(const launch::LoadedLaunch& graph, std::size_t service_count) {
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
  return {};
}

// Service uids of their own (docs/sandbox.md), never the kernel's, not shared with another kernel of this
// machine: as root, a block leased for this kernel's lifetime; without root, a block of the user's subordinate
// ids (rejuv/sys/subid.hpp), which the strict sandbox refuses to start without. Only --insecure-sandbox without
// root runs the services as the kernel's uid.
struct ServiceUids {
  std::optional<sys::Lease> root_block;
  std::optional<sys::SubordinateBlock> subordinate;
};
Result<ServiceUids, KernelError> lease_service_uids(std::size_t service_count, KernelOptions::Sandbox sandbox) {
  if (!sys::running_as_root() && sandbox == KernelOptions::Sandbox::Insecure) return ServiceUids{};
  if (service_count > sys::kUidsPerBlock) {
    return fail(kernel_error(K::Config, std::to_string(service_count) + " services: a kernel runs at most " +
                                            std::to_string(sys::kUidsPerBlock) + " (one uid each)"));
  }
  const auto hint = static_cast<std::uint32_t>(::getpid());
  if (!sys::running_as_root()) {
    auto block = sys::SubordinateBlock::lease(::getuid(), hint);
    if (!block) {
      // No range or no helper: refused as a configuration the operator fixes (exit 2), like missing namespaces.
      const bool config = block.error().kind != sys::SubidError::Kind::System;
      return fail(kernel_error(config ? K::Config : K::System,
                               "the sandbox gives each service a uid of its own: " + block.error().to_string()));
    }
    return ServiceUids{.root_block = std::nullopt, .subordinate = std::move(*block)};
  }
  auto block = sys::lease_uid_block(hint);
  if (!block) return fail(kernel_error(K::System, "a block of service uids: " + block.error().to_string()));
  return ServiceUids{.root_block = std::move(*block), .subordinate = std::nullopt};
}

// ---- on the kernel ----

// The links' filter (sys::SeccompProgram::network_service_policy), built before any fork when the graph has one.
Result<void, KernelError> make_link_seccomp(Kernel::Impl& k) {
  const proto::Launch& g = k.graph.graph;
  if (std::none_of(g.services().begin(), g.services().end(),
                   [&](const proto::ServiceSpec& s) { return policy::is_host_link(g, s); })) {
    return {};
  }
  auto program = sys::SeccompProgram::network_service_policy(sys::Enforcement::Supervised);
  if (!program) return fail(kernel_error(K::System, "seccomp (links): " + program.error().to_string()));
  k.link_seccomp = std::move(*program);
  return {};
}

// The run's configuration from the graph and the options: clock, SR, images, seed, charges, alignment, domain;
// the capability system's time at 0 (the time page is at 0 since the kernel clock was made).
void configure(Kernel::Impl& k, ClockMode clock_mode, bool sr, ServiceUids uids) {
  k.uid_block = std::move(uids.root_block);
  k.subordinate_ids = std::move(uids.subordinate);
  if (!k.uid_block && !k.subordinate_ids) {
    k.log("INSECURE SANDBOX (--insecure-sandbox, not root): no namespaces, and every service runs as this kernel's "
          "uid %u: a compromised service can read this user's files and signal the kernel",
          static_cast<unsigned>(::getuid()));
  } else if (k.subordinate_ids && k.options.verbose) {
    const sys::MappedIds first = k.subordinate_ids->ids_of(0);
    k.log("service uids: subordinate ids of uid %u from %u (gids from %u), block %u", static_cast<unsigned>(::getuid()),
          static_cast<unsigned>(first.uid), static_cast<unsigned>(first.gid), k.subordinate_ids->block());
  }
  k.clock_mode = clock_mode;
  k.sr = sr;
  k.seed = k.options.seed.value_or(k.graph.graph.seed());
  const proto::LockstepTiming& timing = k.graph.graph.lockstep();
  k.rejuvenator.set_up_image_work(
      launch::keep_generations(k.graph.graph.sr()),
      ImageCharge(clock_mode, k.options.charge, std::chrono::round<Nanos>(launch::checkpoint_charge(timing)),
                  std::chrono::round<Nanos>(launch::rollback_charge(timing)),
                  std::chrono::round<Nanos>(launch::catch_up_charge_per_sample(timing))),
      VehiclePace(clock_mode == ClockMode::Realtime && k.graph.graph.has_plant()));
  // The plant aligns (held at rest) before the mission's t = 0; without a plant there is no alignment.
  if (k.options.time_master == TimeMaster::Plant && k.graph.graph.has_plant()) {
    k.rejuvenator.set_flight_start(std::chrono::round<Nanos>(launch::alignment(timing)));
  }
  k.domain = k.options.dds_domain.value_or(k.graph.graph.dds().domain_id());
  k.run_id = k.options.run_id ? *k.options.run_id : dds::random_run_id();
  k.caps.set_time(Nanos{0});
}

// Where an executable named in the graph is: absolute, or under KernelOptions::service_dir.
std::filesystem::path executable_path(const Kernel::Impl& k, const std::string& executable) {
  return launch::resolve_executable(executable, k.options.service_dir);
}

// A link's sandbox (service_runtime.hpp ServiceConfig::HostLink): its host's network namespace and its enclave.
ServiceConfig::HostLink host_link_of(const Kernel::Impl& k, const proto::ServiceSpec& spec) {
  ServiceConfig::HostLink link;
  const std::string_view host = launch::host_of(k.graph.graph, spec);
  for (const proto::Host& h : k.graph.graph.hosts()) {
    if (h.name() == host) link.netns = h.netns();
  }
  for (const proto::Param& p : spec.params()) {
    if (p.name() == host_link_param::kEnclave) link.enclave = p.text();
  }
  return link;
}

// Services, by policy order (ServiceId = policy declaration order = CSpace index), each with its executable
// found (unless skipped), its boot info and its boot params.
Result<void, KernelError> add_services(Kernel::Impl& k) {
  for (const policy::Service& ps : k.policy.services()) {
    ServiceRuntime s;
    s.id = ps.id;
    s.name = ps.name;
    s.stats.name = ps.name;
    s.published.assign(k.objects.size(), 0);  // counted on the publish path by object id: sized once, here
    s.config.spec = launch::find_service(k.graph.graph, ps.name);
    REJUV_ASSERT(s.config.spec != nullptr, "the audit checked that every policy service is in the graph");
    s.config.rejuvenate = launch::rejuvenate(*s.config.spec);
    if (policy::is_host_link(k.graph.graph, *s.config.spec)) s.config.link = host_link_of(k, *s.config.spec);
    if (std::find(k.options.skip_services.begin(), k.options.skip_services.end(), ps.name) != k.options.skip_services.end()) {
      s.config.skip = true;
      s.config.skip_reason = "skipped on request";
    } else if (ps.rejuvenation && !k.sr) {
      s.config.skip = true;
      s.config.skip_reason = "the rejuvenation service has nothing to do without SR";
    }
    s.config.executable = executable_path(k, s.config.spec->executable()).string();
    if (!s.config.skip) {
      std::error_code ec;
      if (!std::filesystem::is_regular_file(s.config.executable, ec)) {
        int index = 0;
        const proto::Launch& g = k.graph.graph;
        while (index < g.services_size() && g.services(index).name() != s.name) ++index;
        return fail(kernel_error(K::Config, k.graph.locations.locate({{"services", index}}, "executable").to_string() +
                                                ": error: service '" + s.name + "': executable " + s.config.executable +
                                                " not found (not built yet? skip it with --skip " + s.name + ")"));
      }
    }
    auto boot = k.caps.boot_info(s.id);
    REJUV_ASSERT(boot.has_value(), "every policy service has boot info");
    s.config.boot = std::move(*boot);
    k.services.push_back(std::move(s));
  }
  for (ServiceRuntime& s : k.services) s.config.params = build_params(k, s);
  return {};
}

// The plant's executable, when the plant keeps time: found before anything is spawned.
Result<void, KernelError> check_plant_executable(Kernel::Impl& k) {
  if (k.options.time_master != TimeMaster::Plant || !k.graph.graph.has_plant()) return {};
  const std::filesystem::path path = executable_path(k, k.graph.graph.plant().executable());
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return fail(kernel_error(K::Config, k.graph.locations.locate({{"plant", -1}}, "executable").to_string() +
                                            ": error: plant executable " + path.string() + " not found (not built yet?)"));
  }
  return {};
}

// The estimate catch-up (launch sr.estimate_catch_up; catch_up.hpp): which samples are kept and which
// services form the chain they are replayed through — the rejuvenated services that read a topic bridged in
// from the plant — from the graph's `uses`. Refused where a replay could not be what the model flies.
Result<void, KernelError> plan_catch_up(Kernel::Impl& k) {
  const proto::Launch& g = k.graph.graph;
  if (!k.sr || !g.sr().estimate_catch_up()) return {};
  const std::string at = k.graph.locations.locate({{"sr", -1}}, "estimate_catch_up").to_string() + ": error: ";
  const auto refuse = [&](const std::string& why) { return fail(kernel_error(K::Config, at + why)); };
  const auto object = [&](const std::string& name) -> std::optional<std::uint32_t> {
    const auto it = std::find_if(k.objects.begin(), k.objects.end(), [&](const ObjectInfo& o) { return o.name == name; });
    return it == k.objects.end() ? std::nullopt : std::optional(it->id.value());
  };
  const auto uses = [&](const ServiceRuntime& s, std::uint32_t topic, char right) {
    return std::any_of(s.config.spec->uses().begin(), s.config.spec->uses().end(), [&](const proto::Use& u) {
      return u.rights().find(right) != std::string::npos && object(u.object()) == topic;
    });
  };
  CatchUp::Plan plan{.logged = std::vector<bool>(k.objects.size()), .cut_off = std::vector<bool>(k.objects.size()),
                     .chain = std::vector<bool>(k.services.size()), .estimate = std::vector<bool>(k.objects.size())};
  std::size_t slot_bytes = 0;
  for (const proto::Bridge& b : g.dds().bridges()) {
    const auto topic = object(b.topic());
    if (b.direction() != proto::BRIDGE_IN || !topic) continue;
    for (const ServiceRuntime& s : k.services) {
      if (s.config.skip || !uses(s, *topic, 'R')) continue;
      if (!s.config.rejuvenate) {
        return refuse("'" + s.name + "' reads '" + b.topic() + "', which the catch-up replays after a rollback, "
                      "but is not rejuvenated: it would be handed those samples a second time");
      }
      plan.logged[*topic] = true;
      plan.chain[s.id.value()] = true;
      slot_bytes = std::max(slot_bytes, k.objects[*topic].type->size);
    }
  }
  if (slot_bytes == 0) return refuse("no rejuvenated service reads a topic bridged in from the plant: nothing to catch up");
  // What the chain publishes goes either to the chain alone (routed during the replay) or to services outside it
  // alone (held from them during the replay): a topic read on both sides would starve one of them.
  for (const ObjectInfo& o : k.objects) {
    if (o.kind != ObjectKind::Topic || plan.logged[o.id.value()]) continue;
    std::string writer, inside, outside;
    for (const ServiceRuntime& s : k.services) {
      if (s.config.skip) continue;
      if (plan.chain[s.id.value()] && uses(s, o.id.value(), 'W')) writer = s.name;
      if (uses(s, o.id.value(), 'R')) (plan.chain[s.id.value()] ? inside : outside) = s.name;
    }
    if (writer.empty() || outside.empty()) continue;
    if (!inside.empty()) {
      return refuse("'" + o.name + "', written by '" + writer + "' of the catch-up chain, is read both inside the chain ('" +
                    inside + "') and outside it ('" + outside + "'): during a replay one of them would miss it");
    }
    plan.cut_off[o.id.value()] = true;
    plan.estimate[o.id.value()] = o.type->name == msgs::TopicTraits<rejuv_msg_VehicleStateEstimate>::name;
  }
  // 32768 samples: ≈ 1 min of the plant's sensors (≈ 550 a second), far more than the generations a store keeps span.
  k.rejuvenator.set_up_catch_up(CatchUp(std::move(plan), 32768, slot_bytes));
  return {};
}

// KernelOptions::placement, before the bridge: Cyclone's threads, the services and the plant inherit the CPU
// mask.
Result<void, KernelError> place(Kernel::Impl& k) {
  using Placement = KernelOptions::Placement;
  const Placement placement = k.options.placement;
  if (!(placement == Placement::Cpu || (placement == Placement::Auto && k.clock_mode == ClockMode::Lockstep))) {
    return {};
  }
  auto cpu = sys::pin_to_one_cpu(placement == Placement::Cpu ? std::optional<int>(k.options.cpu) : std::nullopt);
  if (!cpu && placement == Placement::Cpu && cpu.error().error == EINVAL) {
    return fail(kernel_error(K::Config, "CPU " + std::to_string(k.options.cpu) + " is not available to this process"));
  }
  if (!cpu) return fail(kernel_error(K::System, "pinning to one CPU: " + cpu.error().to_string()));
  k.pinned_cpu = *cpu;
  return {};
}

bool plant_lockstep(const Kernel::Impl& k) {
  return k.options.time_master == TimeMaster::Plant && k.clock_mode == ClockMode::Lockstep;
}

// The DDS bridge (docs/design.md §5) of the graph's `dds.bridges` table, with the lockstep adapter when the plant keeps
// time. Cyclone reads CYCLONEDDS_URI; it defaults to the graph's config file.
Result<void, KernelError> open_bridge(Kernel::Impl& k) {
  std::vector<dds::BridgeEntry> table;
  const DdsNaming naming = launch::dds_naming(k.graph.graph.dds());
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
    table.push_back(dds::BridgeEntry{.topic = *object, .dds_name = launch::dds_name(k.graph.graph.dds(), b),
                                     .type = &msgs::dds_topic_type(*k.objects[object->value()].type, naming),
                                     .direction = b.direction() == proto::BRIDGE_IN ? dds::Direction::In
                                                                                     : dds::Direction::Out});
  }
  if (table.empty() && !plant_lockstep(k)) return {};
  if (std::getenv("CYCLONEDDS_URI") == nullptr) {
    const std::string uri = "file://" + launch::dds_config(k.graph, k.options.repo_root).string();
    ::setenv("CYCLONEDDS_URI", uri.c_str(), 0);  // also what the plant inherits
  }
  // ROS 2 sees the default partition only: with its names the run's endpoints are there.
  const std::string partition = naming == DdsNaming::Ros2 ? std::string() : dds::run_partition(k.run_id);
  auto bridge = DdsBridge::open(k.domain, partition, table, plant_lockstep(k), naming, k.objects.size());
  if (!bridge) return fail(kernel_error(K::Dds, bridge.error().to_string()));
  k.bridge = std::move(*bridge);
  return {};
}

// The event sources known at creation: signals, the realtime timerfd, the bridge's readers.
Result<void, KernelError> watch_event_sources(Kernel::Impl& k) {
  const auto add = [&](int fd, std::uint64_t tok) -> Result<void, KernelError> {
    if (auto ok = k.epoll.add(fd, tok); !ok) return fail(kernel_error(K::System, ok.error().to_string()));
    return {};
  };
  if (auto ok = add(k.signals->fd(), token(Source::Signal, 0)); !ok) return fail(ok.error());
  if (k.clock_mode == ClockMode::Realtime) {
    auto tfd = sys::TimerFd::create();
    if (!tfd) return fail(kernel_error(K::System, tfd.error().to_string()));
    k.timerfd = std::move(*tfd);
    if (auto ok = add(k.timerfd->fd(), token(Source::Timer, 0)); !ok) return fail(ok.error());
  }
  k.lockstep.set_samples_on_step(plant_lockstep(k));
  if (!k.bridge) return {};
  for (std::size_t i = 0; i < k.bridge->readers().size(); ++i) {
    // Lockstep with the plant: the samples of a step are taken when its SimStep arrives (they were published
    // before it), so only the step input wakes the kernel — one wakeup per step, not per sample.
    if (k.lockstep.samples_on_step() && !k.bridge->is_step_input(i)) {
      k.bridge->readers()[i].reader.set_signalling(false);  // until a step is short of samples
      continue;
    }
    if (auto ok = add(k.bridge->readers()[i].reader.ready_fd(), token(Source::Dds, i)); !ok) return fail(ok.error());
  }
  return {};
}

}  // namespace

Result<std::unique_ptr<Kernel>, KernelError> Kernel::create(launch::LoadedLaunch graph, KernelOptions options,
                                                            Observer* observer) {
  if (auto refused = check_params(graph, options); !refused) return fail(std::move(refused.error()));
  auto policy = load_audited_policy(graph);
  if (!policy) return fail(policy.error());
  auto clock_mode = choose_clock(graph, options);
  if (!clock_mode) return fail(clock_mode.error());
  const bool sr = graph.graph.sr().enabled() && !options.no_sr;
  auto caps = make_caps(*policy, sr);
  if (!caps) return fail(caps.error());
  auto objects = make_objects(*policy);
  if (!objects) return fail(objects.error());
  auto fds = open_kernel_fds();
  if (!fds) return fail(fds.error());
  const std::size_t service_count = policy->services().size();
  if (auto ok = ensure_fd_limit(graph, service_count); !ok) return fail(ok.error());
  auto uid_block = lease_service_uids(service_count, options.sandbox);
  if (!uid_block) return fail(uid_block.error());

  auto impl = std::make_unique<Impl>(std::move(graph), std::move(options), observer, std::move(*policy),
                                     std::move(*caps), std::move(objects->broker), std::move(fds->page), service_count,
                                     std::move(fds->epoll));
  Impl& k = *impl;
  k.declared_types = std::move(objects->declared_types);
  k.objects = std::move(objects->objects);
  k.signals.emplace(std::move(fds->signals));
  k.seccomp = std::move(fds->seccomp);
  if (auto ok = make_link_seccomp(k); !ok) return fail(ok.error());
  configure(k, *clock_mode, sr, std::move(*uid_block));
  using Step = Result<void, KernelError> (*)(Impl&);
  for (const Step step : {&add_services, &plan_catch_up, &check_plant_executable, &place, &open_bridge, &watch_event_sources}) {
    if (auto ok = step(k); !ok) return fail(ok.error());
  }
  k.rejuvenator.size_reaper();  // the services' limits are known now (add_services)
  k.rejuvenator.open_links();  // the links to other hosts, closed in the secure interval (link_guard.hpp)
  if (auto ok = k.net_open(); !ok) return fail(ok.error());  // the network gate (netgate.cpp)
  return std::unique_ptr<Kernel>(new Kernel(std::move(impl)));
}

}  // namespace rejuv::kernel
