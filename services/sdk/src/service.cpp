// The API of a service (service.hpp): identity, params and caps from the boot script, topics, timers,
// invocations, the network gate, logging, and the event loop (run) that hands the kernel's frames to them.
// The rest of the SDK sits beside it along its seams (service_impl.hpp lists the files).
#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>

#include "rejuv/clock/timers.hpp"
#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/sanitizer.hpp"
#include "rejuv/sdk/testing.hpp"
#include "service_impl.hpp"

#if defined(REJUV_ASAN)
// LeakSanitizer's check at exit stops the process with ptrace from a helper task, which a service's seccomp
// policy forbids (sys/seccomp.cpp): the check hung until the kernel's shutdown grace ran out and the
// service was killed. Services of an AddressSanitizer build leave leak checking to the tests themselves.
extern "C" int __lsan_is_turned_off() { return 1; }  // NOLINT(bugprone-reserved-identifier)
#endif

namespace rejuv::sdk {

bool CapInfo::ever(Right r) const {
  for (const Rights& x : rights) {
    if (x.has(r)) return true;
  }
  return false;
}

// ---- subscriptions ----

void detail::SubscriptionBase::deliver(std::uint64_t generation, std::span<const std::byte> payload) {
  // Generations of a topic are consecutive; a gap means the kernel clamped our cursor (ring overrun).
  // A rollback may send generations back (docs/design.md §7): that is not a loss.
  if (received_ > 0 && generation > generation_ + 1) {
    lost_ += generation - generation_ - 1;
  }
  generation_ = generation;
  ++received_;
  updated_ = true;
  store_and_notify(payload);
}

// ---- identity, params, caps ----

std::string_view Service::name() const { return impl_->name; }
ServiceId Service::id() const { return impl_->id; }
Nanos Service::now() const { return impl_->time.read().now; }
SrMode Service::mode() const { return impl_->time.read().mode; }
Epoch Service::epoch() const { return impl_->time.read().epoch; }

double Service::param(std::string_view name, double fallback) const {
  for (const Param& p : impl_->params) {
    if (p.name == name && !p.is_text) return p.is_integer ? static_cast<double>(p.integer) : p.number;
  }
  return fallback;
}
std::optional<graph_values::Value> Service::param_value(std::string_view name) const {
  for (const Param& p : impl_->params) {
    if (p.name != name) continue;
    if (p.is_text) return graph_values::Value{std::numeric_limits<double>::quiet_NaN()};
    if (p.is_integer) return graph_values::Value{p.integer};
    return graph_values::Value{p.number};
  }
  return std::nullopt;
}
std::string_view Service::text_param(std::string_view name, std::string_view fallback) const {
  for (const Param& p : impl_->params) {
    if (p.name == name && p.is_text) return p.text;
  }
  return fallback;
}
bool Service::has_param(std::string_view name) const {
  for (const Param& p : impl_->params) {
    if (p.name == name) return true;
  }
  return false;
}

std::span<const CapInfo> Service::caps() const { return impl_->caps; }

SdkResult<const CapInfo*> Service::cap(std::string_view object) const {
  for (const CapInfo& c : impl_->caps) {
    if (c.object == object) return &c;
  }
  // What to add, and what it holds: the usual cause is a grant the policy lacks (or a misspelt name).
  std::string held;
  for (const CapInfo& c : impl_->caps) held += (held.empty() ? "" : ", ") + c.object;
  return error(SdkError::NoSuchObject,
               "'" + std::string(object) + "': '" + impl_->name + "' holds no capability to it; the policy needs a line " +
                   "grants { service: \"" + impl_->name + "\" object: \"" + std::string(object) +
                   "\" rights: \"R\" (or \"W\") modes: [...] } (it holds: " + (held.empty() ? "nothing" : held) + ")");
}

SdkResult<const CapInfo*> Service::topic_cap(std::string_view object, std::string_view type, std::size_t size,
                                             Right needed) const {
  auto found = cap(object);
  if (!found) return found;
  const CapInfo& c = **found;
  if (c.kind != ObjectKind::Topic) return error(SdkError::WrongObjectKind, std::string(object) + " is not a topic");
  if (c.type != type || c.payload_size != size) {
    return error(SdkError::TypeMismatch, std::string(object) + " carries " + c.type + " (" +
                                             std::to_string(c.payload_size) + " bytes), not " + std::string(type) +
                                             " (" + std::to_string(size) + " bytes)");
  }
  if (!c.ever(needed)) {
    return error(SdkError::NeverGranted, std::string(object) + ": the policy grants " +
                                             (needed == Right::Write ? "no Write" : "no Read") + " in any mode");
  }
  return found;
}

SdkResult<void> Service::publish_bytes(const CapInfo& cap, std::span<const std::byte> payload, bool check_mode) {
  if (check_mode && !cap.rights_in(mode()).has(Right::Write)) {
    return error(SdkError::NotHeldInMode, cap.object);
  }
  if (!impl_->tx.build(wire::FrameKind::Publish, cap.slot.value(), 0, 0, payload)) {
    return error(SdkError::BadArgument, "payload too large");
  }
  return impl_->send_built();
}

namespace {

// A subscription to a topic of any type: its payload handed over as bytes (subscribe_untyped).
class UntypedSubscription final : public detail::SubscriptionBase {
 public:
  UntypedSubscription(Slot slot, std::string object, std::size_t size,
                      std::function<void(std::span<const std::byte>)> on_message)
      : SubscriptionBase(slot, std::move(object)), size_(size), on_message_(std::move(on_message)) {}
  [[nodiscard]] std::size_t size() const override { return size_; }

 private:
  void store_and_notify(std::span<const std::byte> payload) override {
    if (on_message_) on_message_(payload);
  }
  std::size_t size_;
  std::function<void(std::span<const std::byte>)> on_message_;
};

}  // namespace

SdkResult<void> Service::subscribe_untyped(std::string_view object,
                                           std::function<void(std::span<const std::byte>)> on_message) {
  auto found = cap(object);
  if (!found) return fail(std::move(found.error()));
  const CapInfo& c = **found;
  auto typed = topic_cap(object, c.type, c.payload_size, Right::Read);
  if (!typed) return fail(std::move(typed.error()));
  if (auto sent = request_subscribe(c, false); !sent) return fail(std::move(sent.error()));
  add_subscription(std::make_unique<UntypedSubscription>(c.slot, c.object, c.payload_size, std::move(on_message)));
  return {};
}

SdkResult<void> Service::publish_untyped(std::string_view object, std::span<const std::byte> payload) {
  auto found = cap(object);
  if (!found) return fail(std::move(found.error()));
  const CapInfo& c = **found;
  auto typed = topic_cap(object, c.type, payload.size(), Right::Write);
  if (!typed) return fail(std::move(typed.error()));
  return publish_bytes(c, payload, true);
}

SdkResult<void> Service::request_subscribe(const CapInfo& cap, bool polled) {
  if (cap.slot.value() < impl_->subscription_by_slot.size() &&
      impl_->subscription_by_slot[cap.slot.value()] != nullptr) {
    return error(SdkError::AlreadySubscribed, cap.object);
  }
  const std::uint32_t seq = ++impl_->seq;
  if (!impl_->tx.build(wire::FrameKind::Subscribe, cap.slot.value(), seq, polled ? wire::kSubscribePolled : 0)) {
    return error(SdkError::Protocol);
  }
  auto reply = impl_->request({}, "subscribe " + cap.object);
  if (!reply) return std::unexpected(reply.error());
  return {};
}

detail::SubscriptionBase* Service::add_subscription(std::unique_ptr<detail::SubscriptionBase> sub) {
  detail::SubscriptionBase* raw = sub.get();
  const std::size_t slot = raw->slot().value();
  if (slot >= impl_->subscription_by_slot.size()) impl_->subscription_by_slot.resize(slot + 1, nullptr);
  impl_->subscription_by_slot[slot] = raw;
  impl_->subscriptions.push_back(std::move(sub));
  return raw;
}

// ---- timers ----

SdkResult<Timer> Service::arm_timer(Nanos first, Nanos period, std::function<void()> on_fire) {
  if (first.count() < 0 || (period.count() != 0 && period < clock::kMinTimerPeriod)) {
    return error(SdkError::BadArgument, "timer period below " + std::to_string(clock::kMinTimerPeriod.count()) + " ns");
  }
  std::size_t index = kMaxTimers;
  for (std::size_t i = 0; i < kMaxTimers; ++i) {
    if (!impl_->timers[i].armed) {
      index = i;
      break;
    }
  }
  if (index == kMaxTimers) return error(SdkError::TooManyTimers);
  // Ids carry a serial above the index, so a TimerFired of a cancelled timer never reaches its successor.
  const std::uint64_t id = (++impl_->timer_serial << 8U) | index;
  const wire::TimerSpec spec{.id = id,
                             .first_ns = static_cast<std::uint64_t>(first.count()),
                             .period_ns = static_cast<std::uint64_t>(period.count())};
  if (!impl_->tx.build_with(wire::FrameKind::TimerArm, 0, 0, 0, spec)) return error(SdkError::Protocol);
  if (auto s = impl_->send_built(); !s) return std::unexpected(s.error());
  impl_->timers[index] = TimerSlot{.id = id, .armed = true, .periodic = period.count() != 0, .on_fire = std::move(on_fire)};
  return Timer(this, id);
}

SdkResult<Timer> Service::every(Nanos period, std::function<void()> on_fire, std::optional<Nanos> phase) {
  if (period.count() <= 0) return error(SdkError::BadArgument, "period must be positive");
  return arm_timer(now() + phase.value_or(period), period, std::move(on_fire));
}

SdkResult<Timer> Service::after(Nanos delay, std::function<void()> on_fire) {
  if (delay.count() < 0) return error(SdkError::BadArgument, "negative delay");
  return arm_timer(now() + delay, Nanos(0), std::move(on_fire));
}

SdkResult<void> Service::cancel(const Timer& timer) {
  TimerSlot* slot = impl_->timer_slot(timer.id());
  if (slot == nullptr) return error(SdkError::NoSuchTimer);
  if (!impl_->tx.build(wire::FrameKind::TimerCancel, 0, 0, timer.id())) return error(SdkError::Protocol);
  if (auto s = impl_->send_built(); !s) return std::unexpected(s.error());
  slot->armed = false;
  slot->on_fire = nullptr;
  return {};
}

SdkResult<void> Timer::cancel() const { return service_->cancel(*this); }

// ---- invocations ----

SdkResult<Slot> Service::object_slot(std::string_view object, ObjectKind kind) const {
  auto found = cap(object);
  if (!found) return std::unexpected(found.error());
  if ((*found)->kind != kind) {
    return error(SdkError::WrongObjectKind,
                 std::string(object) + " is not a " + std::string(rejuv::to_string(kind)) + " object");
  }
  return (*found)->slot;
}

template <class Handle>
SdkResult<Handle> Service::object_handle(std::string_view object, ObjectKind kind) {
  auto slot = object_slot(object, kind);
  if (!slot) return std::unexpected(slot.error());
  return Handle(this, *slot);
}

SdkResult<ModeControl> Service::mode_control(std::string_view object) {
  return object_handle<ModeControl>(object, ObjectKind::Mode);
}
SdkResult<LimitsCell> Service::limits(std::string_view object) {
  return object_handle<LimitsCell>(object, ObjectKind::Limits);
}
SdkResult<PersistentCell> Service::persistent(std::string_view object) {
  return object_handle<PersistentCell>(object, ObjectKind::Persistent);
}
SdkResult<Rejuvenation> Service::rejuvenation(std::string_view object) {
  return object_handle<Rejuvenation>(object, ObjectKind::Checkpoint);
}

// The handles' calls, in the wire's conventions (docs/protocol.md "Invoke": arg0, arg1, data, reply data).
namespace {
SdkResult<void> done(SdkResult<InvokeReply> reply) {
  if (!reply) return std::unexpected(reply.error());
  return {};
}
}  // namespace

SdkResult<void> ModeControl::request(SrMode mode) const {
  return done(service_->invoke_slot(slot_, cap::Operation::ModeRequest, static_cast<std::uint64_t>(index_of(mode))));
}
SdkResult<void> LimitsCell::write(std::span<const std::byte> record) const {
  return done(service_->invoke_slot(slot_, cap::Operation::LimitsWrite, 0, 0, record));
}
SdkResult<std::size_t> LimitsCell::read(std::span<std::byte> out) const {
  auto reply = service_->invoke_slot(slot_, cap::Operation::LimitsRead, 0, 0, {}, out);
  if (!reply) return std::unexpected(reply.error());
  return static_cast<std::size_t>(reply->value);
}
SdkResult<std::size_t> PersistentCell::read(std::span<std::byte> out) const {
  auto reply = service_->invoke_slot(slot_, cap::Operation::PersistentRead, 0, out.size(), {}, out);
  if (!reply) return std::unexpected(reply.error());
  return static_cast<std::size_t>(reply->value);
}
SdkResult<void> PersistentCell::write(std::span<const std::byte> data) const {
  return done(service_->invoke_slot(slot_, cap::Operation::PersistentWrite, 0, 0, data));
}
SdkResult<Nanos> Rejuvenation::arm_timer(Nanos after, Nanos period) const {
  auto reply = service_->invoke_slot(slot_, cap::Operation::TimerArm, static_cast<std::uint64_t>(after.count()),
                                     static_cast<std::uint64_t>(period.count()));
  if (!reply) return std::unexpected(reply.error());
  return Nanos{static_cast<std::int64_t>(reply->value)};
}
SdkResult<void> Rejuvenation::roll_back() const {
  return done(service_->invoke_slot(slot_, cap::Operation::CheckpointRollback));
}

SdkResult<CheckpointOutcome> Service::checkpoint(std::string_view object) {
  auto slot = object_slot(object, ObjectKind::Checkpoint);
  if (!slot) return std::unexpected(slot.error());
  auto reply = invoke_slot(*slot, cap::Operation::CheckpointCreate);
  if (!reply) {
    if (reply.error().code == SdkError::RolledBack && impl_->restored) return *impl_->restored;
    return std::unexpected(reply.error());
  }
  return CheckpointOutcome{.kind = CheckpointOutcome::Kind::Taken, .generation = Generation{reply->value},
                           .epoch = epoch()};
}

SdkResult<void> Service::spawn_worker(std::function<void(WorkerContext&)> body) {
  if (!body) return error(SdkError::BadArgument, "empty worker body");
  if (impl_->workers == nullptr) impl_->workers = new WorkerSet(0);  // NOLINT(cppcoreguidelines-owning-memory)
  if (impl_->workers->size() >= kMaxWorkers) return error(SdkError::BadArgument, "too many workers");
  if (const int e = impl_->workers->spawn(std::move(body)); e != 0) {
    return error(SdkError::Resources, "a worker thread: " + sys::SysError{"pthread_create", e}.to_string());
  }
  return {};
}

SdkResult<InvokeReply> Service::invoke_slot(Slot slot, cap::Operation op, std::uint64_t arg0, std::uint64_t arg1,
                                            std::span<const std::byte> data, std::span<std::byte> out) {
  wire::InvokeHeader head{};
  head.operation = static_cast<std::uint8_t>(op);
  head.arg0 = arg0;
  head.arg1 = arg1;
  const std::uint32_t seq = ++impl_->seq;
  if (!impl_->tx.build_with(wire::FrameKind::Invoke, slot.value(), seq, 0, head, data)) {
    return error(SdkError::BadArgument, "invoke data too large");
  }
  return impl_->request(out, std::string(cap::to_string(op)));
}

// ---- network ----

SdkResult<void> Service::on_datagram(std::string_view object, std::function<void(std::span<const std::byte>)> handler) {
  auto found = cap(object);
  if (!found) return std::unexpected(found.error());
  const CapInfo& c = **found;
  if (c.kind != ObjectKind::Network) return error(SdkError::WrongObjectKind, std::string(object) + " is not a Network object");
  if (!c.ever(Right::Read)) return error(SdkError::NeverGranted, std::string(object) + ": the policy grants no Read in any mode");
  for (const auto& h : impl_->datagram_handlers) {
    if (h.first == c.slot.value()) return error(SdkError::AlreadySubscribed, std::string(object));
  }
  impl_->datagram_handlers.emplace_back(c.slot.value(), std::move(handler));
  return {};
}

SdkResult<void> Service::send_datagram(std::string_view object, std::span<const std::byte> datagram) {
  auto found = cap(object);
  if (!found) return std::unexpected(found.error());
  const CapInfo& c = **found;
  if (c.kind != ObjectKind::Network) return error(SdkError::WrongObjectKind, std::string(object) + " is not a Network object");
  if (datagram.empty() || datagram.size() > wire::kMaxDatagramBytes) {
    return error(SdkError::BadArgument, "a datagram has 1 to " + std::to_string(wire::kMaxDatagramBytes) + " bytes");
  }
  if (!c.rights_in(mode()).has(Right::Write)) return error(SdkError::NotHeldInMode, c.object);
  auto reply = invoke_slot(c.slot, cap::Operation::NetSend, 0, 0, datagram);
  if (!reply) return std::unexpected(reply.error());
  return {};
}

SdkResult<void> Service::judge_datagram(std::string_view object, std::uint32_t verdict) {
  auto found = cap(object);
  if (!found) return std::unexpected(found.error());
  const CapInfo& c = **found;
  if (c.kind != ObjectKind::Network) return error(SdkError::WrongObjectKind, std::string(object) + " is not a Network object");
  if (impl_->datagram_id == 0) return error(SdkError::BadArgument, "judge_datagram outside an on_datagram handler");
  if (verdict >= kernel_net_verdict_codes) {
    return error(SdkError::BadArgument, "a verdict is 0 (valid) or a reason 1 … " + std::to_string(kernel_net_verdict_codes - 1));
  }
  if (!c.rights_in(mode()).has(Right::Read)) return error(SdkError::NotHeldInMode, c.object);
  const std::uint64_t id = std::exchange(impl_->datagram_id, 0);  // one verdict per datagram
  auto reply = invoke_slot(c.slot, cap::Operation::NetReceive, id, verdict);
  if (!reply) return std::unexpected(reply.error());
  return {};
}

bool Service::may_send(std::string_view object) const {
  auto found = cap(object);
  return found && (*found)->rights_in(mode()).has(Right::Write);
}

// ---- log ----

void Service::log(LogLevel level, std::string_view text) {
  wire::LogHeader head{};
  head.level = static_cast<std::uint8_t>(level);
  const std::span<const std::byte> bytes = std::as_bytes(std::span(text.data(), std::min(text.size(), wire::kMaxLogText)));
  if (impl_->tx.build_with(wire::FrameKind::Log, 0, 0, 0, head, bytes)) {
    (void)impl_->send_built();
  }
}

void Service::logf(LogLevel level, const char* format, ...) {
  std::array<char, wire::kMaxLogText + 1> buf{};
  va_list args;
  va_start(args, format);
  const int n = std::vsnprintf(buf.data(), buf.size(), format, args);
  va_end(args);
  if (n < 0) return;
  log(level, std::string_view(buf.data(), std::min<std::size_t>(static_cast<std::size_t>(n), wire::kMaxLogText)));
}

// ---- event loop ----

void Service::stop(int exit_code) {
  impl_->stopping = true;
  impl_->exit_code = exit_code;
}

void Service::on_shutdown(std::function<void()> fn) { impl_->on_shutdown = std::move(fn); }
void Service::on_restored(std::function<void(Epoch)> fn) { impl_->on_restored = std::move(fn); }

// ---- the raw surface (testing.hpp) ----

namespace testing {
SdkResult<void> RawAccess::send_raw(Service& svc, std::span<const std::byte> frame) { return svc.impl_->send(frame); }
SdkResult<InvokeReply> RawAccess::invoke(Service& svc, std::string_view object, cap::Operation op, std::uint64_t arg0,
                                         std::uint64_t arg1, std::span<const std::byte> data, std::span<std::byte> out) {
  auto found = svc.cap(object);
  if (!found) return std::unexpected(found.error());
  return svc.invoke_slot((*found)->slot, op, arg0, arg1, data, out);
}
SdkResult<InvokeReply> RawAccess::invoke_slot(Service& svc, Slot slot, cap::Operation op, std::uint64_t arg0,
                                              std::uint64_t arg1, std::span<const std::byte> data,
                                              std::span<std::byte> out) {
  return svc.invoke_slot(slot, op, arg0, arg1, data, out);
}
SdkResult<void> RawAccess::publish_unchecked(Service& svc, const CapInfo& cap, std::span<const std::byte> payload) {
  return svc.publish_bytes(cap, payload, false);
}
}  // namespace testing

int Service::run() {
  Impl& s = *impl_;
  if (!s.ready_sent) {
    if (!s.tx.build(wire::FrameKind::Ready, 0, 0, 0) || !s.send_built()) return 1;
    s.ready_sent = true;
  }
  std::vector<std::byte> held;  // a queued frame being handled (rx may be reused meanwhile)
  while (!s.stopping) {
    std::span<const std::byte> bytes;
    if (!s.queued.empty()) {
      held = std::move(s.queued.front());
      s.queued.pop_front();
      bytes = held;
    } else {
      const auto got = s.read_frame();
      if (!got) return got.error();
      if (!*got) continue;
      bytes = std::span<const std::byte>(s.rx.data(), **got);
    }
    if (s.restored_pending) {
      s.resume_incarnation(bytes);
      continue;
    }
    if (const std::optional<int> code = s.handle(bytes)) return *code;
    s.report_time_stalls();
  }
  (void)s.flush();
  return s.exit_code;
}

std::expected<std::optional<std::size_t>, int> Service::Impl::read_frame() {
  auto got = receive(false);
  if (got && !*got) {
    // Drained: everything received has been handled.
    if (!report_idle()) return std::unexpected(1);
    if (!flush()) return std::unexpected(1);
    got = receive(true);  // sleeps in recvmmsg until the next frame: the wait is the read
    prepare_pages_fd();   // if no Committed came (a kernel that does not send it): not inside a checkpoint
  }
  if (!got) {
    if (got.error().code == SdkError::ChannelClosed) return std::unexpected(1);
    std::fprintf(stderr, "[%s] channel: %s\n", name.c_str(), got.error().to_string().c_str());
    return std::unexpected(1);
  }
  return *got;
}

// A read of the time page that found no consistent sample in its bound (clock::kTimePageTries) used the last
// one instead; said once per new stall on stderr, which the kernel logs under this service's name.
void Service::Impl::report_time_stalls() {
  if (time.stalls() == time_stalls_reported) return;
  std::fprintf(stderr, "[%s] time page: %llu read(s) found no consistent sample in the bound; used the last one\n",
               name.c_str(), static_cast<unsigned long long>(time.stalls() - time_stalls_reported));
  time_stalls_reported = time.stalls();
}

bool Service::Impl::report_idle() {
  if ((lockstep || sync_asked) && frames_received != idle_reported) {
    if (!tx.build(wire::FrameKind::Idle, 0, 0, frames_received) || !send_built()) return false;
    idle_reported = frames_received;
  }
  sync_asked = false;
  return true;
}

void Service::Impl::resume_incarnation(std::span<const std::byte> frame) {
  // A rollback resumed this process (take_image returned true, here or inside a call's request) and this
  // is the first frame of the new incarnation: the kernel has finished the rollback, so the time page
  // shows the new epoch. The author's hook runs before the frame is handled (kept in `queued`, its fds
  // aside: the hook may make requests of its own, which read the channel).
  restored_pending = false;
  queued.emplace_front(frame.begin(), frame.end());
  std::vector<sys::UniqueFd> fds = std::move(rx_fds);
  if (on_restored) on_restored(restored->epoch);
  rx_fds = std::move(fds);
}

std::optional<int> Service::Impl::handle(std::span<const std::byte> bytes) {
  auto frame = wire::decode(bytes, wire::Direction::ToService);
  if (!frame) {
    ++bad_frames;
    return std::nullopt;
  }
  switch (frame->kind) {
    case wire::FrameKind::Deliver: handle_deliver(*frame); break;
    case wire::FrameKind::TimerFired: handle_timer_fired(*frame); break;
    case wire::FrameKind::Shutdown:
      if (on_shutdown) on_shutdown();
      (void)flush();
      return 0;
    case wire::FrameKind::Snapshot: {
      auto resumed = take_image(frame->header.aux, wire::payload_as<wire::SnapshotBody>(*frame).base);
      if (!resumed) {
        std::fprintf(stderr, "[%s] checkpoint: %s\n", name.c_str(), resumed.error().to_string().c_str());
        return 1;
      }
      break;  // live or restored: the loop goes on (a restored image on its new channel)
    }
    case wire::FrameKind::Committed:  // docs/design.md §7: the next image's record file, in the slack after the commit
      prepare_pages_fd();
      break;
    case wire::FrameKind::Sync:  // docs/protocol.md "Idle": the Idle once drained, in real time too
      sync_asked = true;
      break;
    case wire::FrameKind::NetDatagram: handle_datagram(*frame); break;
    case wire::FrameKind::Reply:           // a reply nobody waits for
    case wire::FrameKind::Boot:
    case wire::FrameKind::BootCap:
    case wire::FrameKind::BootParam:
    case wire::FrameKind::BootEnd:
    case wire::FrameKind::Resume:       // only ever on an image's resume socket
    case wire::FrameKind::Fork:
    case wire::FrameKind::Patch:
      ++bad_frames;
      break;
    case wire::FrameKind::Hello:
    case wire::FrameKind::Publish:
    case wire::FrameKind::Subscribe:
    case wire::FrameKind::Invoke:
    case wire::FrameKind::TimerArm:
    case wire::FrameKind::TimerCancel:
    case wire::FrameKind::Log:
    case wire::FrameKind::Idle:
    case wire::FrameKind::Ready:
    case wire::FrameKind::Taken:
    case wire::FrameKind::TakenPages:
    case wire::FrameKind::Resumed:
    case wire::FrameKind::Copied:
      ++bad_frames;  // decode() refuses service → kernel kinds here; unreachable
      break;
  }
  return std::nullopt;
}

void Service::Impl::handle_deliver(const wire::FrameView& frame) {
  const std::uint32_t slot = frame.header.slot;
  detail::SubscriptionBase* sub = slot < subscription_by_slot.size() ? subscription_by_slot[slot] : nullptr;
  if (sub == nullptr || frame.payload.size() != sub->size()) {
    ++bad_frames;
    return;
  }
  sub->deliver(frame.header.aux, frame.payload);
}

void Service::Impl::handle_timer_fired(const wire::FrameView& frame) {
  TimerSlot* slot = timer_slot(frame.header.aux);
  if (slot == nullptr) return;  // cancelled meanwhile, or no id of ours
  TimerSlot& t = *slot;
  if (!t.periodic) {
    t.armed = false;
    const std::function<void()> fn = std::move(t.on_fire);
    t.on_fire = nullptr;
    if (fn) fn();
  } else if (t.on_fire) {
    t.on_fire();
  }
}

// The network gate (docs/protocol.md): slot = our Network cap.
void Service::Impl::handle_datagram(const wire::FrameView& frame) {
  const auto handler = std::find_if(datagram_handlers.begin(), datagram_handlers.end(),
                                    [&](const auto& h) { return h.first == frame.header.slot; });
  if (handler == datagram_handlers.end() || frame.payload.size() > datagram.size()) {
    ++bad_frames;
    return;
  }
  const std::size_t n = frame.payload.size();
  std::memcpy(datagram.data(), frame.payload.data(), n);
  datagram_id = frame.header.aux;
  handler->second(std::span<const std::byte>(datagram.data(), n));
  datagram_id = 0;
}

}  // namespace rejuv::sdk
