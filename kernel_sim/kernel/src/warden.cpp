// Warden (warden.hpp): containment (docs/design.md §7 "Protection (containment)", docs/sandbox.md). A
// rollback erases only what is inside the image, so nothing a service does may escape it:
//   - the allow-list filter (kernel_sim/sys seccomp.hpp) refers boot calls and forbidden calls to the kernel
//     (on_seccomp_notice): boot calls continue until the service is ready, a forbidden call kills its caller;
//   - every process a service can make is the kernel's child in the service's session (the filter allows
//     clone only with the image fork's flags or a thread's, and no setsid): sweep_strays finds and kills
//     what is neither the live incarnation nor an image;
//   - its fds 1-2 are a pipe the kernel reads (on_service_output): no terminal, nothing unattributed.
// A violation is proof of compromise (§II: the attacker has the service): counted by kind, logged with the
// call's name, published on the security-event topic, and in MC it triggers a rollback at once (waiting
// for T_MC only gives the attacker time); the rejuvenation timer keeps its schedule otherwise.
#include <algorithm>
#include <array>
#include <csignal>
#include <cstdarg>
#include <cstdio>
#include <filesystem>

#include "rejuv/sys/sanitizer.hpp"
#include "supervisor.hpp"
#include "vocabulary.hpp"
#include "warden.hpp"

namespace rejuv::kernel {

namespace {

constexpr std::size_t kNoticesPerWakeup = 64;     // fairness: a service flooding the kernel with calls
constexpr std::size_t kOutputReadsPerWakeup = 16;  // × 4 KiB
constexpr std::size_t kMaxOutputLine = 1024;       // a longer line is cut and logged in pieces
constexpr std::size_t kMaxNamedCalls = 32;         // distinct call names kept per service
constexpr Nanos kSweepPeriod{std::chrono::seconds{1}};  // kernel clock
// How long a rollback's sweep waits for copies requested earlier to report (a fork: tens of µs), wall clock.
constexpr Nanos kCopiesWait{std::chrono::milliseconds{50}};
// A SCHED_FIFO service's real-time budget per second where the machine groups real-time tasks (v1
// cpu.rt_runtime_us): a control-chain service uses a few % of a CPU; one that spins is throttled here (and,
// blocking nothing for RLIMIT_RTTIME, killed).
constexpr std::uint64_t kRtBudgetUs = 100000;

}  // namespace

sys::ResourceLimits Warden::limits_for(const ServiceRuntime& s) const {
  const launch::SandboxLimitValues v = launch::sandbox_limits(parts_.graph, *s.config.spec);
  sys::ResourceLimits limits;
  // RLIMIT_NPROC counts the processes of a uid in a user namespace: meaningful when each service has its
  // own uid (root) or its own user namespace (the strict sandbox without root, process.cpp isolate_in_child).
  if (sys::running_as_root() || parts_.options.sandbox == KernelOptions::Sandbox::Strict)
    limits.processes = v.max_processes;
  limits.open_files = v.max_open_files;
#if !defined(REJUV_TSAN)
  // On top of what a sanitizer's runtime reserves at start (its shadow memory): the limit still bounds what
  // the service maps, and stays below infinity, so raising it is refused. ThreadSanitizer's reservation
  // leaves nothing to bound: no limit in a TSan build.
  // Where no memory cgroup bounds the service's group (without root, docs/sandbox.md "Without root"), the
  // group's budget bounds each of its processes: a service holding more than its group may hold is refused
  // its memory, as the cgroup would refuse it. Its images share its pages until they differ, and the stray
  // sweep ends any other process, so the group stays near one process's bound.
  std::uint32_t memory_mb = v.max_memory_mb;
  if (v.max_group_memory_mb > 0 && !s.sandbox.cgroup.bounds_memory())
    memory_mb = memory_mb == 0 ? v.max_group_memory_mb : std::min(memory_mb, v.max_group_memory_mb);
  if (memory_mb > 0) limits.address_space = (std::uint64_t{memory_mb} << 20U) + sys::kSanitizerAddressSpace;
#endif
  // No file can be opened after boot and every mount is read-only; what is left to write is the memfd of an
  // image by written pages (allocated ahead for twice the largest image, docs/protocol.md).
  limits.file_size = 2 * wire::kMaxImagePages * 4096 + (1U << 20U);
  // The real-time plan (realtime.cpp): a service the plan may put at SCHED_FIFO gets its RLIMIT_RTTIME from
  // birth (the kernel cannot set it later: prlimit on a service of another uid is refused).
  const proto::RealtimePlan& rt = parts_.graph.realtime();
  if (rt.enabled() && s.config.spec->rt_priority() > 0) {
    limits.rt_time_us = std::uint64_t{launch::realtime_values(rt).max_rt_time_ms} * 1000U;
  }
  return limits;
}

void Warden::join_cgroup(ServiceRuntime& s) {
  if (s.sandbox.cgroup.valid() || !s.sandbox.cgroup_note.empty()) return;  // made once, at the first spawn
  const launch::SandboxLimitValues v = launch::sandbox_limits(parts_.graph, *s.config.spec);
  sys::CgroupLimits limits;
  limits.pids = v.max_processes;
  if (v.max_group_memory_mb > 0) limits.memory_bytes = std::uint64_t{v.max_group_memory_mb} << 20U;
  if (v.max_cpu_percent > 0) limits.cpu_percent = v.max_cpu_percent;
  // The real-time plan (realtime.cpp): where real-time tasks are grouped, a SCHED_FIFO service needs a budget
  // in its group, which also bounds what it can take of each second at SCHED_FIFO (kRtBudgetUs). Only where the
  // plan applies (a real-time run): the budgets of all groups share the machine's 950 ms/s, and a lockstep
  // kernel that reserved its share for nothing left a real-time run beside it without (its services refused
  // SCHED_FIFO).
  if (parts_.clock_mode == ClockMode::Realtime && parts_.graph.realtime().enabled() &&
      s.config.spec->rt_priority() > 0)
    limits.rt_runtime_us = kRtBudgetUs;
  // This kernel's scope: its address, unique among the kernels alive in this process.
  const std::string scope = std::to_string(reinterpret_cast<std::uintptr_t>(this));  // NOLINT: an identity
  if (auto made = sys::ServiceCgroup::create(scope, s.name, limits)) {
    s.sandbox.cgroup = std::move(*made);
    s.sandbox.cgroup_note = s.sandbox.cgroup.description();
  } else {
    // Common without root: the rlimits, the filter and the sweeps hold without it (docs/sandbox.md).
    s.sandbox.cgroup_note = "no cgroup (" + made.error().to_string() + ")";
  }
  if (parts_.options.verbose) say("sandbox of '%s': %s", s.name.c_str(), s.sandbox.cgroup_note.c_str());
}

// Calls `f` with each copy (image or spare) of `service` the kernel knows, or of every service (nullopt).
template <class F>
void Warden::for_each_copy(std::optional<ServiceId> service, F f) const {
  peers_.for_each_image([&](const image::Image& im) {
    if (service && im.service != *service) return;
    for (const sys::ChildProcess& c : im.copies) f(parts_.services[im.service.value()], c.pid());
  });
}

// Whether a copy of `service` was forked whose pid the kernel does not know yet (a spare whose Copied has not
// been read): it was born where its parent was — for a spare forked by the restored incarnation, the live
// leaf — and no one can tell it apart from a stray there.
bool Warden::copies_pending(ServiceId service) const {
  bool pending = false;
  peers_.for_each_image(
      [&](const image::Image& im) { pending = pending || (im.service == service && im.spares_pending > 0); });
  return pending;
}

void Warden::say(const char* format, ...) {
  va_list args;
  va_start(args, format);
  const std::string line = log_line(format, args);
  va_end(args);
  peers_.log(line);
}

void Warden::place_images() {
  std::vector<pid_t> now;
  for_each_copy(std::nullopt, [&](const ServiceRuntime& s, pid_t pid) {
    now.push_back(pid);
    if (std::find(placed_images.begin(), placed_images.end(), pid) != placed_images.end()) return;
    // A spare forked by an image already in `images/` is born there: no move (each costs a grace period).
    if (s.sandbox.cgroup.in_leaf(pid, sys::CgroupLeaf::Images) ||
        placer.place(s.sandbox.cgroup, pid, sys::CgroupLeaf::Images)) {
      placed_images.push_back(pid);
    }
  });
  // Forgotten once gone from the store (a resumed copy is placed in `live/` by place_live).
  std::erase_if(placed_images, [&](pid_t pid) { return std::find(now.begin(), now.end(), pid) == now.end(); });
}

void Warden::place_live(const ServiceRuntime& s) {
  (void)placer.place(s.sandbox.cgroup, s.proc.process.pid(), sys::CgroupLeaf::Live);
}

bool Warden::kill_live_leaf(const ServiceRuntime& s) {
  if (!s.sandbox.cgroup.valid() || !placer.idle()) return false;
  // A copy on its way (its pid unknown) may still be in the live leaf: the kill would take it with the strays
  // (a restored generation's spare, lost in the store: seen as a fallback and a cold restart).
  if (copies_pending(s.id)) {
    if (parts_.options.verbose) say("rollback: a copy of '%s' is on its way: no cgroup.kill", s.name.c_str());
    return false;
  }
  bool placed = true;
  for_each_copy(s.id, [&](const ServiceRuntime& owner, pid_t pid) {
    if (!placed) return;
    // Reported since the last sweep (a spare): asked where it is (one read of /proc/<pid>/cgroup).
    if (std::find(placed_images.begin(), placed_images.end(), pid) != placed_images.end()) return;
    placed = owner.sandbox.cgroup.in_leaf(pid, sys::CgroupLeaf::Images);
  });
  if (!placed) {
    if (parts_.options.verbose)
      say("rollback: an image of '%s' is not in its images leaf yet: no cgroup.kill", s.name.c_str());
    return false;
  }
  // Who is in it, for the count (one read of cgroup.procs): each one the kernel does not know (known_child,
  // as the sweep judges) is a stray, counted by the sweep after the rollback (recording a violation logs a
  // line: not here). A fallback retires the services again: by then the incarnation the rollback retired is
  // the reaper's and may still be in the leaf, stopped or dying — the kernel's, no stray. The live
  // incarnation, the common case, is looked at first.
  const std::vector<pid_t> members = s.sandbox.cgroup.members(sys::CgroupLeaf::Live);
  const auto ours = [&](pid_t pid) { return pid == s.proc.process.pid() || known_child(pid); };
  // Nothing but those (no stray): the live incarnation is stopped and killed after the rollback, off the
  // critical path, as without cgroups. Killed here, its exit (freeing its memory) ran beside the resume of
  // every image on two CPUs: rollback p50 0.68 -> 1.70 ms in real time (`rejuv bench realtime`), its resume
  // phase 0.55 -> 1.33 ms. The one-call kill is for what an attacker spawned, whose number it must not grow
  // with.
  if (std::ranges::all_of(members, ours)) return false;
  if (!s.sandbox.cgroup.kill_live()) return false;
  for (const pid_t pid : members) {
    if (!ours(pid)) killed_with_leaf.emplace_back(s.id, pid);
  }
  return true;
}

bool Warden::count_out_of_memory(ServiceRuntime& s, bool live_killed) {
  const std::optional<std::uint64_t> kills = s.sandbox.cgroup.live_oom_kills();
  if (!kills || *kills <= s.sandbox.oom_kills_seen) return false;
  const std::uint64_t n = *kills - s.sandbox.oom_kills_seen;
  s.sandbox.oom_kills_seen = *kills;
  if (live_killed && s.proc.loss_reason.empty()) s.proc.loss_reason = "out of memory (killed by the OOM killer)";
  record_violation(s, Violation::OutOfMemory,
                   std::to_string(n) + " process(es) of its live cgroup killed by the OOM killer" +
                       (live_killed ? ", its live incarnation among them" : ""));
  return true;
}

void Warden::record_violation(ServiceRuntime& s, Violation kind, std::string_view what) {
  if (kind != Violation::ImageLost) ++s.stats.sandbox_violations;  // a loss may be a fault as well: counted apart
  std::uint32_t detail = 0;
  switch (kind) {
    case Violation::ForbiddenCall: {
      ++s.stats.forbidden_calls;
      auto& calls = s.stats.calls_refused;
      auto it = std::find_if(calls.begin(), calls.end(), [&](const auto& c) { return c.first == what; });
      if (it != calls.end()) {
        ++it->second;
      } else if (calls.size() < kMaxNamedCalls) {
        calls.emplace_back(std::string(what), 1);
      }
      if (const auto nr = sys::syscall_number(what)) detail = static_cast<std::uint32_t>(*nr);
      // Not rate-limited: each one ends a process (and a stray sweep is bounded by the process limit).
      say("sandbox violation: '%s' made a forbidden system call: %.*s (mode %s)", s.name.c_str(),
          static_cast<int>(what.size()), what.data(), std::string(to_string(peers_.mode())).c_str());
      break;
    }
    case Violation::StrayProcess:
      ++s.stats.stray_processes;
      say("sandbox violation: '%s' left a process behind: %.*s (mode %s)", s.name.c_str(),
          static_cast<int>(what.size()), what.data(), std::string(to_string(peers_.mode())).c_str());
      break;
    case Violation::OutOfMemory:
      ++s.stats.out_of_memory;
      say("sandbox violation: '%s' ran its live cgroup out of memory: %.*s (mode %s)", s.name.c_str(),
          static_cast<int>(what.size()), what.data(), std::string(to_string(peers_.mode())).c_str());
      break;
    case Violation::ImageLost:
      // Nothing a service can reach signals an image (no signal to another process, no SIGIO owner): an image
      // gone from the store is a fault of the machine or an escape, reported as such, never silent.
      ++s.stats.images_lost;
      say("security: an image of '%s' was lost in the store: %.*s (mode %s)", s.name.c_str(),
          static_cast<int>(what.size()), what.data(), std::string(to_string(peers_.mode())).c_str());
      break;
  }
  rejuv_msg_SecurityEventKind event = rejuv_msg_SECURITY_FORBIDDEN_CALL;
  switch (kind) {
    case Violation::ForbiddenCall: event = rejuv_msg_SECURITY_FORBIDDEN_CALL; break;
    case Violation::StrayProcess: event = rejuv_msg_SECURITY_STRAY_PROCESS; break;
    case Violation::ImageLost: event = rejuv_msg_SECURITY_IMAGE_LOST; break;
    case Violation::OutOfMemory: event = rejuv_msg_SECURITY_OUT_OF_MEMORY; break;
  }
  peers_.publish_security_event(s.id, detail, event);
  // In MC the attacker has the service now: roll back at once rather than at the end of T_MC.
  if (peers_.rolls_back_on_violation() && peers_.mode() == SrMode::MC) {
    peers_.request_rollback("sandbox violation by '" + s.name + "': " + std::string(what));
  }
}

// An open while booting (open, openat): the kernel reads the path the call names and checks it against the
// service's Landlock rules (sys::path_within). Outside them: false, and `shown` the path as the log may show it
// (printable, bounded). Landlock enforces the same rules on the object opened, so a path changed after this
// read (TOCTOU) or reached by a symbolic link is still refused; this look is what names and counts the attempt.
bool Warden::boot_open_within_reach(const ServiceRuntime& s, const sys::SeccompNotice& notice, std::string& shown) {
  static const int open_nr = sys::syscall_number("open").value_or(-1);
  static const int openat_nr = sys::syscall_number("openat").value_or(-1);
  if (notice.nr != open_nr && notice.nr != openat_nr) return true;
  const std::uint64_t address = notice.nr == open_nr ? notice.args[0] : notice.args[1];
  auto path = sys::read_string_of(notice.pid, address, kMaxBootPath);
  if (!s.sandbox.seccomp.still_waiting(notice.id)) return true;  // gone meanwhile: nothing to decide
  const std::string text = path ? *path : std::string("(unreadable: ") + path.error().to_string() + ")";
  // A link's libraries (Cyclone's) are searched along a RUNPATH with "..": seen as the folder it names, as
  // Landlock sees the object; every other service's path must be plain (sys::path_within).
  const std::string seen = s.config.link && path ? std::filesystem::path(text).lexically_normal().string() : text;
  if (path && sys::path_within(landlock_rules(s), seen, notice.tgid)) return true;
  shown.clear();
  for (const char c : text.substr(0, 160)) shown += (c >= 0x20 && c < 0x7f) ? c : '?';
  return false;
}

void Warden::on_seccomp_notice(ServiceRuntime& s) {
  for (std::size_t i = 0; i < kNoticesPerWakeup && s.sandbox.seccomp.valid(); ++i) {
    auto got = s.sandbox.seccomp.receive();
    if (!got) {
      say("'%s': seccomp listener: %s", s.name.c_str(), got.error().to_string().c_str());
      close_sandbox(s);
      return;
    }
    if (!*got) return;
    const sys::SeccompNotice& notice = **got;
    // Only the live incarnation boots; images and anything else it made never run the loader or the SDK's
    // start-up, so their boot calls are violations too.
    const bool booting = s.proc.booting() && s.proc.process.pid() == notice.tgid;
    sys::NoticeKind kind = sys::classify(notice);
    std::string refused_path;
    if (booting && kind == sys::NoticeKind::BootCall && !boot_open_within_reach(s, notice, refused_path)) {
      kind = sys::NoticeKind::RefusedAtBoot;
    }
    if ((booting && kind == sys::NoticeKind::BootCall) || kind == sys::NoticeKind::SignalToSelf) {
      (void)s.sandbox.seccomp.allow(notice.id);  // decided on register values and the kernel's own state: no TOCTOU
      continue;
    }
    const std::string call = sys::syscall_name(notice.nr);
    if (booting && kind == sys::NoticeKind::RefusedAtBoot) {
      // No trusted boot phase: a boot call with arguments no start-up needs (an open for writing,
      // prlimit64 of another process or a new limit, an exec of its own, a prctl other than the SDK's) fails
      // with EPERM and is counted against the service; the call never ran, so it boots on.
      (void)s.sandbox.seccomp.refuse(notice.id, EPERM);
      if (!refused_path.empty()) {
        say("sandbox: '%s' at boot: %s of %s refused (EPERM): outside what a start-up reads (its binary, the "
            "libraries, its own /proc)",
            s.name.c_str(), call.c_str(), refused_path.c_str());
      } else {
        say("sandbox: '%s' at boot: %s(0x%llx, 0x%llx, 0x%llx) refused (EPERM): arguments no start-up needs",
            s.name.c_str(), call.c_str(), static_cast<unsigned long long>(notice.args[0]),
            static_cast<unsigned long long>(notice.args[1]), static_cast<unsigned long long>(notice.args[2]));
      }
      record_violation(s, Violation::ForbiddenCall, call);
      continue;
    }
    const bool live = s.live() && s.proc.process.pid() == notice.tgid;
    if (live && s.proc.loss_reason.empty()) {
      s.proc.loss_reason = "sandbox violation (forbidden system call " + call + ")";
    }
    // Killed while it waits in the call: the call never runs. The whole process, whichever of its threads
    // called (a pidfd names a process). The pidfd is opened before the notice is checked again, so a pid
    // reused meanwhile is never hit.
    const pid_t caller = notice.tgid > 0 ? notice.tgid : notice.pid;
    (void)sys::signal_if(caller, SIGKILL, [&] { return s.sandbox.seccomp.still_waiting(notice.id); });
    record_violation(s, Violation::ForbiddenCall, call);
    if (!live) sweep_due = "a forbidden call";  // a stray (its zombie is reaped by the sweep) or an image (the store sees it)
  }
}

void Warden::on_service_output(ServiceRuntime& s, bool final) {
  if (!s.sandbox.output.valid()) return;
  std::array<char, 4096> buf{};
  bool closed = false;
  for (std::size_t i = 0; i < kOutputReadsPerWakeup || final; ++i) {
    auto n = sys::read_some(s.sandbox.output.get(), buf);
    if (!n || !*n) break;       // error, or nothing waits
    if (**n == 0) {             // every writer is gone
      closed = true;
      break;
    }
    s.sandbox.output_partial.append(buf.data(), **n);
    std::size_t start = 0;
    for (;;) {
      const std::size_t nl = s.sandbox.output_partial.find('\n', start);
      const bool cut = nl == std::string::npos && s.sandbox.output_partial.size() - start >= kMaxOutputLine;
      if (nl == std::string::npos && !cut) break;
      const std::size_t end = cut ? start + kMaxOutputLine : nl;
      ++s.stats.output_lines;
      peers_.service_log(s, std::string_view(s.sandbox.output_partial).substr(start, end - start));
      start = cut ? end : nl + 1;
    }
    s.sandbox.output_partial.erase(0, start);
  }
  if (closed || final) {
    if (!s.sandbox.output_partial.empty()) {
      ++s.stats.output_lines;
      peers_.service_log(s, s.sandbox.output_partial);
      s.sandbox.output_partial.clear();
    }
  }
  if (closed) {
    (void)parts_.epoll.remove(s.sandbox.output.get());
    s.sandbox.output.reset();
  }
}

sys::SysResult<void> Warden::replace_output(ServiceRuntime& s, sys::UniqueFd read_end) {
  if (s.sandbox.output.valid()) {
    on_service_output(s, true);  // what the previous incarnation wrote, to its last partial line
    if (s.sandbox.output.valid()) (void)parts_.epoll.remove(s.sandbox.output.get());
  }
  s.sandbox.output = std::move(read_end);
  return parts_.epoll.add(s.sandbox.output.get(), token(Source::Output, s.id.value()));
}

void Warden::close_sandbox(ServiceRuntime& s) {
  if (s.sandbox.seccomp.valid()) {
    (void)parts_.epoll.remove(s.sandbox.seccomp.fd());
    s.sandbox.seccomp.close();
  }
  if (s.sandbox.output.valid()) {
    on_service_output(s, true);
    if (s.sandbox.output.valid()) (void)parts_.epoll.remove(s.sandbox.output.get());
    s.sandbox.output.reset();
  }
}

void Warden::sweep_if_due() {
  if (sweep_due) {
    sweep_strays(*sweep_due);
  } else if (peers_.now() - last_sweep >= kSweepPeriod) {
    sweep_strays("the periodic sweep");
  }
}

// Per service, whether a copy the kernel asked for (a spare, a Patch's image, an image at a checkpoint) is on
// its way: it is the kernel's child before its pid is reported, so such a service is swept once it has
// reported. The answers that have arrived are read first (waiting up to kCopiesWait for them with
// SweepWait::ForCopies), so that only copies really on their way defer a sweep. None at the final sweep.
std::vector<bool> Warden::copies_on_their_way(bool final, SweepWait wait) {
  std::vector<bool> pending(parts_.services.size(), false);
  const Nanos wait_until = peers_.wall() + (wait == SweepWait::ForCopies ? kCopiesWait : Nanos{0});
  for (;;) {
    peers_.settle_images();
    std::fill(pending.begin(), pending.end(), peers_.checkpoint_running() && !final);
    int answer_fd = -1;  // where the next Copied of a copy on its way arrives
    const auto note = [&](const image::Image& im) {
      if (im.spares_pending == 0 && !im.patch_pending) return;
      pending[im.service.value()] = !final;
      if (answer_fd < 0 && im.resume.valid()) answer_fd = im.resume.fd();
    };
    peers_.for_each_image(note);
    if (std::none_of(pending.begin(), pending.end(), [](bool p) { return p; }) || peers_.wall() >= wait_until)
      break;
    // On that copy's answer, not on epoll: the kernel's other fds may well be readable now (a spin).
    if (answer_fd < 0) break;
    (void)sys::wait_fd(answer_fd, sys::WaitFor::Readable, std::max(Nanos{0}, wait_until - peers_.wall()));
  }
  return pending;
}

bool Warden::known_child(pid_t pid) const {
  return peers_.knows_child(pid);
}

void Warden::sweep_strays(std::string_view when, bool final, SweepWait wait) {
  const std::vector<bool> pending = copies_on_their_way(final, wait);
  if (std::any_of(pending.begin(), pending.end(), [](bool p) { return p; })) {
    if (!sweep_due) sweep_due = when;
  } else {
    sweep_due.reset();
  }
  last_sweep = peers_.now();
  place_images();
  for (ServiceRuntime& s : parts_.services)
    (void)count_out_of_memory(s, false);  // a stray the OOM killer took
  auto children = sys::own_children();
  if (!children) return;
  const auto known = [&](pid_t pid) { return known_child(pid); };
  const auto killed_with_its_leaf = [&](pid_t pid) {
    return std::any_of(killed_with_leaf.begin(), killed_with_leaf.end(), [&](const auto& e) { return e.second == pid; });
  };
  for (const pid_t pid : *children) {
    if (!final && known(pid)) continue;
    if (killed_with_its_leaf(pid)) {  // killed with its live leaf at a rollback: reaped here, counted below
      if (auto stray = sys::ChildProcess::adopt_child(pid)) peers_.kill_and_reap_later(std::move(*stray));
      continue;
    }
    const auto sid = sys::session_of(pid);
    if (!sid) continue;
    for (ServiceRuntime& s : parts_.services) {
      if (std::find(s.sandbox.sessions.begin(), s.sandbox.sessions.end(), *sid) == s.sandbox.sessions.end()) continue;
      if (pending[s.id.value()]) break;  // one of its copies is on its way: next time
      if (final && known(pid)) break;  // shutdown: the known ones are killed and reaped by their owners
      // An image owed to an abandoned checkpoint (its Taken not read yet) is the kernel's own process: killed,
      // not counted. Until the next commit (rejuvenator.cpp), then a stray like any other.
      const bool owed = peers_.owes_image(s.id);
      // A copy the kernel made and no longer tracks (the patch of a generation retired while its base's copy
      // forked it; a spare of a generation let go once its copies had died or been resumed, at a fallback or
      // at shutdown): the kernel's own, killed, not counted — as many as the kernel let go of unheard, no
      // more. Where the process is says nothing: a restored incarnation forks in the images leaf until it is
      // moved to its live leaf (place_live, a grace period later), and a fork bomb there is strays, not
      // copies.
      const bool lost_copy = !owed && peers_.take_unheard_copy(s.id);
      // Killed at once and reaped later by the reaper: however many an attacker made, the sweep costs one
      // system call each, and none of their exits is waited for here (on the vehicle's critical path). Without
      // a pidfd (out of fds) by its pid: a stray is killed whatever the kernel's state.
      if (auto stray = sys::ChildProcess::adopt_child(pid)) {
        peers_.kill_and_reap_later(std::move(*stray));
      } else {
        (void)sys::kill_and_reap_own_child(pid);
      }
      if (lost_copy) {
        say("sweep: pid %d of '%s' is a copy the kernel asked for and lost track of: killed, not counted",
            pid, s.name.c_str());
        break;
      }
      if (owed) break;
      record_violation(s, Violation::StrayProcess,
                       "pid " + std::to_string(pid) + ", killed at " + std::string(when));
      break;
    }
  }
  for (const auto& [id, pid] : killed_with_leaf) {
    record_violation(parts_.services[id.value()], Violation::StrayProcess,
                     "pid " + std::to_string(pid) + ", killed with its live cgroup at a rollback");
  }
  killed_with_leaf.clear();
}

}  // namespace rejuv::kernel
