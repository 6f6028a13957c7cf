// The DDS bridge (docs/design.md §5): thin, type-erased, move-only handles over the Cyclone DDS C API, so that the
// kernel can bridge any topic of the launch graph by name, and the plant (the jMAVSim of paper §VI-A, a
// separate process) can talk to it. Every topic is a fixed-size IDL struct (idl/, msgs::TopicType): a sample
// is exactly `type.size` bytes, checked on every write.
//
// Threads: Cyclone runs its own threads; the only thing they do on our behalf is the Reader's data-available
// listener, which writes an eventfd (ready_fd) and touches nothing else. Everything else — write, take, the
// handles themselves — belongs to the (single-threaded, epoll-based) caller.
#pragma once

#include <dds/dds.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::dds {

// A DDS domain id. With Cyclone's default port mapping (7400 + 250·d) valid ids are 0..232.
using DomainId = StrongId<struct DomainIdTag>;
inline constexpr std::uint32_t kMaxDomainId = 232;

// Why a DDS operation failed. `call` names the failing call (static storage).
struct DdsError {
  enum class Kind : std::uint8_t {
    Dds,           // Cyclone returned `code` (a negative dds_return_t)
    Os,            // a system call failed with errno `code`
    SizeMismatch,  // a payload of `actual_size` bytes for a topic of `expected_size` bytes
    TypeMismatch,  // a typed write/take on an endpoint of another topic type
    BadArgument,   // an argument out of range (depth < 1, domain id too large, empty topic name)
    Timeout,       // a wait for matching endpoints ran out
  };
  Kind kind = Kind::Dds;
  std::string_view call{};
  std::int32_t code = 0;
  std::size_t expected_size = 0;
  std::size_t actual_size = 0;

  // dds_strretcode(code) for Kind::Dds, strerror(code) for Kind::Os, otherwise the kind's name.
  [[nodiscard]] std::string text() const;
  // "dds_create_reader: Bad Parameter (-3)", "write: payload of 10 bytes, topic type needs 48".
  [[nodiscard]] std::string to_string() const;
};

template <class T>
using DdsResult = Result<T, DdsError>;

// Which matching endpoints a reader/writer ignores (Cyclone's ignorelocal QoS, a reader/writer policy: a pair
// is not matched when either side ignores the other). docs/design.md §5: the kernel uses Participant so that it does
// not hear its own writes on a bridged topic.
enum class IgnoreLocal : std::uint8_t { None, Participant, Process };

// QoS of a bridged endpoint: reliable, keep-last `history_depth`, volatile. Keep-last on the writer side
// means that a write never blocks on a slow reader: the oldest unacknowledged sample is dropped instead.
// `partition`: the DDS partition of the endpoint's (implicit) publisher or subscriber; a writer and a reader
// match only within one partition. Empty: the default partition. A run's kernel and plant use the run's
// (run_partition.hpp).
struct EndpointQos {
  std::int32_t history_depth = 16;
  IgnoreLocal ignore_local = IgnoreLocal::Participant;
  std::string partition{};
};

// A domain participant (RAII over dds_create_participant). Cyclone reads its configuration from
// CYCLONEDDS_URI (config/cyclonedds.xml: loopback-only unicast). Deleting it deletes every reader and writer
// created from it, so keep it alive longer than they are (a Reader/Writer that outlives it is inert).
class Participant {
 public:
  [[nodiscard]] static DdsResult<Participant> create(DomainId domain);

  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;
  Participant(Participant&& other) noexcept;
  Participant& operator=(Participant&& other) noexcept;
  ~Participant() { reset(); }

  [[nodiscard]] DomainId domain() const { return domain_; }
  [[nodiscard]] bool valid() const { return entity_ > 0; }
  void reset() noexcept;

 private:
  friend class Writer;
  friend class Reader;
  Participant(dds_entity_t entity, DomainId domain) : entity_(entity), domain_(domain) {}
  dds_entity_t entity_ = 0;
  DomainId domain_{};
};

// A writer of one topic: `topic_name` on DDS (e.g. "rejuv/sensor_gyro"), samples of `type`.
class Writer {
 public:
  [[nodiscard]] static DdsResult<Writer> create(const Participant& participant, std::string_view topic_name,
                                                const msgs::TopicType& type, const EndpointQos& qos = {});

  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;
  Writer(Writer&& other) noexcept;
  Writer& operator=(Writer&& other) noexcept;
  ~Writer() { reset(); }

  // Publishes one sample: exactly type().size bytes (SizeMismatch otherwise, and nothing is sent). Any
  // alignment is accepted (a misaligned payload is copied first).
  [[nodiscard]] DdsResult<void> write(std::span<const std::byte> sample);
  // Typed convenience: T must be the C struct of type() (TypeMismatch otherwise).
  template <class T>
  [[nodiscard]] DdsResult<void> write_value(const T& sample);

  // Readers currently matched (not counting ignored local ones).
  [[nodiscard]] DdsResult<std::uint32_t> matched_readers() const;
  // Waits until at least `count` readers are matched. Samples of a volatile topic written before a reader
  // matched never reach it, so a publisher whose first sample matters waits here first.
  [[nodiscard]] DdsResult<void> wait_for_readers(std::uint32_t count, Nanos timeout) const;

  [[nodiscard]] const msgs::TopicType& type() const { return *type_; }
  [[nodiscard]] const std::string& topic_name() const { return topic_name_; }
  [[nodiscard]] bool valid() const { return writer_ > 0; }
  void reset() noexcept;

 private:
  Writer() = default;
  dds_entity_t topic_ = 0;
  dds_entity_t writer_ = 0;
  const msgs::TopicType* type_ = nullptr;
  std::string topic_name_;
  std::unique_ptr<std::max_align_t[]> scratch_;  // aligned copy of a misaligned payload
};

// A reader of one topic. ready_fd() is an eventfd that a Cyclone thread makes readable when data arrives;
// add it to the event loop (EPOLLIN) and call take() when it fires. take() clears it before draining, so a
// sample that arrives during take() makes it readable again: no wake-up is lost, some may be spurious.
class Reader {
 public:
  [[nodiscard]] static DdsResult<Reader> create(const Participant& participant, std::string_view topic_name,
                                                const msgs::TopicType& type, const EndpointQos& qos = {});

  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;
  Reader(Reader&& other) noexcept;
  Reader& operator=(Reader&& other) noexcept;
  ~Reader();

  [[nodiscard]] int ready_fd() const;
  // Whether arriving data makes ready_fd() readable (default on). Off for a reader that is only ever taken
  // when something else wakes the loop (the kernel's sensor readers in lockstep: taken with the SimStep):
  // then the Cyclone thread writes no eventfd per sample and take() reads none — two system calls per
  // sample saved. Turn it on before adding ready_fd() to a poll set, then take() once: what arrived while
  // it was off is taken then, and everything after it signals.
  void set_signalling(bool on);

  // Takes every available sample, oldest first, and calls on_sample(span of type().size bytes, aligned for
  // the type) for each; returns how many. The span is valid only during the call. Not reentrant: on_sample
  // must not call take() on the same reader.
  template <class F>
  requires std::is_invocable_v<F&, std::span<const std::byte>>
  [[nodiscard]] DdsResult<std::size_t> take(F&& on_sample);
  // Typed convenience: on_sample(const T&); T must be the C struct of type() (TypeMismatch otherwise).
  template <class T, class F>
  requires std::is_invocable_v<F&, const T&>
  [[nodiscard]] DdsResult<std::size_t> take_as(F&& on_sample);

  [[nodiscard]] DdsResult<std::uint32_t> matched_writers() const;
  [[nodiscard]] DdsResult<void> wait_for_writers(std::uint32_t count, Nanos timeout) const;

  [[nodiscard]] const msgs::TopicType& type() const { return *type_; }
  [[nodiscard]] const std::string& topic_name() const { return topic_name_; }
  [[nodiscard]] bool valid() const { return reader_ > 0; }
  void reset() noexcept;

 private:
  struct State;  // eventfd + take buffers; on the heap so that the listener's pointer survives a move
  using SampleFn = void (*)(void* context, std::span<const std::byte> sample);
  [[nodiscard]] DdsResult<std::size_t> take_erased(SampleFn fn, void* context);

  Reader() = default;
  dds_entity_t topic_ = 0;
  dds_entity_t reader_ = 0;
  const msgs::TopicType* type_ = nullptr;
  std::string topic_name_;
  std::unique_ptr<State> state_;
};

// ---- templates ----

namespace detail {
template <class T>
[[nodiscard]] DdsResult<void> check_type(const msgs::TopicType& type, std::string_view call) {
  static_assert(std::is_trivially_copyable_v<T>, "topic structs are fixed-size");
  if (type.name != msgs::TopicTraits<T>::name) {
    return fail(DdsError{.kind = DdsError::Kind::TypeMismatch,
                         .call = call,
                         .code = 0,
                         .expected_size = type.size,
                         .actual_size = sizeof(T)});
  }
  return {};
}
}  // namespace detail

template <class T>
DdsResult<void> Writer::write_value(const T& sample) {
  if (auto ok = detail::check_type<T>(*type_, "write_value"); !ok) {
    return ok;
  }
  return write(std::as_bytes(std::span<const T, 1>(&sample, 1)));
}

template <class F>
requires std::is_invocable_v<F&, std::span<const std::byte>> DdsResult<std::size_t> Reader::take(
    F&& on_sample) {
  using Fn = std::remove_reference_t<F>;
  return take_erased(
      [](void* context, std::span<const std::byte> sample) { (*static_cast<Fn*>(context))(sample); },
      const_cast<void*>(static_cast<const void*>(std::addressof(on_sample))));
}

template <class T, class F>
requires std::is_invocable_v<F&, const T&> DdsResult<std::size_t> Reader::take_as(F&& on_sample) {
  if (auto ok = detail::check_type<T>(*type_, "take_as"); !ok) {
    return fail(ok.error());
  }
  return take([&on_sample](std::span<const std::byte> bytes) {
    T value{};
    std::memcpy(&value, bytes.data(), sizeof(T));
    on_sample(static_cast<const T&>(value));
  });
}

}  // namespace rejuv::dds
