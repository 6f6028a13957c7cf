// The attacker's system calls are made here directly, not through kernel_sim/sys: this is the code of a
// compromised service, and what it calls is the point of the test (the sandbox must stop it).
#include "rejuv/attacks/hooks.hpp"

#include <arpa/inet.h>
#include <linux/io_uring.h>
#include <netinet/in.h>
#include <sched.h>
#include <signal.h>
#include <sys/ptrace.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <ctime>
#include <fstream>
#include <string>

#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/sdk/testing.hpp"

namespace rejuv::attacks {

namespace {

// A syscall's outcome as an Attempt code: 0 when it succeeded, its errno otherwise.
std::int64_t outcome(long rc) { return rc >= 0 ? 0 : errno; }

std::vector<std::byte> actuator_outputs_payload() {
  rejuv_msg_ActuatorOutputs out{};
  for (double& m : out.motor) m = 1.0;  // full thrust on every motor
  const auto bytes = std::as_bytes(std::span(&out, 1));
  return {bytes.begin(), bytes.end()};
}

// ESCAPE_HELPER's helper: a copy of the service made by a bare clone, so only system calls here (no
// allocation, no stdio, no SDK: the C library's locks and the channel belong to the service). It tries the
// network until something ends it; under the kernel the first try does.
[[noreturn]] void escaped_helper(std::uint16_t port) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  static constexpr char kText[] = "rejuv attack: escaped helper";
  constexpr auto kPause = std::chrono::duration_cast<std::chrono::nanoseconds>(kEscapePeriod);
  for (std::uint64_t i = 0;; ++i) {
    if (i % 2 == 0) {
      const long fd = ::syscall(SYS_socket, AF_INET, SOCK_DGRAM, 0);
      if (fd >= 0) {
        (void)::syscall(SYS_sendto, fd, kText, sizeof kText - 1, 0, &to, sizeof to);
        (void)::syscall(SYS_close, fd);
      }
    } else {
      io_uring_params params{};
      const long fd = ::syscall(SYS_io_uring_setup, 8, &params);
      if (fd >= 0) (void)::syscall(SYS_close, fd);
    }
    timespec pause{.tv_sec = 0, .tv_nsec = static_cast<long>(kPause.count())};
    (void)::syscall(SYS_nanosleep, &pause, nullptr);
  }
}

}  // namespace

bool sandboxed() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("Seccomp:", 0) == 0) return line.find('2') != std::string::npos;
  }
  return false;
}

AttackHooks::AttackHooks(sdk::Service& svc, RuntimeAttackPlan plan)
    : svc_(svc), plan_(std::move(plan)), under_filter_(sandboxed()), pgrp_(::getpid()) {
  clocks_.reserve(plan_.attacks.size());
  for (const RuntimeAttack& a : plan_.attacks) {
    if (occasion_of(a.kind) != Occasion::OnceAtBoot) clocks_.emplace_back(a, plan_.sr);  // also AtBootThenEveryWindow
  }
}

void AttackHooks::tick() {
  const Nanos now = svc_.now();
  const SrMode mode = svc_.mode();
  const Epoch epoch = svc_.epoch();
  bool any = false;
  for (WindowClock& c : clocks_) {
    if (!c.begins(now, mode, epoch)) continue;
    any = true;
    carry_out(c.attack().kind, c.ordinal());
  }
  if (any) ++windows_attacked_;
  // A sustained flood goes on at every tick of the window it began in (a rollback ends it: this memory too).
  if (flood_epoch_ && !any) {
    if (mode == SrMode::MC && epoch == *flood_epoch_) {
      flood(planned_count(AttackKind::FloodBroker));
    } else {
      flood_epoch_.reset();
    }
  }
}

void AttackHooks::report(AttackKind kind, std::string action, std::uint64_t target, std::int64_t code) {
  ++attempts_;
  if (code == 0) ++accepted_;
  if (reporter_) reporter_(Attempt{.kind = kind, .action = std::move(action), .target = target, .code = code});
}

std::vector<Slot> AttackHooks::never_held() const {
  std::uint32_t top = 0;
  for (const sdk::CapInfo& c : svc_.caps()) top = std::max(top, static_cast<std::uint32_t>(c.slot.value()));
  std::vector<Slot> out;
  for (std::uint32_t s = 0; s <= top + 2 && out.size() < 4; ++s) {
    const bool held = std::ranges::any_of(svc_.caps(), [&](const sdk::CapInfo& c) { return c.slot.value() == s; });
    if (!held) out.emplace_back(s);
  }
  out.emplace_back(1U << 20);     // beyond any CSpace
  out.emplace_back(0xFFFF'FFFFU);
  return out;
}

void AttackHooks::invoke_all(AttackKind kind, ObjectKind target_kind, cap::Operation op, std::uint64_t arg0,
                             std::uint64_t arg1, std::span<const std::byte> data) {
  // Its own caps of the kind the operation needs first (held, but not with the right in this mode), then
  // one cap of another kind (WrongObject), then slots it never held.
  std::vector<Slot> slots;
  const sdk::CapInfo* other = nullptr;
  for (const sdk::CapInfo& c : svc_.caps()) {
    if (c.kind == target_kind) {
      slots.push_back(c.slot);
    } else if (other == nullptr) {
      other = &c;
    }
  }
  if (other != nullptr) slots.push_back(other->slot);
  for (const Slot s : never_held()) slots.push_back(s);
  for (const Slot s : slots) {
    auto r = sdk::testing::invoke_slot(svc_, s, op, arg0, arg1, data);
    report(kind, std::string(cap::to_string(op)), s.value(), r ? 0 : std::max<std::int64_t>(r.error().wire_error, 1));
  }
}

void AttackHooks::publish_to(AttackKind kind, Slot slot, std::span<const std::byte> payload) {
  sdk::CapInfo forged{};
  forged.slot = slot;
  forged.object = "forged";
  (void)sdk::testing::publish_unchecked(svc_, forged, payload);
  report(kind, "Publish", slot.value(), Attempt::kFireAndForget);
}

void AttackHooks::carry_out(AttackKind kind, std::uint32_t variant) {
  attempts_ = 0;
  accepted_ = 0;
  switch (kind) {
    case AttackKind::InvokeCheckpoint:
      invoke_all(kind, ObjectKind::Checkpoint, cap::Operation::CheckpointCreate, 0, 0, {});
      invoke_all(kind, ObjectKind::Checkpoint, cap::Operation::CheckpointRollback, 0, 0, {});
      break;
    case AttackKind::ArmTimer:
      // A periodic 10 ms rejuvenation timer: the attacker would roll the vehicle back forever.
      invoke_all(kind, ObjectKind::Checkpoint, cap::Operation::TimerArm, 10'000'000, 1, {});
      break;
    case AttackKind::WriteLimits: write_limits(kind); break;
    case AttackKind::PublishActuatorOutputs: publish_actuator_outputs(kind); break;
    case AttackKind::WritePersistent: write_persistent(kind); break;
    case AttackKind::ForgedSlot: forged_slots(kind); break;
    case AttackKind::NetworkInSei: {
      static constexpr std::string_view kText = "rejuv attack: exfiltrate in the secure interval";
      invoke_all(kind, ObjectKind::Network, cap::Operation::NetSend, 0, 0,
                 std::as_bytes(std::span(kText.data(), kText.size())));
      break;
    }
    case AttackKind::KillImage: kill_image(variant); break;
    case AttackKind::OpenSocket: open_socket(variant); break;
    case AttackKind::FloodBroker: {
      const std::uint32_t per_tick = planned_count(kind);
      if (per_tick > 0) flood_epoch_ = svc_.epoch();
      if (const auto slot = flood(per_tick > 0 ? per_tick : kFloodMessages)) {
        report(AttackKind::FloodBroker,
               "Publish x" + std::to_string(per_tick > 0 ? per_tick : kFloodMessages) +
                   (per_tick > 0 ? " per tick" : ""),
               slot->value(), Attempt::kFireAndForget);
      }
      break;
    }
    case AttackKind::EscapeHelper: escape_helper(); break;
    case AttackKind::SigioImages:
    case AttackKind::SigioKernel:
    case AttackKind::SigioLogTrap:
    case AttackKind::StraySpinners:
    case AttackKind::StrayMemory:
    case AttackKind::SpinningThreads:
    case AttackKind::RetiredWorker:
    case AttackKind::WorkerRaise:
    case AttackKind::ForgedLog:
    case AttackKind::PagemapFrames:
    case AttackKind::OomImages: against_rollback(kind, variant, planned_count(kind)); break;
    case AttackKind::BootTimePage:
    case AttackKind::BootPrlimitKernel:
    case AttackKind::BootReadSecrets: hostile_from_boot(kind, variant); break;
  }
  if (!reporter_) {
    svc_.logf(sdk::LogLevel::Warn, "attack %.*s (epoch %u, %s): %u attempts, %u accepted",
              static_cast<int>(to_string(kind).size()), to_string(kind).data(),
              static_cast<unsigned>(svc_.epoch().value()), std::string(to_string(svc_.mode())).c_str(), attempts_,
              accepted_);
  }
}

std::uint32_t AttackHooks::planned_count(AttackKind kind) const {
  std::uint32_t count = 0;
  for (const RuntimeAttack& a : plan_.attacks) {
    if (a.kind == kind) count = a.count;
  }
  return count;
}

void AttackHooks::write_limits(AttackKind kind) {
  const std::array<double, 16> full{kForgedLimit, kForgedLimit, kForgedLimit, kForgedLimit, kForgedLimit,
                                    kForgedLimit, kForgedLimit, kForgedLimit, kForgedLimit, kForgedLimit,
                                    kForgedLimit, kForgedLimit, kForgedLimit, kForgedLimit, kForgedLimit,
                                    kForgedLimit};
  invoke_all(kind, ObjectKind::Limits, cap::Operation::LimitsWrite, 0, 0, std::as_bytes(std::span(full)));
}

void AttackHooks::publish_actuator_outputs(AttackKind kind) {
  const auto payload = actuator_outputs_payload();
  for (const sdk::CapInfo& c : svc_.caps()) {
    if (c.kind == ObjectKind::Topic) publish_to(kind, c.slot, payload);
  }
  for (const Slot s : never_held()) publish_to(kind, s, payload);
}

void AttackHooks::write_persistent(AttackKind kind) {
  std::array<std::byte, 8> bytes{};
  bytes.fill(kForgedPersistentByte);
  invoke_all(kind, ObjectKind::Persistent, cap::Operation::PersistentWrite, 0, 0, bytes);
}

void AttackHooks::forged_slots(AttackKind kind) {
  const auto payload = actuator_outputs_payload();
  const std::array<std::byte, 8> bytes{};
  for (const Slot s : never_held()) {
    publish_to(kind, s, payload);
    for (const auto& [op, arg0, data] :
         {std::tuple{cap::Operation::CheckpointCreate, std::uint64_t{0}, std::span<const std::byte>{}},
          std::tuple{cap::Operation::LimitsWrite, std::uint64_t{0}, std::span<const std::byte>(bytes)},
          std::tuple{cap::Operation::NetSend, std::uint64_t{0}, std::span<const std::byte>(bytes)},
          std::tuple{cap::Operation::ModeRequest, std::uint64_t{index_of(SrMode::MC)}, std::span<const std::byte>{}},
          std::tuple{cap::Operation::Copy, std::uint64_t{s.value() + 1U}, std::span<const std::byte>{}}}) {
      auto r = sdk::testing::invoke_slot(svc_, s, op, arg0, op == cap::Operation::Copy ? 0x7U : 0U, data);
      report(kind, std::string(cap::to_string(op)), s.value(), r ? 0 : std::max<std::int64_t>(r.error().wire_error, 1));
    }
  }
}

void AttackHooks::kill_image(std::uint32_t variant) {
  if (!under_filter_) {
    svc_.log(sdk::LogLevel::Warn, "attack KILL_IMAGE skipped: not under a seccomp filter");
    return;
  }
  const pid_t self = ::getpid();
  const pid_t parent = ::getppid();
  const pid_t guess = self + 1;  // images are forked from the service: the next pids are likely ones
  constexpr std::uint32_t kVariants = 5;
  for (std::uint32_t i = 0; i < kVariants; ++i) {
    const std::uint32_t v = (variant + i) % kVariants;
    // Say it first, and send it: the first forbidden call ends this process.
    static constexpr std::array<const char*, kVariants> kNames{"kill(parent, SIGKILL)", "kill(image guess, 0)",
                                                               "ptrace(ATTACH, image guess)",
                                                               "process_vm_readv(image guess)", "pidfd_open(parent)"};
    svc_.logf(sdk::LogLevel::Warn, "attack KILL_IMAGE: %s", kNames[v]);
    (void)svc_.flush();
    switch (v) {
      case 0: report(AttackKind::KillImage, "kill", static_cast<std::uint64_t>(parent), outcome(::kill(parent, SIGKILL))); break;
      case 1: report(AttackKind::KillImage, "kill", static_cast<std::uint64_t>(guess), outcome(::kill(guess, 0))); break;
      case 2:
        report(AttackKind::KillImage, "ptrace", static_cast<std::uint64_t>(guess),
               outcome(::ptrace(PTRACE_ATTACH, guess, nullptr, nullptr)));
        break;
      case 3: {
        std::array<std::byte, 64> buf{};
        iovec local{.iov_base = buf.data(), .iov_len = buf.size()};
        iovec remote{.iov_base = reinterpret_cast<void*>(0x400000), .iov_len = buf.size()};  // NOLINT: an address
        report(AttackKind::KillImage, "process_vm_readv", static_cast<std::uint64_t>(guess),
               outcome(::process_vm_readv(guess, &local, 1, &remote, 1, 0)));
        break;
      }
      default: {
        const long fd = ::syscall(SYS_pidfd_open, parent, 0);
        if (fd >= 0) ::close(static_cast<int>(fd));
        report(AttackKind::KillImage, "pidfd_open", static_cast<std::uint64_t>(parent), outcome(fd));
        break;
      }
    }
  }
}

void AttackHooks::open_socket(std::uint32_t variant) {
  if (!under_filter_) {
    svc_.log(sdk::LogLevel::Warn, "attack OPEN_SOCKET skipped: not under a seccomp filter");
    return;
  }
  constexpr std::uint32_t kVariants = 3;
  for (std::uint32_t i = 0; i < kVariants; ++i) {
    const std::uint32_t v = (variant + i) % kVariants;
    static constexpr std::array<const char*, kVariants> kNames{"socket(AF_INET, SOCK_DGRAM)", "socketpair(AF_UNIX)",
                                                               "socket(AF_UNIX, SOCK_SEQPACKET)"};
    svc_.logf(sdk::LogLevel::Warn, "attack OPEN_SOCKET: %s", kNames[v]);
    (void)svc_.flush();
    long rc = -1;
    if (v == 1) {
      std::array<int, 2> fds{-1, -1};
      rc = ::socketpair(AF_UNIX, SOCK_STREAM, 0, fds.data());
      for (const int fd : fds) {
        if (fd >= 0) ::close(fd);
      }
    } else {
      rc = ::socket(v == 0 ? AF_INET : AF_UNIX, v == 0 ? SOCK_DGRAM : SOCK_SEQPACKET, 0);
      if (rc >= 0) ::close(static_cast<int>(rc));
    }
    report(AttackKind::OpenSocket, kNames[v], 0, outcome(rc));
  }
}

std::optional<Slot> AttackHooks::flood(std::uint32_t messages) {
  // A topic it may write now (the broker's bounds are what is tested), else every topic it holds.
  std::vector<const sdk::CapInfo*> topics;
  for (const sdk::CapInfo& c : svc_.caps()) {
    if (c.kind == ObjectKind::Topic && c.rights_in(svc_.mode()).has(Right::Write)) {
      topics.push_back(&c);
      break;
    }
  }
  if (topics.empty()) {
    for (const sdk::CapInfo& c : svc_.caps()) {
      if (c.kind == ObjectKind::Topic) topics.push_back(&c);
    }
  }
  if (topics.empty()) return std::nullopt;
  std::vector<std::byte> payload;
  for (std::uint32_t i = 0; i < messages; ++i) {
    const sdk::CapInfo& c = *topics[i % topics.size()];
    payload.assign(std::max<std::size_t>(c.payload_size, 1), std::byte{0});
    (void)sdk::testing::publish_unchecked(svc_, c, payload);
  }
  return topics.front()->slot;
}

void AttackHooks::escape_helper() {
  if (!under_filter_) {
    svc_.log(sdk::LogLevel::Warn, "attack ESCAPE_HELPER skipped: not under a seccomp filter");
    return;
  }
  const std::uint16_t port = plan_.escape_port;
  // The image fork's flags, the only ones the filter lets a service clone a process with: the helper is the
  // kernel's child in the service's session, which is where the kernel looks for strays.
  const long pid = ::syscall(SYS_clone, CLONE_PARENT | SIGCHLD, 0, 0, 0, 0);
  if (pid == 0) escaped_helper(port);
  const int clone_errno = errno;
  report(AttackKind::EscapeHelper, "clone(CLONE_PARENT|SIGCHLD)", pid > 0 ? static_cast<std::uint64_t>(pid) : 0,
         outcome(pid));
  if (pid > 0) {
    svc_.logf(sdk::LogLevel::Warn, "attack ESCAPE_HELPER: helper pid %ld tries UDP to 127.0.0.1:%u and io_uring",
              pid, static_cast<unsigned>(port));
  } else {
    svc_.logf(sdk::LogLevel::Warn, "attack ESCAPE_HELPER: clone refused (errno %d)", clone_errno);
  }
}

Result<std::unique_ptr<AttackHooks>, PlanError> install(sdk::Service& svc) {
  auto plan = runtime_attack_plan(
      [&svc](std::string_view name) -> std::optional<double> {
        if (!svc.has_param(name)) return std::nullopt;
        return svc.param(name, 0.0);
      },
      [&svc](std::string_view name) { return std::string(svc.text_param(name, "")); });
  if (!plan) return fail(std::move(plan.error()));
  if (plan->attacks.empty()) return std::unique_ptr<AttackHooks>{};
  auto hooks = std::make_unique<AttackHooks>(svc, std::move(*plan));
  AttackHooks* raw = hooks.get();
  std::string kinds;
  bool windowed = false;
  for (const RuntimeAttack& a : raw->plan().attacks) {
    kinds += (kinds.empty() ? "" : ", ") + std::string(to_string(a.kind));
    if (occasion_of(a.kind) == Occasion::OnceAtBoot) {
      kinds += " at boot";
      continue;
    }
    if (occasion_of(a.kind) == Occasion::AtBootThenEveryWindow) kinds += " at boot and";
    windowed = true;
    if (a.start.count() > 0) kinds += " from t = " + std::to_string(a.start.count()) + " s";
    if (a.max_windows > 0) kinds += " in " + std::to_string(a.max_windows) + " window(s)";
  }
  svc.logf(sdk::LogLevel::Warn, "attack hooks armed: %s", kinds.c_str());
  if (windowed) {
    auto timer = svc.every(kTickPeriod, [raw] { raw->tick(); });
    if (!timer) {
      return fail(PlanError{.param = "attack", .message = "cannot arm the hooks' timer: " + timer.error().to_string()});
    }
  }
  for (const RuntimeAttack& a : raw->plan().attacks) {
    if (occasion_of(a.kind) != Occasion::EveryWindow) raw->carry_out(a.kind, kAtBoot);
  }
  return hooks;
}

}  // namespace rejuv::attacks

namespace rejuv::attacks {

Result<std::optional<LawAttack>, PlanError> law_attack_of(sdk::Service& svc,
                                                         std::initializer_list<flight::AttackLaw> laws) {
  auto plan = law_attack_plan(
      [&svc](std::string_view name) -> std::optional<double> {
        if (!svc.has_param(name)) return std::nullopt;
        return svc.param(name, 0.0);
      },
      [&svc](std::string_view name) { return std::string(svc.text_param(name, "")); }, laws);
  if (!plan) return fail(std::move(plan.error()));
  if (*plan) {
    const LawAttack& a = **plan;
    svc.logf(sdk::LogLevel::Warn, "attack hook armed: %s (magnitude %g) from t = %g s, %s",
             std::string(flight::to_string(a.law)).c_str(), a.magnitude, a.start.count(),
             a.max_windows == 0 ? "every MC window" : (std::to_string(a.max_windows) + " MC window(s)").c_str());
  }
  return plan;
}

}  // namespace rejuv::attacks
