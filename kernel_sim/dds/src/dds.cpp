#include "rejuv/dds/dds.hpp"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <thread>
#include <utility>
#include <vector>

#include "event_fd.hpp"
#include "rejuv/sys/sanitizer.hpp"
#include "thread_policy.hpp"

#if defined(REJUV_TSAN)
// The tsan preset: Cyclone DDS is Debian's uninstrumented library, whose own atomics and locks ThreadSanitizer
// does not see, so it reports races inside it that are none (ddsrt_mutex_lock against the write that made the
// mutex). Suppressed here, in every program that links DDS, whatever environment it was started in; races in
// our code, even on data DDS hands us, are still reported (the frames are matched on the library alone).
extern "C" const char* __tsan_default_suppressions() {  // NOLINT(bugprone-reserved-identifier)
  return "race:libddsc.so\n";
}
#endif

namespace rejuv::dds {

namespace {

constexpr std::size_t kTakeBatch = 32;  // samples per dds_take; take() loops until the reader is empty

// A unit of the take buffers: aligned for any topic struct and without padding of its own, so that a value-
// initialised vector of them is zero in every byte. One of std::max_align_t is not: libstdc++ fills it by
// copying one max_align_t{}, i.e. its long long and long double, not the 14 bytes of padding around them,
// which keep what the heap held. Cyclone's deserialiser writes a sample's members, not its padding
// (SensorGps's 6 bytes after satellites_used): that padding is what the buffer held, zero, the same in every
// run's routes and ULog.
struct alignas(std::max_align_t) TakeUnit {
  std::byte bytes[alignof(std::max_align_t)];
};
static_assert(sizeof(TakeUnit) == alignof(std::max_align_t), "a TakeUnit has no padding");

constexpr auto kMatchPollPeriod = std::chrono::milliseconds{1};
// A reliable keep-last writer only blocks on resource limits it does not have; bound it anyway.
constexpr dds_duration_t kMaxBlocking = DDS_MSECS(100);

std::unexpected<DdsError> dds_fail(std::string_view call, dds_return_t code) {
  return std::unexpected(DdsError{.kind = DdsError::Kind::Dds, .call = call, .code = code});
}

std::unexpected<DdsError> bad_argument(std::string_view call) {
  return std::unexpected(DdsError{.kind = DdsError::Kind::BadArgument, .call = call});
}

std::string_view kind_name(DdsError::Kind kind) {
  switch (kind) {
    case DdsError::Kind::Dds: return "DDS error";
    case DdsError::Kind::Os: return "system error";
    case DdsError::Kind::SizeMismatch: return "payload size mismatch";
    case DdsError::Kind::TypeMismatch: return "topic type mismatch";
    case DdsError::Kind::BadArgument: return "bad argument";
    case DdsError::Kind::Timeout: return "timed out";
  }
  return "unknown";
}

dds_ignorelocal_kind_t to_dds(IgnoreLocal ignore) {
  switch (ignore) {
    case IgnoreLocal::None: return DDS_IGNORELOCAL_NONE;
    case IgnoreLocal::Participant: return DDS_IGNORELOCAL_PARTICIPANT;
    case IgnoreLocal::Process: return DDS_IGNORELOCAL_PROCESS;
  }
  return DDS_IGNORELOCAL_PARTICIPANT;
}

// Owned dds_qos_t.
struct QosDeleter {
  void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;

// Reliable, keep-last depth, volatile, with the ignorelocal policy and the partition (docs/design.md §5).
QosPtr endpoint_qos(const EndpointQos& q) {
  QosPtr qos(dds_create_qos());
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, kMaxBlocking);
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, q.history_depth);
  dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
  dds_qset_ignorelocal(qos.get(), to_dds(q.ignore_local));
  // Cyclone makes the implicit publisher (subscriber) of an endpoint created on a participant with the
  // endpoint's QoS, so the partition set here is that publisher's (subscriber's).
  if (!q.partition.empty()) dds_qset_partition1(qos.get(), q.partition.c_str());
  return qos;
}

DdsResult<void> check_endpoint_args(std::string_view call, std::string_view topic_name,
                                    const EndpointQos& q) {
  if (topic_name.empty() || q.history_depth < 1) {
    return bad_argument(call);
  }
  return {};
}

// Deletes a Cyclone entity if it is one (0 = none). An entity already deleted with its participant makes
// dds_delete return an error, which is fine: it is gone either way.
void delete_entity(dds_entity_t& entity) noexcept {
  if (entity > 0) {
    (void)dds_delete(entity);
  }
  entity = 0;
}

template <class Status, class GetFn>
DdsResult<std::uint32_t> current_matched(dds_entity_t entity, GetFn get, std::string_view call) {
  Status status{};
  const dds_return_t rc = get(entity, &status);
  if (rc < 0) {
    return dds_fail(call, rc);
  }
  return status.current_count;
}

template <class CountFn>
DdsResult<void> wait_matched(CountFn count_now, std::uint32_t wanted, Nanos timeout, std::string_view call) {
  // Discovery happens on Cyclone's threads; polling the matched count at 1 ms is simple and only runs while
  // connecting, never in a loop's steady state.
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    auto count = count_now();
    if (!count) {
      return fail(count.error());
    }
    if (*count >= wanted) {
      return {};
    }
    if (std::chrono::steady_clock::now() >= deadline) {
      return fail(DdsError{.kind = DdsError::Kind::Timeout, .call = call});
    }
    std::this_thread::sleep_for(kMatchPollPeriod);
  }
}

}  // namespace

// ---- DdsError ----

std::string DdsError::text() const {
  switch (kind) {
    case Kind::Dds: return dds_strretcode(code);
    case Kind::Os: return std::strerror(code);
    case Kind::SizeMismatch:
    case Kind::TypeMismatch:
    case Kind::BadArgument:
    case Kind::Timeout: return std::string(kind_name(kind));
  }
  return std::string(kind_name(kind));
}

std::string DdsError::to_string() const {
  std::string out(call);
  out += ": ";
  switch (kind) {
    case Kind::Dds: out += text() + " (" + std::to_string(code) + ")"; break;
    case Kind::SizeMismatch:
      out += "payload of " + std::to_string(actual_size) + " bytes, topic type needs " +
             std::to_string(expected_size);
      break;
    case Kind::TypeMismatch:
      out += "C type of " + std::to_string(actual_size) + " bytes is not the endpoint's topic type";
      break;
    case Kind::Os:
    case Kind::BadArgument:
    case Kind::Timeout: out += text(); break;
  }
  return out;
}

// ---- Participant ----

DdsResult<Participant> Participant::create(DomainId domain) {
  if (domain.value() > kMaxDomainId) {
    return bad_argument("dds_create_participant");
  }
  // Cyclone's threads (receive, timed events, …) start here and inherit SCHED_BATCH: a thread woken by a
  // datagram never preempts the thread that sent it (the plant writing its step's samples, the kernel
  // routing), it runs when that thread sleeps or on the other core. In lockstep this halves the context
  // switches per step; the application thread keeps its own policy.
  const dds_entity_t entity = [&] {
    const detail::BatchPolicyScope batch;
    return dds_create_participant(domain.value(), nullptr, nullptr);
  }();
  if (entity < 0) {
    return dds_fail("dds_create_participant", entity);
  }
  return Participant(entity, domain);
}

Participant::Participant(Participant&& other) noexcept
    : entity_(std::exchange(other.entity_, 0)), domain_(other.domain_) {}

Participant& Participant::operator=(Participant&& other) noexcept {
  if (this != &other) {
    reset();
    entity_ = std::exchange(other.entity_, 0);
    domain_ = other.domain_;
  }
  return *this;
}

void Participant::reset() noexcept {
  delete_entity(entity_);
}

// ---- Writer ----

DdsResult<Writer> Writer::create(const Participant& participant, std::string_view topic_name,
                                 const msgs::TopicType& type, const EndpointQos& qos) {
  if (auto ok = check_endpoint_args("dds_create_writer", topic_name, qos); !ok) {
    return fail(ok.error());
  }
  REJUV_ASSERT(participant.valid(), "Writer::create on an empty Participant");
  Writer w;
  w.type_ = &type;
  w.topic_name_ = std::string(topic_name);
  w.topic_ = dds_create_topic(participant.entity_, type.descriptor, w.topic_name_.c_str(), nullptr, nullptr);
  if (w.topic_ < 0) {
    const dds_return_t rc = std::exchange(w.topic_, 0);
    return dds_fail("dds_create_topic", rc);
  }
  const QosPtr q = endpoint_qos(qos);
  w.writer_ = dds_create_writer(participant.entity_, w.topic_, q.get(), nullptr);
  if (w.writer_ < 0) {
    const dds_return_t rc = std::exchange(w.writer_, 0);
    return dds_fail("dds_create_writer", rc);  // ~Writer deletes the topic
  }
  // One sample, aligned for any topic struct: a misaligned payload is copied here before dds_write reads it.
  w.scratch_ = std::make_unique<std::max_align_t[]>((type.size + sizeof(std::max_align_t) - 1) /
                                                    sizeof(std::max_align_t));
  return w;
}

Writer::Writer(Writer&& other) noexcept
    : topic_(std::exchange(other.topic_, 0)),
      writer_(std::exchange(other.writer_, 0)),
      type_(other.type_),
      topic_name_(std::move(other.topic_name_)),
      scratch_(std::move(other.scratch_)) {}

Writer& Writer::operator=(Writer&& other) noexcept {
  if (this != &other) {
    reset();
    topic_ = std::exchange(other.topic_, 0);
    writer_ = std::exchange(other.writer_, 0);
    type_ = other.type_;
    topic_name_ = std::move(other.topic_name_);
    scratch_ = std::move(other.scratch_);
  }
  return *this;
}

void Writer::reset() noexcept {
  delete_entity(writer_);
  delete_entity(topic_);
}

DdsResult<void> Writer::write(std::span<const std::byte> sample) {
  REJUV_ASSERT(valid(), "write on an empty Writer");
  if (sample.size() != type_->size) {
    return fail(DdsError{.kind = DdsError::Kind::SizeMismatch,
                         .call = "write",
                         .code = 0,
                         .expected_size = type_->size,
                         .actual_size = sample.size()});
  }
  const void* data = sample.data();
  if (reinterpret_cast<std::uintptr_t>(data) % type_->align != 0) {
    std::memcpy(scratch_.get(), sample.data(), sample.size());
    data = scratch_.get();
  }
  const dds_return_t rc = dds_write(writer_, data);
  if (rc < 0) {
    return dds_fail("dds_write", rc);
  }
  return {};
}

DdsResult<std::uint32_t> Writer::matched_readers() const {
  return current_matched<dds_publication_matched_status_t>(writer_, dds_get_publication_matched_status,
                                                           "dds_get_publication_matched_status");
}

DdsResult<void> Writer::wait_for_readers(std::uint32_t count, Nanos timeout) const {
  return wait_matched([this] { return matched_readers(); }, count, timeout, "wait_for_readers");
}

// ---- Reader ----

struct Reader::State {
  State(detail::EventFd fd, std::size_t size, std::size_t stride)
      : ready(std::move(fd)), sample_size(size), storage(stride * kTakeBatch), samples(kTakeBatch), infos(kTakeBatch) {}
  detail::EventFd ready;
  std::size_t sample_size = 0;
  std::vector<TakeUnit> storage;          // kTakeBatch samples, each aligned as max_align_t; zero at first
  std::vector<void*> samples;             // pointers into storage, handed to dds_take
  std::vector<dds_sample_info_t> infos;
  std::atomic<bool> signalling{true};     // Reader::set_signalling

  // Runs on a Cyclone thread: signal the event loop and touch nothing else (docs/design.md §5; the kernel is
  // single-threaded).
  static void on_data_available(dds_entity_t /*reader*/, void* arg) {
    const State& s = *static_cast<const State*>(arg);
    if (s.signalling.load(std::memory_order_acquire)) s.ready.signal();
  }
};

DdsResult<Reader> Reader::create(const Participant& participant, std::string_view topic_name,
                                 const msgs::TopicType& type, const EndpointQos& qos) {
  if (auto ok = check_endpoint_args("dds_create_reader", topic_name, qos); !ok) {
    return fail(ok.error());
  }
  REJUV_ASSERT(participant.valid(), "Reader::create on an empty Participant");
  auto ready = detail::EventFd::create();
  if (!ready) {
    return fail(DdsError{.kind = DdsError::Kind::Os, .call = "eventfd", .code = ready.error().error});
  }
  const std::size_t stride = (type.size + sizeof(TakeUnit) - 1) / sizeof(TakeUnit);
  auto state = std::make_unique<State>(std::move(*ready), type.size, stride);
  for (std::size_t i = 0; i < kTakeBatch; ++i) {
    state->samples[i] = &state->storage[i * stride];
  }

  Reader r;
  r.type_ = &type;
  r.topic_name_ = std::string(topic_name);
  r.state_ = std::move(state);
  r.topic_ = dds_create_topic(participant.entity_, type.descriptor, r.topic_name_.c_str(), nullptr, nullptr);
  if (r.topic_ < 0) {
    const dds_return_t rc = std::exchange(r.topic_, 0);
    return dds_fail("dds_create_topic", rc);
  }
  dds_listener_t* listener = dds_create_listener(r.state_.get());
  dds_lset_data_available(listener, &State::on_data_available);
  const QosPtr q = endpoint_qos(qos);
  r.reader_ = dds_create_reader(participant.entity_, r.topic_, q.get(), listener);
  dds_delete_listener(listener);  // the reader keeps its own copy
  if (r.reader_ < 0) {
    const dds_return_t rc = std::exchange(r.reader_, 0);
    return dds_fail("dds_create_reader", rc);
  }
  return r;
}

Reader::Reader(Reader&& other) noexcept
    : topic_(std::exchange(other.topic_, 0)),
      reader_(std::exchange(other.reader_, 0)),
      type_(other.type_),
      topic_name_(std::move(other.topic_name_)),
      state_(std::move(other.state_)) {}

Reader& Reader::operator=(Reader&& other) noexcept {
  if (this != &other) {
    reset();
    topic_ = std::exchange(other.topic_, 0);
    reader_ = std::exchange(other.reader_, 0);
    type_ = other.type_;
    topic_name_ = std::move(other.topic_name_);
    state_ = std::move(other.state_);
  }
  return *this;
}

Reader::~Reader() {
  reset();
}

void Reader::reset() noexcept {
  // dds_delete waits for a listener call in progress, so the state outlives every use by Cyclone's thread.
  delete_entity(reader_);
  delete_entity(topic_);
  state_.reset();
}

int Reader::ready_fd() const {
  return state_ ? state_->ready.fd() : -1;
}

void Reader::set_signalling(bool on) {
  REJUV_ASSERT(state_ != nullptr, "set_signalling on an empty Reader");
  state_->signalling.store(on, std::memory_order_release);
}

DdsResult<std::size_t> Reader::take_erased(SampleFn fn, void* context) {
  REJUV_ASSERT(valid() && state_, "take on an empty Reader");
  State& s = *state_;
  // Before taking: a sample arriving from now on signals again. Not signalling: nothing to drain (a stale
  // readiness from before set_signalling(false) only makes one spurious wake-up once it is on again).
  if (s.signalling.load(std::memory_order_acquire)) s.ready.drain();
  std::size_t delivered = 0;
  for (;;) {
    const dds_return_t n = dds_take(reader_, s.samples.data(), s.infos.data(), kTakeBatch,
                                    static_cast<std::uint32_t>(kTakeBatch));
    if (n < 0) {
      return dds_fail("dds_take", n);
    }
    for (dds_return_t i = 0; i < n; ++i) {
      const auto idx = static_cast<std::size_t>(i);
      // Invalid samples carry only a state change (e.g. the last writer went away): no payload.
      if (s.infos[idx].valid_data) {
        fn(context, std::span<const std::byte>(static_cast<const std::byte*>(s.samples[idx]), s.sample_size));
        ++delivered;
      }
    }
    if (static_cast<std::size_t>(n) < kTakeBatch) {
      return delivered;
    }
  }
}

DdsResult<std::uint32_t> Reader::matched_writers() const {
  return current_matched<dds_subscription_matched_status_t>(reader_, dds_get_subscription_matched_status,
                                                            "dds_get_subscription_matched_status");
}

DdsResult<void> Reader::wait_for_writers(std::uint32_t count, Nanos timeout) const {
  return wait_matched([this] { return matched_writers(); }, count, timeout, "wait_for_writers");
}

}  // namespace rejuv::dds
