// The private state of a Service (Service::Impl) and the SDK's internal helpers, shared by the files that
// implement the SDK along its seams:
//   errors.cpp     SdkError and Error as text, the Reply error field as an Error
//   transport.cpp  the channel I/O: frames queued and packed, bursts read, a request and its Reply
//   image.cpp      the image protocol (docs/design.md §7): take_image, the frozen copies, the resumed image
//   boot.cpp       connect: Hello and the boot script, the Service's birth and end
//   service.cpp    the API of service.hpp and the event loop
// Not installed: nothing outside services/sdk/src includes it.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <expected>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rejuv/channel/transport.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/clock/time_page.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/fd.hpp"
#include "workers.hpp"

namespace rejuv::sdk {

// ---- errors (errors.cpp) ----

[[nodiscard]] std::unexpected<Error> error(SdkError code, std::string detail = {});
[[nodiscard]] std::unexpected<Error> io_error(const sys::SysError& e);
// A Reply's error field as an SDK error (channel::reply_kind: a denial, an operation error, or neither).
[[nodiscard]] std::unexpected<Error> reply_error(std::int32_t wire_error, std::string detail);

// ---- the service's state ----

struct Param {
  std::string name;
  double number = 0;
  std::string text;
  bool is_text = false;
  std::int64_t integer = 0;
  bool is_integer = false;
};

struct TimerSlot {
  std::uint64_t id = 0;
  bool armed = false;
  bool periodic = false;
  std::function<void()> on_fire;
};

struct Service::Impl {
  Impl() { out.reserve(kOutBytes); }  // the one allocation of the send queue
  Impl(const Impl&) = delete;         // pinned: `reader` points into its own buffers
  Impl& operator=(const Impl&) = delete;
  Impl(Impl&&) = delete;
  Impl& operator=(Impl&&) = delete;
  ~Impl() = default;

  sys::SeqPacket channel;
  clock::TimePageReader time;
  std::string name;
  ServiceId id;
  std::vector<CapInfo> caps;
  std::vector<Param> params;
  std::vector<std::unique_ptr<detail::SubscriptionBase>> subscriptions;
  std::vector<detail::SubscriptionBase*> subscription_by_slot;
  std::array<TimerSlot, Service::kMaxTimers> timers{};
  // The armed slot of timer `id` (its index in the low byte, a serial above), or nullptr: cancelled, fired
  // once, or an id that names no slot (a stale handle, a broken frame).
  TimerSlot* timer_slot(std::uint64_t timer_id) {
    const std::size_t index = timer_id & 0xFFU;
    if (index >= timers.size() || !timers[index].armed || timers[index].id != timer_id) return nullptr;
    return &timers[index];
  }
  std::uint64_t timer_serial = 0;
  std::uint32_t seq = 0;
  std::uint64_t frames_received = 0;  // every frame read from the channel since boot (docs/protocol.md Idle)
  std::uint64_t idle_reported = 0;
  std::uint64_t bad_frames = 0;
  std::uint64_t time_stalls_reported = 0;  // time.stalls() already said (report_time_stalls)
  bool ready_sent = false;
  bool stopping = false;
  int exit_code = 0;
  bool lockstep = true;  // Idle is only meaningful in lockstep (docs/protocol.md "Idle")
  bool sync_asked = false;  // a Sync came: the next Idle goes out in real time too
  std::function<void()> on_shutdown;
  std::function<void(Epoch)> on_restored;
  bool restored_pending = false;  // a restored incarnation whose on_restored has not run yet (resumed_image)
  std::deque<std::vector<std::byte>> queued;  // frames read while waiting for a Reply
  [[nodiscard]] bool fire_queued(std::uint64_t timer_id) const;  // a TimerFired of this timer waits in it
  // Network gate: a handler per Network cap slot, and a copy of the datagram being handled (a handler that
  // sends reuses rx for the Reply).
  std::vector<std::pair<std::uint32_t, std::function<void(std::span<const std::byte>)>>> datagram_handlers;
  std::array<std::byte, wire::kMaxDatagramBytes> datagram{};
  std::uint64_t datagram_id = 0;  // the kernel's id of the datagram being handled (0: none)
  WorkerSet* workers = nullptr;   // owned; raw because a restored image leaks its copy (workers.hpp)

  // ---- transport (transport.cpp) ----

  alignas(8) std::array<std::byte, wire::kMaxFrameBytes> rx{};  // the frame being handled
  std::vector<sys::UniqueFd> rx_fds;                             // fds that came with it (Snapshot: one or two)
  wire::FrameBuffer tx;                                          // the frame being built

  // Outgoing frames are queued and leave together, packed in one datagram (channel::send_packed), when the
  // service next waits — for frames or for a Reply — so that a callback's publications and the following
  // Idle wake the kernel once. `out` holds them as a datagram lays them out (channel::append_frame); its
  // capacity is reserved once and never exceeded (a full queue is sent first): no allocation per message.
  static constexpr std::size_t kOutBytes = 64 * 1024;
  std::vector<std::byte> out;

  // Frames read ahead: one recvmmsg takes a burst (channel::BatchReader), receive() hands them out one by
  // one through rx (copied: rx stays the home of the frame being handled until the next receive, the rule
  // the datagram and request() paths are written against). A restored image drops what is left (forget):
  // nothing sent to the old incarnation is read by the restored one (docs/design.md §7).
  static constexpr std::size_t kBatch = 4;
  alignas(8) std::array<std::byte, wire::kMaxFrameBytes * kBatch> batch_bytes{};
  std::array<sys::Received, kBatch> batch{};
  channel::BatchReader reader{batch_bytes, batch};

  // Queues a frame (sending what is queued first when it would not fit).
  SdkResult<void> queue(std::span<const std::byte> frame);
  SdkResult<void> send_built() { return queue(tx.bytes()); }
  // Sends everything queued, waiting for room if the kernel has not drained the channel yet.
  SdkResult<void> flush();
  SdkResult<void> send(std::span<const std::byte> frame) {
    if (auto q = queue(frame); !q) return q;
    return flush();
  }
  // Reads one frame into rx (its size); nullopt when none is ready and `wait` is false. A datagram may carry
  // several frames (wire::next_frame): they are handed out one by one, the datagram's fds with the first.
  SdkResult<std::optional<std::size_t>> receive(bool wait);
  // Sends the request in tx and waits for its Reply, queueing every other frame (handled later, in order).
  SdkResult<InvokeReply> request(std::span<std::byte> reply_data, std::string_view what);

  // ---- the event loop (service.cpp) ----

  // Reads the next frame into rx (its size), first reporting Idle and flushing when everything received has
  // been handled; nullopt when a wait ended without a frame. The error is run()'s exit code (1: the channel
  // failed, or an Idle could not be sent).
  std::expected<std::optional<std::size_t>, int> read_frame();
  // docs/protocol.md "Idle": tells the kernel everything received is handled (lockstep, or asked by a
  // Sync). False when the Idle could not be sent.
  [[nodiscard]] bool report_idle();
  // Says on stderr (logged by the kernel under the service's name) each new bounded time-page read that gave up.
  void report_time_stalls();
  // The first frame of a restored incarnation: runs the author's on_restored hook before it is handled.
  void resume_incarnation(std::span<const std::byte> frame);
  // Hands one frame to the handler of its kind; an exit code when run() must return it.
  std::optional<int> handle(std::span<const std::byte> bytes);
  void handle_deliver(const wire::FrameView& frame);
  void handle_timer_fired(const wire::FrameView& frame);
  void handle_datagram(const wire::FrameView& frame);

  // ---- images (image.cpp, docs/design.md §7) ----

  // Set in a restored image: the answer of the checkpoint() call it was taken in.
  std::optional<CheckpointOutcome> restored;
  // Images by written pages (memory_image.hpp; possible at all where memory_image::whole_memory_tracked()):
  // the generation this process's memory derives from as far as its write tracking goes (0: none, the next
  // image is by fork).
  std::uint64_t tracked_base = 0;
  // This incarnation's pagemap (the kernel's, with its first Snapshot that offers a base) and the memfd the
  // next image's pages go into (made after a checkpoint, when the next frame comes: off its critical path).
  int pagemap_fd = -1;
  int next_pages_fd = -1;
  static constexpr std::chrono::milliseconds kWorkerParkDeadline{500};
  // Snapshot{g, base}: takes the image; false in the live process, true in the image resumed by a rollback.
  SdkResult<bool> take_image(std::uint64_t g, std::uint64_t base);
  SdkResult<bool> resumed_image();
  // The memfd for the next image by written pages, if tracking and none is made yet.
  void prepare_pages_fd();
};

}  // namespace rejuv::sdk
