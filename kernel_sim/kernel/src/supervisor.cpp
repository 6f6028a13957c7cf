// Supervision (docs/design.md §2, §7): the kernel is the parent (and subreaper) of every service and of the plant.
// Services are spawned with their channel at fd 3 and the read-only time page at fd 4, the BeforeExec
// seccomp stage and, when the kernel runs as root, their own uid. A child's death is learnt from its pidfd
// and handled in one place (lose_service); shutdown sends Shutdown, waits a grace period, then kills and
// reaps everything and closes every fd.
#include <fcntl.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "impl.hpp"
#include "rejuv/channel/boot.hpp"
#include "rejuv/core/graph_values.hpp"

extern char** environ;  // NOLINT: the plant inherits the kernel's environment (CYCLONEDDS_URI, ...)

namespace rejuv::kernel {

namespace {

// The longest a lockstep step waits for a service that waits for a CPU past the step's idle deadline, from
// the step's start: below the plant's ack timeout (60 s by default), which would end the run.
constexpr Nanos kIdleWaitBound{std::chrono::seconds{50}};

std::string format_double(double v) {
  std::array<char, 64> buf{};
  std::snprintf(buf.data(), buf.size(), "%.17g", v);
  return buf.data();
}

std::string_view attack_kind_name(proto::AttackKind kind) { return proto::AttackKind_Name(kind); }

// Why a service's uid could not execute its binary, and what to do. The kernel execs the file it opened itself
// (sys::spawn_supervised: execveat on its fd), so the folders above it need no search right for that uid; the
// file's own mode must let the uid (neither its owner nor in its group) execute it.
std::string exec_refused_why(const sys::SpawnSpec& spec) {
  std::string who = "the kernel's uid";
  if (spec.mapped_ids) {
    who = "its own subordinate uid " + std::to_string(spec.mapped_ids->uid);
  } else if (spec.uid) {
    who = "its own uid " + std::to_string(*spec.uid);
  }
  std::string mode = "unknown mode";
  struct stat st {};
  if (::stat(spec.executable.c_str(), &st) == 0) {
    std::array<char, 64> buf{};
    std::snprintf(buf.data(), buf.size(), "mode %04o, owner uid %u", st.st_mode & 07777U, st.st_uid);
    mode = buf.data();
  }
  return " — the service runs as " + who + ", which may not execute " + spec.executable + " (" + mode +
         "): let others execute it (chmod o+x, or build with umask 022); the folders above it need no search "
         "right, the kernel execs the file it opened";
}

}  // namespace

namespace {

// Boot parameters by name, as numbers or text.
struct ParamWriter {
  std::vector<wire::BootParam>& out;
  void number(std::string_view name, double v) const {
    out.push_back(channel::encode_boot_param(channel::BootParamEntry{.name = name, .number = v, .text = {}, .is_text = false}));
  }
  void text(std::string_view name, std::string_view v) const {
    out.push_back(channel::encode_boot_param(channel::BootParamEntry{.name = name, .number = 0, .text = v, .is_text = true}));
  }
};

void mission_params(const ParamWriter& w, const proto::Mission& m) {
  w.number("mission.count", m.waypoints_size());
  w.number("mission.acceptance_radius_m", m.acceptance_radius_m());
  w.number("mission.timeout_s", launch::mission_timeout(m).count());
  for (int i = 0; i < m.waypoints_size(); ++i) {
    const std::string prefix = "mission." + std::to_string(i) + ".";
    w.number(prefix + "north_m", m.waypoints(i).north_m());
    w.number(prefix + "east_m", m.waypoints(i).east_m());
    w.number(prefix + "down_m", m.waypoints(i).down_m());
    w.number(prefix + "yaw_rad", m.waypoints(i).yaw_rad());
  }
}

// The graph's attacks on service `s` (none when attacks are off); their count.
int attack_params(const ParamWriter& w, const Kernel::Impl& k, const ServiceRuntime& s) {
  int attacks = 0;
  const proto::Launch& g = k.graph.graph;
  const bool attack_on = g.attack().enabled() && !k.options.no_attack;
  for (const proto::Attack& a : g.attack().attacks()) {
    if (a.service() != s.name || !attack_on) continue;
    const std::string prefix = "attack." + std::to_string(attacks) + ".";
    w.text(prefix + "kind", attack_kind_name(a.kind()));
    // The launch file's start_s is flight time, as in `rejuv sim` (its t = 0 ends the alignment); a service reads
    // kernel time, so the alignment is added here, once for every attack hook: no window before take-off.
    w.number(prefix + "start_s", a.start_s() + to_seconds(k.rejuvenator.flight_start()).count());
    w.number(prefix + "max_windows", a.max_windows());
    w.number(prefix + "magnitude", a.magnitude());  // the attack library's size (docs/control.md "Attack library")
    ++attacks;
  }
  return attacks;
}

}  // namespace

std::vector<wire::BootParam> build_params(const Kernel::Impl& k, const ServiceRuntime& s) {
  std::vector<wire::BootParam> out;
  const ParamWriter w{out};
  const auto number = [&](std::string_view name, double v) { w.number(name, v); };
  const auto text = [&](std::string_view name, std::string_view v) { w.text(name, v); };
  for (const proto::Param& p : s.config.spec->params()) {
    if (p.has_text()) {
      text(p.name(), p.text());
    } else {
      number(p.name(), p.number());
    }
  }
  const proto::Launch& g = k.graph.graph;
  number("seed", static_cast<double>(k.seed));
  text("clock", to_string(k.clock_mode));
  // The SR scheme's graph-wide values, typed by their key (rejuv/core/graph_values.hpp): durations as ns.
  namespace gv = graph_values;
  const auto send = [&](const auto& key, auto value) {
    out.push_back(channel::encode_boot_param(channel::boot_param_of(key.name, gv::encode(key, value))));
  };
  // A field the file leaves at proto3's 0 where 0 is outside its key's range is not sent, and a service takes the
  // key's default: the loader refuses such a 0 with SR on, and a graph without SR need not set the SR block.
  const auto send_set = [&](const auto& key, auto value, double in_file) {
    if (in_file != 0.0) send(key, value);
  };
  const proto::SrParams& sr = g.sr();
  send(gv::kEnabled, k.sr);
  send_set(gv::kTmc, gv::nanos_of_seconds(launch::t_mc(sr).count()), sr.t_mc_s());
  send_set(gv::kTest, gv::nanos_of_seconds(launch::t_est(sr).count()), sr.t_est_s());
  send_set(gv::kRhoM, sr.rho_m(), sr.rho_m());
  send_set(gv::kRhoS, sr.rho_s(), sr.rho_s());
  send(gv::kTmin, gv::nanos_of_seconds(launch::t_min(sr).count()));
  send(gv::kCheckPeriod, gv::nanos_of_seconds(launch::check_period(sr).count()));
  send(gv::kKeepGenerations, launch::keep_generations(sr));
  send_set(gv::kRestrictedLimitFraction, sr.restricted_limit_fraction(), sr.restricted_limit_fraction());
  // The estimator's re-arm after a rollback: only what the launch file sets (ekf2's defaults are the table's).
  // With the estimate catch-up the restored estimator is fed the samples it missed instead, its covariance kept
  // (catch_up.hpp), as the model does.
  for (const launch::RearmField& f : launch::ekf_rearm_fields(sr.ekf_rearm())) {
    if (f.is_switch) {
      if (!sr.estimate_catch_up()) send(gv::kRearmEnabled, f.value != 0.0);
      continue;
    }
    send(*f.key, f.value);
  }
  if (sr.estimate_catch_up()) send(gv::kRearmEnabled, false);
  send_set(gv::kBoxPosition, sr.box().position_m(), sr.box().position_m());
  send_set(gv::kBoxVelocity, sr.box().velocity_m_s(), sr.box().velocity_m_s());
  send_set(gv::kBoxAngle, sr.box().angle_rad(), sr.box().angle_rad());
  send_set(gv::kBoxRate, sr.box().rate_rad_s(), sr.box().rate_rad_s());
  mission_params(w, g.mission());
  const int attacks = attack_params(w, k, s);
  number("attack.enabled", attacks > 0 ? 1 : 0);
  number("attack.count", attacks);
  // > 0: this incarnation was started by a cold restart (docs/design.md §7): the vehicle is not at its take-off point.
  number("boot.cold_restarts", static_cast<double>(k.rejuvenator.sr_stats().cold_restarts));
  // The mission's t = 0 on the kernel clock (the end of the plant's alignment): SR starts there (docs/design.md §6).
  send(gv::kFlightStart, k.rejuvenator.flight_start());
  return out;
}

Supervisor::Supervisor(Kernel::Impl& kernel)
    : k(kernel), liveness_(kernel.options.realtime_chain_hang_deadline, kernel.options.realtime_hang_deadline) {}

Result<void, KernelError> Supervisor::spawn_all() {
  if (auto ok = sys::become_subreaper(); !ok) {
    return fail(KernelError{.kind = KernelError::Kind::System, .message = ok.error().to_string(), .findings = {}});
  }
  for (ServiceRuntime& s : k.services) {
    if (s.config.skip) continue;
    if (auto ok = spawn_one(s); !ok) return ok;
  }
  return {};
}

std::vector<sys::LandlockRule> landlock_rules(const ServiceRuntime& s) {
  std::vector<sys::LandlockRule> rules = sys::service_landlock_rules(s.config.executable);
  if (s.config.link) {
    // Cyclone at boot: its enclave (the certificates, the signed governance and permissions; the key comes on an
    // fd), OpenSSL's seed, the time zone of its log, the interfaces' wireless flags (/proc/net: its own).
    for (const std::string& path : {s.config.link->enclave, std::string("/dev/urandom"), std::string("/etc/localtime"),
                                   std::string("/proc/net")}) {
      if (!path.empty()) rules.push_back(sys::LandlockRule{.path = path, .grant = sys::LandlockGrant::Read});
    }
  }
  return rules;
}

namespace {

// A link's own (docs/across_hosts.md "The link"), added to `spec`: its host's network namespace, joined by the
// child first (SpawnSpec::netns_fd), and its DDS Security key on wire::kHostLinkKeyFd (the file is its owner's
// only). Held open until the spawn; nothing for any other service.
struct LinkFds {
  sys::UniqueFd netns;
  sys::UniqueFd key;
};
Result<LinkFds, KernelError> open_link_fds(const ServiceRuntime& s, sys::SpawnSpec& spec) {
  LinkFds fds;
  if (!s.config.link) return fds;
  const auto open = [&](const std::string& path, std::string_view what) -> Result<sys::UniqueFd, KernelError> {
    sys::UniqueFd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (fd) return fd;
    return fail(KernelError{.kind = KernelError::Kind::Boot,
                            .message = "spawn '" + s.name + "': its " + std::string(what) + " " + path + ": " +
                                       std::strerror(errno),
                            .findings = {}});
  };
  if (!s.config.link->netns.empty()) {
    auto netns = sys::open_netns(s.config.link->netns);
    if (!netns) {
      return fail(KernelError{.kind = KernelError::Kind::Boot,
                              .message = "spawn '" + s.name + "': its host's network namespace: " +
                                         netns.error().to_string(),
                              .findings = {}});
    }
    fds.netns = std::move(*netns);
    spec.netns_fd = fds.netns.get();
  } else {
    spec.keep_network = true;  // its host's uplink is one of the kernel's own interfaces
  }
  if (!s.config.link->enclave.empty()) {
    auto key = open(s.config.link->enclave + "/key.pem", "DDS Security key");
    if (!key) return fail(std::move(key.error()));
    fds.key = std::move(*key);
    spec.fds.emplace_back(wire::kHostLinkKeyFd, fds.key.get());
  }
  return fds;
}

// Why a spawn failed, and what to do where the cause is known: the sandbox's namespaces need root or
// unprivileged user namespaces; an executable the service's uid cannot reach (exec_refused_why).
std::string spawn_refused(const ServiceRuntime& s, const sys::SpawnSpec& spec, const sys::SysError& error) {
  std::string message = "spawn '" + s.name + "' (" + s.config.executable + "): " + error.to_string();
  const std::string_view call = error.call;
  if (call.starts_with("unshare") || call.starts_with("read-only mounts")) {
    message += " — the sandbox runs each service in an empty network namespace and a read-only mount namespace,"
               " which takes root or unprivileged user namespaces; `rejuv run --insecure-sandbox` runs without"
               " them (and says so in the summary)";
  } else if (call == "execve" && error.error == EACCES) {
    message += exec_refused_why(spec);
  }
  return message;
}

}  // namespace

Result<void, KernelError> Supervisor::spawn_one(ServiceRuntime& s) {
  const auto system_error = [](const sys::SysError& e) {
    return fail(KernelError{.kind = KernelError::Kind::System, .message = e.to_string(), .findings = {}});
  };
  auto pair = sys::SeqPacket::pair(sys::Blocking::Yes);
  if (!pair) return system_error(pair.error());
  auto& [kernel_end, service_end] = *pair;
  if (auto ok = sys::set_nonblocking(kernel_end.fd(), true); !ok) return system_error(ok.error());
  // No terminal (docs/design.md §7 "Protection"): /dev/null to read, a pipe the kernel logs under the service's name
  // to write, and a session of its own with no controlling terminal.
  auto null = sys::open_null();
  if (!null) return system_error(null.error());
  auto out = sys::make_pipe();
  if (!out) return system_error(out.error());
  sys::SpawnSpec spec;
  spec.executable = s.config.executable;
  spec.env = {"REJUV_SERVICE=" + s.name};
  for (const char* keep : {"ASAN_OPTIONS", "UBSAN_OPTIONS", "TSAN_OPTIONS", "LSAN_OPTIONS"}) {
    if (const char* v = std::getenv(keep); v != nullptr) spec.env.push_back(std::string(keep) + "=" + v);
  }
  spec.fds = {{0, null->get()},
              {1, out->write.get()},
              {2, out->write.get()},
              {wire::kChannelFd, service_end.fd()},
              {wire::kTimePageFd, k.kernel_clock.read_only_fd().get()}};
  spec.seccomp = s.config.link ? &*k.link_seccomp : &*k.seccomp;
  auto link_fds = open_link_fds(s, spec);
  if (!link_fds) return fail(std::move(link_fds.error()));
  spec.session = sys::Session::NewSession;
  spec.isolation =
      k.options.sandbox == KernelOptions::Sandbox::Strict ? sys::Isolation::Namespaces : sys::Isolation::None;
  k.warden.join_cgroup(s);  // first: without a memory cgroup, limits_for bounds each process instead
  spec.limits = k.warden.limits_for(s);
  // What it may open while it boots (rejuv/sys/landlock.hpp): the libraries, its binary, its own /proc/<pid>.
  static const int landlock_abi = sys::landlock_abi();
  spec.landlock = landlock_rules(s);
  spec.landlock_abi = landlock_abi;
  if (k.uid_block) spec.uid = sys::service_uid(*k.uid_block, s.id.value());
  if (k.subordinate_ids && spec.isolation == sys::Isolation::Namespaces) {
    spec.mapped_ids = k.subordinate_ids->ids_of(s.id.value());
    spec.id_helpers = k.subordinate_ids->sources();
  }
  // Without root a service's /proc/<pid>/pagemap (images by written pages, checkpoint.cpp) can be opened (by
  // the agent in its user namespace, rejuv/sys/pagemap_agent.hpp) only while the service is dumpable: a
  // non-dumpable process whose binary's owner (root) is not mapped in its namespace needs CAP_SYS_PTRACE in
  // the initial one. So it stays dumpable (docs/sandbox.md "Without root"): its uid is its own, and the
  // filter forbids ptrace, process_vm_* and every open after boot.
  if (!sys::running_as_root()) spec.env.emplace_back(std::string(wire::kKeepDumpableEnv) + "=1");
  spec.cgroup_procs = s.sandbox.cgroup.join_fds();
  auto spawned = sys::spawn_supervised(spec);
  if (!spawned) {
    return fail(KernelError{.kind = KernelError::Kind::Boot, .message = spawn_refused(s, spec, spawned.error()),
                            .findings = {}});
  }
  k.warden.close_sandbox(s);  // a cold restart: the previous incarnations' listener and pipe
  auto* child = &spawned->process;
  s.sandbox.seccomp = std::move(spawned->listener);
  s.sandbox.output = std::move(out->read);
  s.sandbox.sessions.push_back(child->pid());
  const auto watch = [&](int fd, Source source) { return k.epoll.add(fd, token(source, s.id.value())); };
  if (s.sandbox.seccomp.valid()) {
    if (auto ok = watch(s.sandbox.seccomp.fd(), Source::Seccomp); !ok) return system_error(ok.error());
  }
  if (auto ok = watch(s.sandbox.output.get(), Source::Output); !ok) return system_error(ok.error());
  s.proc.process = std::move(*child);
  s.proc.channel = std::move(kernel_end);
  s.proc.spawned();
  ++s.stats.spawns;
  s.pages.start_incarnation(Generation{});  // a fresh process: its first image is by fork
  s.proc.spawned_at = k.wall();
  s.sandbox.limiter.last = s.proc.spawned_at;
  if (auto ok = watch(s.proc.channel.fd(), Source::Channel); !ok) return system_error(ok.error());
  if (auto ok = watch(s.proc.process.pidfd(), Source::Pidfd); !ok) return system_error(ok.error());
  return {};
}

std::optional<pid_t> Supervisor::plant_pid() const {
  if (!plant_started_ || plant_.pid() <= 0) return std::nullopt;
  return plant_.pid();
}

Result<void, KernelError> Supervisor::spawn_plant() {
  const proto::Launch& g = k.graph.graph;
  sys::SpawnSpec spec;
  spec.executable = launch::resolve_executable(g.plant().executable(), k.options.service_dir).string();
  double north = 0;
  double east = 0;
  double down = -3;
  if (g.mission().waypoints_size() > 0) {
    north = g.mission().waypoints(0).north_m();
    east = g.mission().waypoints(0).east_m();
    down = g.mission().waypoints(0).down_m();
  }
  spec.args = {"--domain",      std::to_string(k.domain),
               "--seed",        std::to_string(k.seed),
               "--clock",       std::string(to_string(k.clock_mode)),
               "--start-north", format_double(north),
               "--start-east",  format_double(east),
               "--start-down",  format_double(down)};
  // The bridge's partition (rejuv/dds/run_partition.hpp) and names: with ROS 2 names, the default partition
  // and ROS 2's names for every topic of the plant interface (create.cpp, open_bridge).
  if (launch::dds_naming(g.dds()) == DdsNaming::Ros2) {
    spec.args.insert(spec.args.end(), {"--dds-names", std::string(to_string(DdsNaming::Ros2))});
  } else {
    spec.args.insert(spec.args.end(), {"--run-id", dds::to_string(k.run_id)});
  }
  if (g.plant().wind_mean_m_s() != 0) {
    spec.args.insert(spec.args.end(), {"--wind-mean", format_double(g.plant().wind_mean_m_s())});
  }
  if (g.plant().wind_toward_deg() != 0) {
    spec.args.insert(spec.args.end(), {"--wind-toward", format_double(g.plant().wind_toward_deg())});
  }
  if (g.plant().wind_gust_m_s() != 0) {
    spec.args.insert(spec.args.end(), {"--wind-gust", format_double(g.plant().wind_gust_m_s())});
  }
  // The pre-flight alignment of the launch file (docs/design.md §6), as long as `rejuv sim`'s (SimConfig::alignment).
  spec.args.insert(spec.args.end(),
                   {"--align-s", format_double(to_seconds(k.rejuvenator.flight_start()).count())});
  spec.args.insert(spec.args.end(), k.options.plant_args.begin(), k.options.plant_args.end());
  for (char** e = environ; *e != nullptr; ++e) spec.env.emplace_back(*e);
  auto child = sys::spawn(spec);
  if (!child) {
    return fail(KernelError{.kind = KernelError::Kind::Boot,
                            .message = "spawn the plant (" + spec.executable + "): " + child.error().to_string(),
                            .findings = {}});
  }
  plant_ = std::move(*child);
  plant_started_ = true;
  if (auto ok = k.epoll.add(plant_.pidfd(), token(Source::Plant, 0)); !ok) {
    return fail(KernelError{.kind = KernelError::Kind::System, .message = ok.error().to_string(), .findings = {}});
  }
  return {};
}

// The boot script (docs/protocol.md "Boot"), by the channel's one encoder (rejuv/channel/boot.hpp).
void Supervisor::send_boot(ServiceRuntime& s) {
  std::vector<wire::BootCap> boot_caps;
  boot_caps.reserve(s.config.boot.caps.size());
  for (const cap::BootCap& c : s.config.boot.caps) {
    const ObjectInfo& o = k.objects[c.object.value()];
    channel::BootCapEntry entry{.slot = c.slot, .kind = c.kind, .rights = c.rights, .payload_size = 0,
                                .object = c.name, .type = {}};
    if (o.type != nullptr) {
      entry.payload_size = static_cast<std::uint32_t>(o.type->size);
      entry.type = o.type->name;
    } else if (o.kind == ObjectKind::Persistent) {
      entry.payload_size = static_cast<std::uint32_t>(o.persistent.size());
    }
    boot_caps.push_back(channel::encode_boot_cap(entry));
  }
  const channel::BootIdentity who{.service = s.id, .epoch = k.kernel_clock.epoch(), .name = s.name};
  channel::write_boot_script(k.tx, who, boot_caps, s.config.params,
                             [&](std::span<const std::byte> frame) { k.router.send_control(s, frame); });
}

void Supervisor::on_child_exit(ServiceRuntime& s) {
  if (s.proc.phase() == Phase::Dead || s.proc.phase() == Phase::NotStarted) return;
  auto status = s.proc.process.try_wait();
  if (status && !*status) return;  // not yet (spurious wakeup)
  if (!status) {
    // Its pidfd said it ended but it cannot be waited for (reaped elsewhere?): it is gone all the same. Lost
    // with the error, never ignored: an unnoticed death leaves the graph without the service and SR without
    // its rollback (the fault campaign's one unexplained unsafe case had neither a loss nor a rollback).
    k.log("service '%s': its end cannot be read (%s): counted as lost", s.name.c_str(),
          status.error().to_string().c_str());
    status = std::optional<sys::ExitStatus>{sys::ExitStatus{.how = sys::ExitStatus::How::Signaled, .value = SIGKILL}};
  }
  if (!k.booted) {
    // Its last words may still be in the channel (the pidfd can be handled first): read them, so that a
    // boot failure is reported with the service's own error (lose_service).
    for (std::uint64_t before = ~std::uint64_t{0}; s.live() && s.proc.channel.valid() && before != s.stats.frames_in;) {
      before = s.stats.frames_in;
      k.input.read_channel(s);
    }
  }
  (void)k.epoll.remove(s.proc.process.pidfd());
  if (s.proc.channel.valid()) {
    (void)k.epoll.remove(s.proc.channel.fd());
    s.proc.channel.close();
  }
  s.proc.ended();
  s.stats.exit = **status;
  k.broker.remove_service(s.id);
  k.timers.remove_service(s.id);
  k.router.channel_closed(s);
  // What it wrote last (often why it ended) before the kernel's own line about it.
  k.warden.on_service_output(s);
  // Killed by the OOM killer of its live cgroup leaf (docs/sandbox.md "A cgroup per service"): the live
  // incarnation that exhausts its memory is the one stopped, and that is counted like a violation.
  if ((**status).how == sys::ExitStatus::How::Signaled && (**status).value == SIGKILL) {
    (void)k.warden.count_out_of_memory(s, true);
  }
  // A forbidden call is killed by the kernel itself (warden.cpp, loss_reason set). A death by SIGSYS is a
  // filter of the service's own that refused a call: the kernel never sends SIGSYS, so it counts the same.
  const bool sigsys = s.proc.loss_reason.empty() && (**status).how == sys::ExitStatus::How::Signaled &&
                      (**status).value == SIGSYS;
  if (sigsys) {
    s.proc.loss_reason = "sandbox violation (killed by SIGSYS)";
    k.warden.record_violation(s, Violation::ForbiddenCall, "unknown (SIGSYS)");
  }
  if (k.stopping) return;
  std::string reason = s.proc.loss_reason.empty() ? (**status).to_string()
                                                  : s.proc.loss_reason + " (" + (**status).to_string() + ")";
  lose_service(s, std::move(reason));
}

void Supervisor::lose_service(ServiceRuntime& s, std::string reason) {
  k.log("service '%s' lost at t = %.3f s: %s", s.name.c_str(), to_seconds(k.now()).count(), reason.c_str());
  // Before the graph has booted (every service Ready once) no checkpoint exists: there is no image to roll
  // back to, and a restart from the binary would fail the same way (a refused parameter, a wrong
  // executable). The run stops with the service's own error, SR on or off.
  if (!k.booted) {
    std::string detail = "service '" + s.name + "' (" + s.config.executable + ") failed at boot: " + reason;
    if (!s.proc.last_error.empty()) detail += "; its last error: " + s.proc.last_error;
    k.stop_run(StopReason::ServiceFailed, std::move(detail));
    return;
  }
  // docs/design.md §7: a rejuvenated service dying is one of the three rollback triggers (rejuvenator.cpp).
  // Without SR, or for a driver-level service (never rolled back), the run cannot continue safely.
  if (k.sr && s.config.rejuvenate) {
    k.rejuvenator.request_rollback("service '" + s.name + "' lost: " + reason);
    return;
  }
  // A link between hosts (never rolled back: it holds no state of the flight) is restarted from its binary.
  if (s.config.link && s.stats.spawns <= kMaxLinkRestarts) {
    s.subscriptions.clear();
    k.router.channel_opened(s);
    if (auto ok = spawn_one(s); !ok) {
      k.stop_run(StopReason::ServiceFailed, "restarting '" + s.name + "': " + ok.error().message);
      return;
    }
    k.log("service '%s' restarted from its binary (pid %d)", s.name.c_str(), static_cast<int>(s.proc.process.pid()));
    return;
  }
  k.stop_run(StopReason::ServiceFailed, "service '" + s.name + "': " + reason);
}

void Supervisor::kill_hung(ServiceRuntime& s, std::string reason) {
  if (!s.live() || !s.proc.loss_reason.empty()) return;
  s.proc.loss_reason = std::move(reason);
  s.stats.hung = true;
  k.lockstep.note_hung(s.id);
  k.log("killing '%s': %s", s.name.c_str(), s.proc.loss_reason.c_str());
  (void)s.proc.process.signal(SIGKILL);  // the pidfd reports the death; on_child_exit does the rest
}

void Supervisor::on_plant_exit() {
  auto status = plant_.try_wait();
  if (!status || !*status) return;
  (void)k.epoll.remove(plant_.pidfd());
  if (k.stopping) return;
  k.log("the plant exited: %s", (**status).to_string().c_str());
  k.stop_run(StopReason::PlantExited, "the plant " + (**status).to_string());
}

// Lockstep with the plant: no step has completed for a while. Says what the kernel is waiting for (a step's
// samples, an idle service, a checkpoint's quiescence) once per stall, so that a hang is never silent.
void Supervisor::report_stall() {
  k.lockstep.stall_reported();
  std::string what;
  if (!k.lockstep.steps().active()) {
    what = k.lockstep.steps().waiting_for();
  } else {
    what = "step " + std::to_string(k.lockstep.steps().active()->step) + " in round " +
           std::to_string(k.lockstep.steps().rounds());
    for (const ServiceRuntime& s : k.services) {
      if (!s.live() || s.idle()) continue;
      what += "; '" + s.name + "' not idle (phase " + std::to_string(static_cast<int>(s.proc.phase())) + ", idle " +
              std::to_string(s.flow().reported()) + "/" + std::to_string(s.flow().frames_out()) +
              (s.flow().has_held() ? ", held" : "") +
              (s.flow().queued() == 0 ? "" : ", queued " + std::to_string(s.flow().queued())) +
              (s.flow().sweeping() ? ", sweep" : "") + ")";
    }
    if (k.rejuvenator.coordinator().checkpoint() == ImageCoordinator::Checkpoint::Asked)
      what += "; a checkpoint waits for quiescence";
    if (k.rejuvenator.coordinator().rollback_asked()) what += "; a rollback is pending";
    if (const std::size_t staged = k.lockstep.publications_staged(); staged > 0)
      what += "; " + std::to_string(staged) + " staged";
  }
  k.log("no lockstep step completed for %.1f s: %s",
        to_seconds(k.wall() - k.lockstep.steps().last_done()).count(), what.c_str());
}

void Supervisor::check_deadlines() {
  const Nanos t = k.wall();
  if (const auto at = k.lockstep.steps().stall_deadline();
      plant_started_ && k.clock_mode == ClockMode::Lockstep && at && t > *at) {
    report_stall();
  }
  for (ServiceRuntime& s : k.services) {
    if (s.proc.booting() && t - s.proc.spawned_at > k.options.boot_deadline) {
      kill_hung(s, "not Ready within the boot deadline (" +
                       std::to_string(to_seconds(k.options.boot_deadline).count()) + " s)");
    }
  }
  for (ServiceRuntime& s : k.services) {
    // After a Shutdown a closed channel is the service on its way out (under LeakSanitizer its exit check
    // can take longer than kChannelCloseGrace): the shutdown's own grace period bounds it.
    if (!k.shut_down && s.live() && s.proc.channel_closed_at &&
        t - *s.proc.channel_closed_at > kChannelCloseGrace) {
      kill_hung(s, "closed its channel");
    }
  }
  if (const auto at = k.lockstep.steps().idle_deadline(k.options.idle_deadline); at && t > idle_look(*at)) {
    idle_look_.reset();
    bool killed = false;
    for (ServiceRuntime& s : k.services) {
      if (!s.live() || s.idle()) continue;
      // The scheduler first, then the channel: a service seen asleep sent whatever it answered before it
      // slept, so the read finds its Idle if it is there.
      const std::optional<CpuSight> cpu = cpu_sight(s.proc.process.pid());
      if (s.proc.channel.valid()) k.input.read_channel(s);
      if (!s.live() || s.idle() || spared_at_idle_deadline(s, *at, t, cpu)) continue;
      kill_hung(s, "not idle within the idle deadline (" +
                       std::to_string(to_seconds(k.options.idle_deadline).count()) + " s) of step " +
                       std::to_string(k.lockstep.steps().active()->step) +
                       (!cpu            ? "; its CPU time unknown"
                        : cpu->runnable ? "; runnable"
                                        : "; asleep or stopped"));
      killed = true;
    }
    // The others get a full deadline again for what the step still has to do.
    if (killed) k.lockstep.restart_idle_deadline(t);
  }
}

bool Supervisor::spared_at_idle_deadline(const ServiceRuntime& s, Nanos deadline_at, Nanos t,
                                         std::optional<CpuSight> cpu) {
  if (idle_waits_.size() < k.services.size()) idle_waits_.resize(k.services.size());
  std::optional<CpuWait>& wait = idle_waits_[s.id.value()];
  const Nanos length = k.options.idle_deadline;
  // Never past kIdleWaitBound since the step began: below the plant's ack timeout, which would end the run.
  if (t - (deadline_at - length) >= kIdleWaitBound) return false;
  if (!wait || wait->deadline_at() != deadline_at) wait.emplace(deadline_at, length, deadline_at - length);
  const std::optional<CpuWait::GoOn> on = wait->go_on(t, cpu);
  if (!on) return false;
  if (on->first) {
    k.log(
        "'%s' waiting for a CPU at the idle deadline of step %llu: %lld ms on one since: not hung "
        "(the deadline counts CPU time while it is runnable)",
        s.name.c_str(), static_cast<unsigned long long>(k.lockstep.steps().active()->step),
        static_cast<long long>(std::chrono::duration_cast<std::chrono::milliseconds>(on->ran).count()));
  }
  idle_look_ = idle_look_ ? std::min(*idle_look_, on->until) : on->until;
  return true;
}

bool Supervisor::runs_fifo(const ServiceRuntime& s) const {
  return realtime_active && s.id.value() < fifo_pid_.size() && fifo_pid_[s.id.value()] == s.proc.process.pid();
}

LivenessSight Supervisor::liveness_sight(const ServiceRuntime& s) const {
  // The catch-up chain while it replays or drains what it was handed is left alone: a slow replay is no
  // violation (catch_up.hpp), and the catch-up's own bound ends it.
  const bool watched = s.config.rejuvenate && s.live() && !s.proc.scripted && s.proc.phase() == Phase::Ready &&
                       s.proc.loss_reason.empty() && !k.rejuvenator.catch_up().in_replay(s.id);
  return LivenessSight{.id = s.id, .watched = watched, .chain = runs_fifo(s), .pid = s.proc.process.pid(),
                       .frames_in = s.stats.frames_in, .frames_out = s.flow().frames_out(),
                       .reported = s.flow().reported()};
}

void Supervisor::watch_liveness() {
  if (!k.sr) return;  // without SR a kill ends the run: a slow service is not worth that
  const Nanos t = k.wall();
  if (!liveness_.begin_pass(t)) return;
  for (ServiceRuntime& s : k.services) {
    const LivenessSight sight = liveness_sight(s);
    const LivenessCall call = liveness_.look(sight, t);
    switch (call.kind) {
      case LivenessCall::Kind::Nothing:
        break;
      case LivenessCall::Kind::Ask:
        if (k.ask_idle(s)) liveness_.asked(s.id, t, call.owed, cpu_sight(s.proc.process.pid()));
        break;
      case LivenessCall::Kind::Overdue:
        // The scheduler first, then the channel: a service seen asleep sent whatever it answered before
        // it slept, so the read below finds it.
        const std::optional<CpuSight> cpu = cpu_sight(s.proc.process.pid());
        if (s.proc.channel.valid()) k.input.read_channel(s);  // its Idle may be waiting in the channel
        if (s.live() && s.flow().reported() < call.owed) {
          const auto ms = [](Nanos d) {
            return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d).count());
          };
          if (const auto spared = liveness_.spared_for_cpu(s.id, t, cpu, call.deadline)) {
            // Runnable with less than its deadline of CPU time: the machine's doing. Looked at again next time.
            if (spared->first) {
              k.log("'%s' waiting for a CPU: %s ms on one in the %s ms since a Sync: not hung (its deadline counts "
                    "CPU time while it is runnable)",
                    s.name.c_str(), ms(spared->ran).c_str(), ms(spared->since).c_str());
            }
            break;
          }
          kill_hung(s, "no Idle within " + ms(call.deadline) + " ms of a Sync in real time (" +
                           std::to_string(s.flow().reported()) + " of " + std::to_string(call.owed) +
                           " frames reported" + (sight.chain ? ", at SCHED_FIFO" : "") +
                           (cpu ? "" : "; its CPU time unknown") + ")");
        }
        liveness_.fresh(liveness_sight(s), t);
        break;
    }
  }
}

void Supervisor::shutdown_all() {
  if (k.shut_down) return;
  k.shut_down = true;
  k.stopping = true;
  const bool any_live =
      std::any_of(k.services.begin(), k.services.end(), [](const ServiceRuntime& s) { return s.live(); });
  if (any_live) {
    for (ServiceRuntime& s : k.services) {
      if (s.live() && k.tx.build(wire::FrameKind::Shutdown, 0, 0, 0)) k.router.send_control(s, k.tx.bytes());
    }
    // Grace: keep the loop running (reading channels, draining queued Shutdowns, reaping).
    const Nanos deadline = k.wall() + k.options.shutdown_grace;
    k.lockstep.abandon_step();
    while (k.wall() < deadline && std::any_of(k.services.begin(), k.services.end(),
                                              [](const ServiceRuntime& s) { return s.live(); })) {
      if (!k.pump(std::min<Nanos>(deadline - k.wall(), std::chrono::milliseconds{50}))) break;
    }
  }
  for (ServiceRuntime& s : k.services) {
    if (!s.live()) continue;
    k.log("'%s' did not exit within the grace period: killed", s.name.c_str());
    s.proc.process.kill_and_reap();
    if (s.proc.channel.valid()) (void)k.epoll.remove(s.proc.channel.fd());
    (void)k.epoll.remove(s.proc.process.pidfd());
    s.proc.channel.close();
    s.stats.exit = s.proc.process.status();
    s.proc.ended();
  }
  if (plant_started_ && plant_.running()) {
    (void)plant_.signal(SIGTERM);
    (void)sys::wait_fd(plant_.pidfd(), sys::WaitFor::Readable, k.options.shutdown_grace);
    if (auto st = plant_.try_wait(); !st || !*st) {
      k.log("the plant did not exit within the grace period: killed");
    }
    plant_.kill_and_reap();
  }
  // Every image and every killed incarnation (docs/design.md §7): killed and reaped.
  k.rejuvenator.release_all_images();
  // And whatever else a service left (docs/design.md §7 "Protection"): nothing outlives the run. The cgroup, where
  // there is one, ends all of a service in one call; the sweep then names, counts and reaps what was left in
  // a service's session (a zombie is still its session's).
  for (ServiceRuntime& s : k.services) s.sandbox.cgroup.kill_all();
  k.warden.sweep_strays("shutdown", true);
  k.rejuvenator.kill_and_reap_all();
  for (ServiceRuntime& s : k.services) k.warden.close_sandbox(s);
  // Close every fd the run opened: DDS (participant, sockets, threads), the timerfd.
  k.bridge.reset();
  k.timerfd.reset();
}

}  // namespace rejuv::kernel
