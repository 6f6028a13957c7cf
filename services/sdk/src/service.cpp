#include "rejuv/sdk/service.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <string>
#include <utility>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <unistd.h>

#include "rejuv/clock/time_page.hpp"
#include "rejuv/clock/timers.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/process.hpp"
#include "rejuv/sys/seccomp.hpp"
#include "rejuv/sdk/memory_image.hpp"
#include "workers.hpp"

#if defined(__SANITIZE_ADDRESS__)
// LeakSanitizer's check at exit stops the process with ptrace from a helper task, which a service's seccomp
// policy forbids (sys/seccomp.cpp): the check hung until the kernel's shutdown grace ran out and the
// service was killed. Services of an AddressSanitizer build leave leak checking to the tests themselves.
extern "C" int __lsan_is_turned_off() { return 1; }  // NOLINT(bugprone-reserved-identifier)
#endif

namespace rejuv::sdk {

// ---- errors ----

std::string_view to_string(SdkError error) {
  switch (error) {
    case SdkError::NotAService: return "not a service";
    case SdkError::Seccomp: return "seccomp";
    case SdkError::ChannelIo: return "channel i/o";
    case SdkError::ChannelClosed: return "channel closed";
    case SdkError::Protocol: return "protocol violation";
    case SdkError::VersionMismatch: return "protocol version mismatch";
    case SdkError::NoSuchObject: return "no such object";
    case SdkError::WrongObjectKind: return "wrong object kind";
    case SdkError::TypeMismatch: return "type mismatch";
    case SdkError::NeverGranted: return "never granted";
    case SdkError::NotHeldInMode: return "not held in this mode";
    case SdkError::AlreadySubscribed: return "already subscribed";
    case SdkError::TooManyTimers: return "too many timers";
    case SdkError::NoSuchTimer: return "no such timer";
    case SdkError::BadArgument: return "bad argument";
    case SdkError::Denied: return "denied";
    case SdkError::OperationFailed: return "operation failed";
    case SdkError::RolledBack: return "rolled back (this is a restored image)";
    case SdkError::Resources: return "out of resources";
  }
  return "?";
}

std::string Error::to_string() const {
  std::string out(sdk::to_string(code));
  if (cap_error) {
    out += ": ";
    out += cap::to_string(*cap_error);
  } else if (wire_error != 0) {
    out += ": ";
    out += wire::to_string(static_cast<wire::OpError>(wire_error));
  }
  if (!detail.empty()) {
    out += " (" + detail + ")";
  }
  return out;
}

int report_connect_failure(const Error& error) {
  const char* name = std::getenv("REJUV_SERVICE");
  std::fprintf(stderr, "[%s] cannot connect to the kernel: %s\n", name != nullptr ? name : "?",
               error.to_string().c_str());
  return 2;
}

namespace {
std::unexpected<Error> error(SdkError code, std::string detail = {}) {
  return std::unexpected(Error{.code = code, .cap_error = std::nullopt, .wire_error = 0, .detail = std::move(detail)});
}
std::unexpected<Error> io_error(const sys::SysError& e) { return error(SdkError::ChannelIo, e.to_string()); }

// A Reply's error field as an SDK error (docs/protocol.md: 0 ok, 1 + CapError, or ≥ 100).
std::unexpected<Error> reply_error(std::int32_t wire_error, std::string detail) {
  if (wire_error >= 1 && wire_error <= static_cast<std::int32_t>(cap::kCapErrorCount)) {
    return std::unexpected(Error{.code = SdkError::Denied,
                                 .cap_error = static_cast<cap::CapError>(wire_error - 1),
                                 .wire_error = wire_error,
                                 .detail = std::move(detail)});
  }
  if (wire_error >= wire::kFirstOpError) {
    return std::unexpected(
        Error{.code = SdkError::OperationFailed, .cap_error = std::nullopt, .wire_error = wire_error, .detail = std::move(detail)});
  }
  return std::unexpected(
      Error{.code = SdkError::Protocol, .cap_error = std::nullopt, .wire_error = wire_error, .detail = std::move(detail)});
}
}  // namespace

bool CapInfo::ever(Right r) const {
  for (const Rights& x : rights) {
    if (x.has(r)) return true;
  }
  return false;
}

// ---- subscriptions ----

void detail::SubscriptionBase::deliver(std::uint64_t generation, std::span<const std::byte> payload) {
  // Generations of a topic are consecutive; a gap means the kernel clamped our cursor (ring overrun).
  // A rollback may send generations back (DESIGN §7): that is not a loss.
  if (received_ > 0 && generation > generation_ + 1) {
    lost_ += generation - generation_ - 1;
  }
  generation_ = generation;
  ++received_;
  updated_ = true;
  store_and_notify(payload);
}

// ---- the service ----

struct Param {
  std::string name;
  double number = 0;
  std::string text;
  bool is_text = false;
};

struct TimerSlot {
  std::uint64_t id = 0;
  bool armed = false;
  bool periodic = false;
  std::function<void()> on_fire;
};

struct Service::Impl {
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
  bool ready_sent = false;
  bool stopping = false;
  int exit_code = 0;
  std::function<void()> on_shutdown;
  std::deque<std::vector<std::byte>> queued;  // frames read while waiting for a Reply
  // Network gate: a handler per Network cap slot, and a copy of the datagram being handled (a handler that
  // sends reuses rx for the Reply).
  std::vector<std::pair<std::uint32_t, std::function<void(std::span<const std::byte>)>>> datagram_handlers;
  std::array<std::byte, wire::kMaxDatagramBytes> datagram{};
  std::uint64_t datagram_id = 0;  // the kernel's id of the datagram being handled (0: none)
  std::vector<sys::UniqueFd> rx_fds;          // fds that came with the frame in rx (Snapshot: one or two)
  // Images (DESIGN §7): set in a restored image, the answer of the checkpoint() call it was taken in.
  std::optional<CheckpointOutcome> restored;
  // Images by written pages (memory_image.hpp; possible at all where memory_image::whole_memory_tracked()):
  // the generation this process's memory derives from as far as its write tracking goes (0: none, the next
  // image is by fork).
  std::uint64_t tracked_base = 0;
  // This incarnation's pagemap (the kernel's, with its first Snapshot that offers a base) and the memfd the
  // next image's pages go into (made after a checkpoint, when the next frame comes: off its critical path).
  int pagemap_fd = -1;
  int next_pages_fd = -1;
  WorkerSet* workers = nullptr;  // owned; raw because a restored image leaks its copy (workers.hpp)
  alignas(8) std::array<std::byte, wire::kMaxFrameBytes> rx{};
  wire::FrameBuffer tx;

  // Outgoing frames are queued and leave together, packed in one datagram (wire::next_frame), when the
  // service next waits — for frames or for a Reply — so that a callback's publications and the following
  // Idle wake the kernel once.
  static constexpr std::size_t kOutBytes = 64 * 1024;
  alignas(8) std::array<std::byte, kOutBytes> out_arena{};
  std::size_t out_used = 0;  // bytes of out_arena: the queued frames, laid out as in a datagram
  bool lockstep = true;  // Idle is only meaningful in lockstep (docs/protocol.md "Idle")

  SdkResult<void> queue(std::span<const std::byte> frame) {
    const std::size_t padded = wire::aligned_frame_size(frame.size());
    if (out_used + padded > out_arena.size()) {
      if (auto f = flush(); !f) return f;
    }
    std::memcpy(out_arena.data() + out_used, frame.data(), frame.size());
    std::memset(out_arena.data() + out_used + frame.size(), 0, padded - frame.size());
    out_used += padded;
    return {};
  }

  // The next datagram of what is queued from byte `start` on: as many whole frames as fit.
  [[nodiscard]] std::span<const std::byte> packed(std::size_t start) const {
    const std::span<const std::byte> rest(out_arena.data() + start, out_used - start);
    return rest.first(wire::datagram_prefix(rest));
  }

  // Sends everything queued, waiting for room if the kernel has not drained the channel yet.
  SdkResult<void> flush() {
    std::size_t start = 0;
    while (start < out_used) {
      const std::span<const std::byte> next = packed(start);
      auto sent = channel.send(next);
      if (sent) {
        start += wire::aligned_frame_size(next.size());
        continue;
      }
      if (sent.error().error == EPIPE || sent.error().error == ECONNRESET) {
        out_used = 0;
        return error(SdkError::ChannelClosed);
      }
      if (sent.error().error != EAGAIN) {
        out_used = 0;
        return io_error(sent.error());
      }
      if (auto w = sys::wait_fd(channel.fd(), sys::WaitFor::Writable, std::nullopt); !w) return io_error(w.error());
    }
    out_used = 0;
    return {};
  }

  SdkResult<void> send(std::span<const std::byte> frame) {
    if (auto q = queue(frame); !q) return q;
    return flush();
  }
  SdkResult<void> send_built() { return queue(tx.bytes()); }

  // Frames read ahead: one recvmmsg takes a burst (sys::SeqPacket::receive_batch), receive() hands them out
  // one by one through rx (copied: rx stays the home of the frame being handled until the next receive,
  // the rule the datagram and request() paths are written against). A batch smaller than the buffer means
  // the channel was empty after it, so the drained check that follows costs no system call. An image resumed by a rollback drops what is left
  // (forget_batch): nothing sent to the old incarnation is read by the restored one (DESIGN §7).
  static constexpr std::size_t kBatch = 4;
  alignas(8) std::array<std::byte, wire::kMaxFrameBytes * kBatch> batch_bytes{};
  std::array<sys::Received, kBatch> batch{};
  std::size_t batch_next = 0;
  std::size_t batch_count = 0;
  std::size_t frame_offset = 0;  // where the next frame of datagram batch_next starts (wire::next_frame)
  bool batch_drained = false;  // the last recvmmsg returned fewer datagrams than it had room for
  void forget_batch() {
    for (sys::Received& r : batch) r.fds.clear();
    batch_next = batch_count = frame_offset = 0;
    batch_drained = false;
  }

  // Reads one frame into rx; nullopt when none is ready and `wait` is false. A datagram may carry several
  // frames (wire::next_frame): they are handed out one by one, the datagram's fds with the first.
  SdkResult<std::optional<std::size_t>> receive(bool wait) {
    for (;;) {
      if (batch_next < batch_count) {
        sys::Received& r = batch[batch_next];
        if (r.closed) {
          ++batch_next;
          return error(SdkError::ChannelClosed);
        }
        ++frames_received;
        if (frame_offset == 0) {
          rx_fds = std::move(r.fds);
        } else {
          rx_fds.clear();
        }
        if (r.truncated) {
          ++batch_next;
          return std::optional<std::size_t>(0);  // decodes as TooShort: counted as bad
        }
        const std::span<const std::byte> bytes(batch_bytes.data() + batch_next * wire::kMaxFrameBytes, r.size);
        const std::span<const std::byte> frame = wire::next_frame(bytes, frame_offset);
        if (frame_offset >= bytes.size()) {
          ++batch_next;
          frame_offset = 0;
        }
        std::memcpy(rx.data(), frame.data(), frame.size());
        return std::optional<std::size_t>(frame.size());
      }
      if (batch_drained && !wait) {
        batch_drained = false;
        return std::optional<std::size_t>{};
      }
      auto n = channel.receive_batch(batch_bytes, wire::kMaxFrameBytes, batch, 2, wait ? sys::Wait::ForOne : sys::Wait::No);
      if (n) {
        batch_next = 0;
        batch_count = *n;
        batch_drained = *n < kBatch && !batch[*n - 1].closed;
        continue;
      }
      batch_drained = false;
      if (n.error().error != EAGAIN) return io_error(n.error());
      if (!wait) return std::optional<std::size_t>{};
      // Only on a non-blocking channel (the wait is otherwise inside recvmmsg): wait, then read.
      if (auto w = sys::wait_fd(channel.fd(), sys::WaitFor::Readable, std::nullopt); !w) return io_error(w.error());
    }
  }

  // Images (DESIGN §7): defined below, next to the constructor.
  static constexpr std::chrono::milliseconds kWorkerParkDeadline{500};
  SdkResult<bool> take_image(std::uint64_t g, std::uint64_t base);
  SdkResult<bool> resumed_image();
  // The memfd for the next image by written pages, if tracking and none is made yet.
  void prepare_pages_fd() {
    if (next_pages_fd < 0 && tracked_base != 0) {
      if (auto made = memory_image::make_record_file()) next_pages_fd = made->release();
    }
  }

  // Sends a request and waits for its Reply, queueing every other frame (handled later, in order).
  SdkResult<InvokeReply> request(std::span<std::byte> out, std::string_view what) {
    const std::uint32_t want = seq;
    if (auto s = send(tx.bytes()); !s) return std::unexpected(s.error());
    for (;;) {
      auto got = receive(true);
      if (!got) return std::unexpected(got.error());
      const std::span<const std::byte> bytes(rx.data(), **got);
      auto frame = wire::decode(bytes, wire::Direction::ToService);
      if (frame && frame->kind == wire::FrameKind::Snapshot) {
        // A checkpoint while this process waits (the caller of checkpoint() always does): the image is
        // taken inside the call and, once restored, returns from it with RolledBack (DESIGN §7).
        auto resumed = take_image(frame->header.aux, wire::payload_as<wire::SnapshotBody>(*frame).base);
        if (!resumed) return std::unexpected(resumed.error());
        if (*resumed) return error(SdkError::RolledBack, std::string(what));
        continue;
      }
      if (frame && frame->kind == wire::FrameKind::Reply && frame->header.seq == want) {
        const auto head = wire::payload_as<wire::ReplyHeader>(*frame);
        if (head.error != 0) return reply_error(head.error, std::string(what));
        const auto data = frame->payload.subspan(sizeof(wire::ReplyHeader));
        const std::size_t n = std::min(data.size(), out.size());
        if (n > 0) std::memcpy(out.data(), data.data(), n);  // out may be empty (a null data())
        return InvokeReply{.value = head.value, .data_size = n};
      }
      queued.emplace_back(bytes.begin(), bytes.end());
    }
  }
};

namespace {

// The context an image is taken in (memory_image.hpp REJUV_IMAGE_SAVE) and what a frozen copy hands to it
// when it is resumed. In .bss: part of every image, written by a copy only just before it jumps.
memory_image::Context image_context{};
struct Handoff {
  std::uint64_t generation = 0;  // of the image (before the jump: which one a new copy serves)
  std::uint32_t epoch = 0;       // Resume: the epoch the restored incarnation runs in
  bool tracking = false;         // Resume: the copy tracks its writes from the image
};
Handoff handoff{};
static_assert(memory_image::kMaxWrittenPages == wire::kMaxImagePages, "one limit on an image's written pages");

// A new frozen copy tracks its writes from the image (track_writes_self drops what it inherited first), so
// that once resumed its next image can be by written pages; its tracking state lives outside data, heap and
// stack. Then, as after every fork on either side (memory_image::touch_working_set), it makes its working
// set its own, so that the copy a Resume wakes takes no copy-on-write fault on the rollback's critical path
// (mission, 3 A/B pairs: rollback p50 0.87, 0.85, 1.10 ms without → 0.66, 0.72, 0.79 ms with).
void start_copy() {
  if (memory_image::whole_memory_tracked()) (void)memory_image::track_writes_self();
  memory_image::touch_working_set();
}

// Copied{g, pid} on a resume socket, from a frozen copy (standby stack, no allocation); a failed fork
// answers pid 0 with its errno.
void answer_copied(const sys::SeqPacket& to, std::uint64_t g, const sys::SysResult<pid_t>& copy) {
  wire::FrameBuffer out;
  const wire::TakenBody body{.image_pid = copy ? *copy : 0,
                             .reserved = copy ? 0U : static_cast<std::uint32_t>(copy.error().error)};
  if (out.build_with(wire::FrameKind::Copied, 0, 0, g, body)) (void)to.send(out.bytes());
}

// A frozen image of generation handoff.generation (DESIGN §7), on the standby stack: blocks on its resume
// socket, which every frozen copy of the generation shares.
//   Fork: one copy forks a spare (g stays restorable after it is resumed) and answers Copied{pid}.
//   Patch{g', pages} with the sealed pages and g''s resume socket: one copy forks a copy that applies the
//     pages (memory_image::apply_written) and serves g''s socket as g''s image, answering Copied there.
//   Resume{g, epoch} with a new channel: the copy that reads it takes the channel at fd 3 and jumps into the
//     context the image was taken in (take_image), where it continues as the live service.
// The kernel closing the socket (generation discarded) or killing the copy ends it. Until the jump it
// writes nothing but its standby stack and memory_image's scratch (the rule memory_image.hpp states): no
// allocation, so the socket is read with SeqPacket::receive_into.
[[noreturn]] void frozen_image(int resume_fd) {
  std::uint64_t g = handoff.generation;
  sys::SeqPacket resume{sys::UniqueFd(resume_fd)};
  start_copy();
  for (;;) {
    alignas(8) std::array<std::byte, sizeof(wire::FrameHeader) + sizeof(wire::PatchBody)> buf{};
    std::array<int, 2> fds{-1, -1};
    std::size_t nfds = 0;
    auto n = resume.receive_into(buf, fds, nfds);
    if (!n || *n == 0) std::_Exit(0);  // closed: the generation is gone
    auto frame = wire::decode(std::span<const std::byte>(buf.data(), *n), wire::Direction::ToService);
    if (!frame || frame->header.aux != g) std::_Exit(3);  // the kernel is trusted: this is a broken kernel
    if (frame->kind == wire::FrameKind::Fork && nfds == 0) {
      auto copy = sys::fork_sibling();
      if (copy && *copy == 0) {  // the spare: frozen like us
        start_copy();
        continue;
      }
      answer_copied(resume, g, copy);
      if (copy) memory_image::touch_working_set();  // the fork shared our pages again
      continue;
    }
    if (frame->kind == wire::FrameKind::Patch && nfds == 2) {
      const auto body = wire::payload_as<wire::PatchBody>(*frame);
      sys::UniqueFd pages(fds[0]);
      sys::SeqPacket next{sys::UniqueFd(fds[1])};
      auto copy = sys::fork_sibling();
      if (copy && *copy == 0) {  // the new image: g's memory made g''s
        if (!memory_image::apply_written(pages.get(), body.pages)) std::_Exit(3);
        resume = std::move(next);
        g = body.generation;
        start_copy();
        answer_copied(resume, g, sys::SysResult<pid_t>(sys::current_pid()));
        continue;
      }
      if (copy) {
        memory_image::touch_working_set();  // the fork shared our pages again
      } else {
        answer_copied(next, body.generation, copy);  // g' has no image
      }
      continue;  // pages and next closed here
    }
    if (frame->kind != wire::FrameKind::Resume || nfds != 1) std::_Exit(3);
    resume.close();
    if (!sys::install_fd(sys::UniqueFd(fds[0]), wire::kChannelFd) || !sys::set_nonblocking(wire::kChannelFd, false)) {
      std::_Exit(3);
    }
    handoff.generation = g;
    handoff.epoch = wire::payload_as<wire::ResumeBody>(*frame).epoch;
    handoff.tracking = memory_image::tracking_writes();
    memory_image::resume_saved(image_context);
  }
}

}  // namespace

// Snapshot{g, base} (DESIGN §7, docs/protocol.md "Checkpoint and rollback"): everything received before it
// has been handled (channels are FIFO). Sends what is queued (so that nothing sent before the cut is sent
// again by a restored image) and takes the image in one of two ways:
//   - by written pages, when the kernel offers a base generation this process's memory derives from and
//     its tracked layout still holds: the pages written since the base go into a sealed memfd, answered
//     with TakenPages{g, base, pages}; the kernel has a copy of the base image make g's image from them,
//     off the critical path. No fork, no copy-on-write faults afterwards.
//   - by fork otherwise (the first image, workers, a changed layout, a dynamic build): parks the workers,
//     starts tracking writes afresh, forks the image as the kernel's child and answers Taken{g, pid}.
// Returns false in the live process; true when this process is the image, resumed by a rollback and now
// live on its new channel. A refusal (no resume socket, workers that do not park, a failed fork) is a Taken
// with pid 0: the kernel abandons generation g.
//
// Both ways save the context here (REJUV_IMAGE_SAVE) and the image resumes by jumping back into it, so no
// local that owns anything may live across the save: a resumed image returns through this frame and would
// run its destructors with the live process's values.
SdkResult<bool> Service::Impl::take_image(std::uint64_t g, std::uint64_t base) {
  // The resume socket, and with the first base offered this process's pagemap (it cannot open its own: it is
  // not dumpable), kept for the next ones.
  const int resume_fd = !rx_fds.empty() ? rx_fds.front().release() : -1;
  if (rx_fds.size() == 2) {
    if (pagemap_fd >= 0) ::close(pagemap_fd);
    pagemap_fd = rx_fds.back().release();
  }
  rx_fds.clear();
  const auto answer = [&](wire::FrameKind kind, pid_t pid) -> SdkResult<void> {
    const wire::TakenBody body{.image_pid = pid, .reserved = 0};
    if (!tx.build_with(kind, 0, 0, g, body)) return error(SdkError::Protocol);
    if (auto q = send_built(); !q) return q;
    return flush();
  };
  prepare_pages_fd();  // normally made already, after the previous checkpoint
  if (base != 0 && base == tracked_base && workers == nullptr && next_pages_fd >= 0 &&
      memory_image::layout_unchanged(memory_image::stack_pointer())) {
    if (resume_fd >= 0) ::close(resume_fd);  // the image is made from the base's, which has its own
    if (auto f = flush(); !f) return std::unexpected(f.error());
    const int pages = std::exchange(next_pages_fd, -1);
    if (REJUV_IMAGE_SAVE(image_context) != 0) return resumed_image();
    auto n = memory_image::copy_written_self(pages, pagemap_fd);
    tracked_base = 0;  // until the answer is on its way: a failure leaves the tracking in no known state
    if (!n || ::fcntl(pages, F_ADD_SEALS, wire::kPagesSeals) != 0) {
      ::close(pages);
      if (auto a = answer(wire::FrameKind::Taken, 0); !a) return std::unexpected(a.error());  // g is abandoned
      return false;
    }
    tracked_base = g;
    const wire::TakenPagesBody body{.base = base, .pages = *n};
    if (!tx.build_with(wire::FrameKind::TakenPages, 0, 0, g, body)) return error(SdkError::Protocol);
    auto sent = channel.send(tx.bytes(), std::span(&pages, 1));
    ::close(pages);
    if (!sent) return io_error(sent.error());
    return false;
  }
  // The resume socket is made blocking here, for the image (the live process never reads it): a new copy
  // then has nothing to set up before it blocks on it.
  if (resume_fd < 0 || !sys::set_nonblocking(resume_fd, false) ||
      (workers != nullptr && !workers->park_all(kWorkerParkDeadline))) {
    if (resume_fd >= 0) ::close(resume_fd);
    if (auto a = answer(wire::FrameKind::Taken, 0); !a) return std::unexpected(a.error());
    return false;
  }
  if (auto f = flush(); !f) {
    ::close(resume_fd);
    return std::unexpected(f.error());
  }
  if (next_pages_fd >= 0) ::close(std::exchange(next_pages_fd, -1));  // not into the image's fd table
  handoff.generation = g;
  if (REJUV_IMAGE_SAVE(image_context) != 0) return resumed_image();
  // Tracking starts (again) before the fork: what this process writes from here on is what its next image
  // by written pages carries over g's.
  tracked_base = memory_image::whole_memory_tracked() && workers == nullptr && memory_image::track_writes_self() ? g : 0;
  auto pid = sys::fork_sibling();
  if (pid && *pid == 0) memory_image::run_on_standby_stack(frozen_image, resume_fd);  // never returns
  ::close(resume_fd);
  if (workers != nullptr) workers->unpark_all();
  if (auto a = answer(wire::FrameKind::Taken, pid ? *pid : 0); !a) return std::unexpected(a.error());
  return false;
}

// In a copy of an image that a Resume woke (frozen_image), back in take_image's frame on the main stack:
// the restored incarnation, live on its new channel (fd 3).
SdkResult<bool> Service::Impl::resumed_image() {
  frames_received = 0;  // Idle counts frames on this channel (docs/protocol.md "Idle")
  idle_reported = 0;
  forget_batch();       // frames read ahead on the old channel belong to the old incarnation
  restored = CheckpointOutcome{.kind = CheckpointOutcome::Kind::Restored, .generation = Generation{handoff.generation},
                               .epoch = Epoch{handoff.epoch}};
  tracked_base = handoff.tracking ? handoff.generation : 0;
  pagemap_fd = -1;     // the numbers were the live process's: this one's kernel sends its own
  next_pages_fd = -1;
  // Without its workers this incarnation would run half a service: it dies at once instead, so the kernel
  // sees its channel hang up and falls back (an abort here would signal itself, and a copy's signal to
  // itself waits for the kernel's seccomp supervisor, which is waiting for this Resumed).
  if (workers != nullptr) {
    workers = WorkerSet::respawn_in_image(workers);
    if (workers == nullptr) std::_Exit(3);
  }
  const wire::TakenBody answer{.image_pid = sys::current_pid(), .reserved = 0};
  if (!tx.build_with(wire::FrameKind::Resumed, 0, 0, handoff.generation, answer) || !send_built() || !flush()) {
    std::_Exit(3);
  }
  return true;
}

Service::Service(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Service::~Service() {
  if (impl_ && impl_->workers != nullptr) {
    delete impl_->workers;  // NOLINT(cppcoreguidelines-owning-memory): stops and joins them
    impl_->workers = nullptr;
  }
  // One attempt, never a wait: a service leaving must not hang on a kernel that stopped reading.
  if (impl_) {
    for (std::size_t start = 0; start < impl_->out_used;) {
      const std::span<const std::byte> next = impl_->packed(start);
      if (!impl_->channel.send(next)) break;
      start += wire::aligned_frame_size(next.size());
    }
  }
}

SdkResult<void> Service::flush() { return impl_->flush(); }

SdkResult<std::unique_ptr<Service>> Service::connect(const ConnectOptions& options) {
  // First, before the service allocates much: malloc tied to the brk heap, the stack grown once, so that a
  // static build can take its images by written pages (memory_image.hpp). Where that fails, or the process
  // has more writable memory (whole_memory_tracked() says which), every image is by fork.
  (void)memory_image::prepare_self();
  auto impl = std::make_unique<Impl>();
  if (const char* name = std::getenv("REJUV_SERVICE"); name != nullptr) impl->name = name;
  if (!sys::fd_is_open(options.channel_fd) || !sys::fd_is_open(options.time_page_fd)) {
    return error(SdkError::NotAService, "fd 3 (channel) and fd 4 (time page) must be open: run under the kernel");
  }
  // The sandbox is the kernel's (installed before exec, DESIGN §7 "Protection"): from the first Ready on,
  // this process opens nothing and maps nothing executable.
  memory_image::opens_done();
  // Not dumpable: no process of its uid (its own images, say) can open its /proc/<pid>/mem or ptrace it.
  // Its images inherit this at fork (frozen_image).
  if (auto nd = sys::make_non_dumpable(); !nd) return error(SdkError::NotAService, nd.error().to_string());
  auto page = clock::TimePageReader::map(options.time_page_fd);
  if (!page) return error(SdkError::NotAService, "time page: " + page.error().to_string());
  impl->time = std::move(*page);
  impl->channel = sys::SeqPacket(sys::UniqueFd(options.channel_fd));
  // Blocking for reads, so that waiting for a frame is the read itself (receive_batch, Wait::ForOne); every
  // read that must not wait and every send say so per call (MSG_DONTWAIT).
  if (auto nb = sys::set_nonblocking(options.channel_fd, false); !nb) return io_error(nb.error());

  // Hello, then Boot, BootCap × n, BootParam × m, BootEnd (docs/protocol.md "Boot").
  if (!impl->tx.build(wire::FrameKind::Hello, 0, 0, wire::kProtocolVersion)) return error(SdkError::Protocol);
  if (auto s = impl->send(impl->tx.bytes()); !s) {
    if (s.error().code == SdkError::ChannelIo) s.error().code = SdkError::NotAService;
    return std::unexpected(s.error());
  }
  const auto next = [&]() -> SdkResult<wire::FrameView> {
    auto got = impl->receive(true);
    if (!got) return std::unexpected(got.error());
    auto frame = wire::decode(std::span<const std::byte>(impl->rx.data(), **got), wire::Direction::ToService);
    if (!frame) return error(SdkError::Protocol, std::string("boot: ") + std::string(wire::to_string(frame.error())));
    return *frame;
  };
  auto boot = next();
  if (!boot) return std::unexpected(boot.error());
  if (boot->kind != wire::FrameKind::Boot) {
    return error(SdkError::Protocol, "expected Boot, got " + std::string(wire::to_string(boot->kind)));
  }
  if (boot->header.aux != wire::kProtocolVersion && boot->header.aux != 0) {
    return error(SdkError::VersionMismatch, "kernel speaks version " + std::to_string(boot->header.aux));
  }
  const auto head = wire::payload_as<wire::BootHeader>(*boot);
  impl->id = ServiceId(head.service_id);
  if (impl->name.empty()) impl->name = std::string(wire::read_name(head.name));
  std::size_t max_slot = 0;
  for (std::uint32_t i = 0; i < head.cap_count; ++i) {
    auto f = next();
    if (!f) return std::unexpected(f.error());
    if (f->kind != wire::FrameKind::BootCap) return error(SdkError::Protocol, "expected BootCap");
    const auto c = wire::payload_as<wire::BootCap>(*f);
    // The slot sizes a table below (subscription_by_slot): one out of the CSpace is a broken boot script,
    // not a reason to allocate gigabytes (found by tests/fuzz sdk_frames).
    if (c.slot >= wire::kCSpaceSlots) return error(SdkError::Protocol, "BootCap slot " + std::to_string(c.slot) + " out of range");
    CapInfo info;
    info.object = std::string(wire::read_name(c.object));
    info.slot = Slot(c.slot);
    info.kind = c.kind < kAllObjectKinds.size() ? static_cast<ObjectKind>(c.kind) : ObjectKind::Topic;
    for (std::size_t m = 0; m < kModeCount; ++m) {
      info.rights[m] = Rights::none();
      for (const Right r : {Right::Read, Right::Write, Right::Grant}) {
        if ((c.rights_by_mode[m] & static_cast<std::uint8_t>(r)) != 0) info.rights[m] = info.rights[m] | r;
      }
    }
    info.type = std::string(wire::read_name(c.type));
    info.payload_size = c.payload_size;
    max_slot = std::max<std::size_t>(max_slot, c.slot);
    impl->caps.push_back(std::move(info));
  }
  for (std::uint32_t i = 0; i < head.param_count; ++i) {
    auto f = next();
    if (!f) return std::unexpected(f.error());
    if (f->kind != wire::FrameKind::BootParam) return error(SdkError::Protocol, "expected BootParam");
    const auto p = wire::payload_as<wire::BootParam>(*f);
    impl->params.push_back(Param{.name = std::string(wire::read_name(p.name)),
                                 .number = p.number,
                                 .text = std::string(wire::read_name(p.text)),
                                 .is_text = p.is_text != 0});
  }
  auto end = next();
  if (!end) return std::unexpected(end.error());
  if (end->kind != wire::FrameKind::BootEnd) return error(SdkError::Protocol, "expected BootEnd");
  impl->subscription_by_slot.assign(max_slot + 1, nullptr);
  for (const Param& p : impl->params) {
    if (p.name == "clock" && p.is_text) impl->lockstep = p.text != "realtime";
  }
  return std::unique_ptr<Service>(new Service(std::move(impl)));
}

std::string_view Service::name() const { return impl_->name; }
ServiceId Service::id() const { return impl_->id; }
Nanos Service::now() const { return impl_->time.read().now; }
SrMode Service::mode() const { return impl_->time.read().mode; }
Epoch Service::epoch() const { return impl_->time.read().epoch; }

double Service::param(std::string_view name, double fallback) const {
  for (const Param& p : impl_->params) {
    if (p.name == name && !p.is_text) return p.number;
  }
  return fallback;
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
  return error(SdkError::NoSuchObject, std::string(object));
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

SdkResult<InvokeReply> Service::invoke(std::string_view object, cap::Operation op, std::uint64_t arg0,
                                       std::uint64_t arg1, std::span<const std::byte> data, std::span<std::byte> out) {
  auto found = cap(object);
  if (!found) return std::unexpected(found.error());
  return invoke_slot((*found)->slot, op, arg0, arg1, data, out);
}

SdkResult<CheckpointOutcome> Service::checkpoint(std::string_view object) {
  auto reply = invoke(object, cap::Operation::CheckpointCreate);
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

SdkResult<void> Service::send_raw(std::span<const std::byte> frame) { return impl_->send(frame); }

int Service::run() {
  Impl& s = *impl_;
  if (!s.ready_sent) {
    if (!s.tx.build(wire::FrameKind::Ready, 0, 0, 0) || !s.send_built()) return 1;
    s.ready_sent = true;
  }
  const auto leave = [&](int code) {
    (void)s.flush();
    return code;
  };
  std::vector<std::byte> held;  // a queued frame being handled (rx may be reused meanwhile)
  while (!s.stopping) {
    std::span<const std::byte> bytes;
    if (!s.queued.empty()) {
      held = std::move(s.queued.front());
      s.queued.pop_front();
      bytes = held;
    } else {
      auto got = s.receive(false);
      if (got && !*got) {
        // Drained: everything received has been handled (docs/protocol.md "Idle").
        if (s.lockstep && s.frames_received != s.idle_reported) {
          if (!s.tx.build(wire::FrameKind::Idle, 0, 0, s.frames_received) || !s.send_built()) return 1;
          s.idle_reported = s.frames_received;
        }
        if (!s.flush()) return 1;
        got = s.receive(true);  // sleeps in recvmmsg until the next frame: the wait is the read
        s.prepare_pages_fd();   // after a checkpoint's commit (no frame comes before it), not inside it
      }
      if (!got) {
        if (got.error().code == SdkError::ChannelClosed) return 1;
        std::fprintf(stderr, "[%s] channel: %s\n", s.name.c_str(), got.error().to_string().c_str());
        return 1;
      }
      if (!*got) continue;
      bytes = std::span<const std::byte>(s.rx.data(), **got);
    }
    auto frame = wire::decode(bytes, wire::Direction::ToService);
    if (!frame) {
      ++s.bad_frames;
      continue;
    }
    switch (frame->kind) {
      case wire::FrameKind::Deliver: {
        const std::uint32_t slot = frame->header.slot;
        detail::SubscriptionBase* sub = slot < s.subscription_by_slot.size() ? s.subscription_by_slot[slot] : nullptr;
        if (sub == nullptr || frame->payload.size() != sub->size()) {
          ++s.bad_frames;
          break;
        }
        sub->deliver(frame->header.aux, frame->payload);
        break;
      }
      case wire::FrameKind::TimerFired: {
        TimerSlot* slot = s.timer_slot(frame->header.aux);
        if (slot == nullptr) break;  // cancelled meanwhile, or no id of ours
        TimerSlot& t = *slot;
        if (!t.periodic) {
          t.armed = false;
          const std::function<void()> fn = std::move(t.on_fire);
          t.on_fire = nullptr;
          if (fn) fn();
        } else if (t.on_fire) {
          t.on_fire();
        }
        break;
      }
      case wire::FrameKind::Shutdown:
        if (s.on_shutdown) s.on_shutdown();
        return leave(0);
      case wire::FrameKind::Snapshot: {
        auto resumed = s.take_image(frame->header.aux, wire::payload_as<wire::SnapshotBody>(*frame).base);
        if (!resumed) {
          std::fprintf(stderr, "[%s] checkpoint: %s\n", s.name.c_str(), resumed.error().to_string().c_str());
          return 1;
        }
        break;  // live or restored: the loop goes on (a restored image on its new channel)
      }
      case wire::FrameKind::Reply:           // a reply nobody waits for
      case wire::FrameKind::Boot:
      case wire::FrameKind::BootCap:
      case wire::FrameKind::BootParam:
      case wire::FrameKind::BootEnd:
      case wire::FrameKind::Resume:       // only ever on an image's resume socket
      case wire::FrameKind::Fork:
      case wire::FrameKind::Patch:
        ++s.bad_frames;
        break;
      case wire::FrameKind::NetDatagram: {  // network gate (docs/protocol.md): slot = our Network cap
        const auto handler = std::find_if(s.datagram_handlers.begin(), s.datagram_handlers.end(),
                                          [&](const auto& h) { return h.first == frame->header.slot; });
        if (handler == s.datagram_handlers.end() || frame->payload.size() > s.datagram.size()) {
          ++s.bad_frames;
          break;
        }
        const std::size_t n = frame->payload.size();
        std::memcpy(s.datagram.data(), frame->payload.data(), n);
        s.datagram_id = frame->header.aux;
        handler->second(std::span<const std::byte>(s.datagram.data(), n));
        s.datagram_id = 0;
        break;
      }
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
        ++s.bad_frames;  // decode() refuses service → kernel kinds here; unreachable
        break;
    }
  }
  return leave(s.exit_code);
}

}  // namespace rejuv::sdk
