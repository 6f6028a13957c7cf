#include "rejuv/bench/dds_ping_pong.hpp"

#include <unistd.h>

#include <cstring>

#include "endpoint.hpp"
#include "rejuv/bench/latency.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::bench {

namespace {

constexpr auto kFirstReplyRetry = std::chrono::milliseconds{200};
constexpr std::uint64_t kProbeSeqBase = std::uint64_t{1} << 62;  // never a measured sequence number
constexpr auto kEchoExitGrace = std::chrono::seconds{5};

std::uint64_t seq_of(std::span<const std::byte> sample) {
  std::uint64_t seq = 0;
  std::memcpy(&seq, sample.data(), sizeof seq);
  return seq;
}

}  // namespace

std::string_view to_string(DdsPath path) {
  switch (path) {
    case DdsPath::RawWaitset: return "raw_waitset";
    case DdsPath::BridgeEventFd: return "bridge_eventfd";
  }
  return "?";
}

struct DdsPingPong::Impl {
  PingPongOptions options;
  const msgs::TopicType* type = nullptr;
  std::unique_ptr<detail::PingEndpoint> endpoint;
  sys::SeqPacket control;  // the echo runs until this closes
  sys::ChildProcess echo;
  std::vector<std::max_align_t> payload;  // aligned for the topic struct

  ~Impl() {
    control.close();  // the echo sees EOF on its fd 0 and exits 0
    if (echo.running()) {
      (void)sys::wait_fd(echo.pidfd(), sys::WaitFor::Readable, Nanos{kEchoExitGrace});
      // kill_and_reap in ~ChildProcess covers an echo that did not exit.
    }
    endpoint.reset();
  }

  std::span<std::byte> payload_bytes() {
    return std::as_writable_bytes(std::span(payload)).first(type->size);
  }

  // Sends `seq` and waits up to `timeout` for its echo; false on timeout. Stale echoes are skipped.
  Result<bool, std::string> ping(std::uint64_t seq, Nanos timeout) {
    std::memcpy(payload_bytes().data(), &seq, sizeof seq);
    if (auto ok = endpoint->write(payload_bytes()); !ok) return fail(ok.error());
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    bool got = false;
    while (!got) {
      const Nanos left = std::chrono::duration_cast<Nanos>(deadline - std::chrono::steady_clock::now());
      if (left <= Nanos{0}) return false;
      auto n =
          endpoint->wait_take(left, [&](std::span<const std::byte> s) { got = got || seq_of(s) == seq; });
      if (!n) return fail(n.error());
    }
    return true;
  }
};

DdsPingPong::DdsPingPong(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DdsPingPong::DdsPingPong(DdsPingPong&&) noexcept = default;
DdsPingPong& DdsPingPong::operator=(DdsPingPong&&) noexcept = default;
DdsPingPong::~DdsPingPong() = default;

std::size_t DdsPingPong::payload_size() const {
  return impl_->type->size;
}

Result<DdsPingPong, std::string> DdsPingPong::start(const PingPongOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->type = msgs::find_topic_type(options.type_name);
  if (impl->type == nullptr) return fail("unknown topic type " + options.type_name);
  if (impl->type->size < sizeof(std::uint64_t))
    return fail(options.type_name + " is too small for a sequence number");
  impl->payload.resize((impl->type->size + sizeof(std::max_align_t) - 1) / sizeof(std::max_align_t));

  auto endpoint = detail::open_endpoint(options.path, options.domain, *impl->type, kPongTopic, kPingTopic);
  if (!endpoint) return fail("driver endpoint: " + endpoint.error());
  impl->endpoint = std::move(*endpoint);

  auto control = sys::SeqPacket::pair();
  if (!control) return fail(control.error().to_string());
  auto echo = sys::spawn(
      sys::SpawnSpec{.executable = options.echo_executable,
                     .args = {"--domain", std::to_string(options.domain.value()), "--type", options.type_name,
                              "--path", std::string(to_string(options.path))},
                     .env = {"CYCLONEDDS_URI=" + options.cyclone_uri},
                     .fds = {{STDIN_FILENO, control->second.fd()}, {STDERR_FILENO, STDERR_FILENO}}});
  if (!echo) return fail("spawn " + options.echo_executable + ": " + echo.error().to_string());
  impl->echo = std::move(*echo);
  impl->control = std::move(control->first);
  control->second.close();

  if (auto ok = impl->endpoint->wait_matched(options.connect_timeout); !ok)
    return fail("connect: " + ok.error());
  // Both ends matched here does not mean the echo's ends matched ours: probe until an echo comes back.
  const auto deadline = std::chrono::steady_clock::now() + options.connect_timeout;
  for (std::uint64_t probe = kProbeSeqBase;; ++probe) {
    auto got = impl->ping(probe, kFirstReplyRetry);
    if (!got) return fail(got.error());
    if (*got) break;
    if (std::chrono::steady_clock::now() >= deadline) return fail(std::string("the echo never answered"));
    if (!impl->echo.running() || impl->echo.try_wait().value_or(std::nullopt)) {
      return fail(std::string("the echo process exited"));
    }
  }
  DdsPingPong pp(std::move(impl));
  for (std::size_t i = 0; i < options.warmup_round_trips; ++i) {
    if (auto ok = pp.round_trip(kProbeSeqBase / 2 + i); !ok) return fail("warm-up: " + ok.error());
  }
  return pp;
}

Result<void, std::string> DdsPingPong::round_trip(std::uint64_t seq) {
  auto got = impl_->ping(seq, impl_->options.reply_timeout);
  if (!got) return fail(got.error());
  if (!*got) return fail("no echo of " + std::to_string(seq) + " within the reply timeout");
  return {};
}

Result<std::vector<Nanos>, std::string> DdsPingPong::run(std::size_t count) {
  return measure_round_trips(count, [this](std::uint64_t seq) { return round_trip(seq); });
}

}  // namespace rejuv::bench
