// The image protocol of a service (docs/design.md §7; docs/protocol.md "Checkpoint and rollback"): take_image
// answers a Snapshot by written pages or by fork; a frozen copy (frozen_image) waits on the standby stack for
// Fork, Patch or Resume; resumed_image makes a woken copy the live service on its new channel.
// The standby-stack rule (memory_image.hpp): a frozen copy writes nothing but its standby stack and
// memory_image's scratch until it jumps — no allocation, so its socket is read with receive_into and its
// answers built in a FrameBuffer on that stack.
#include <cerrno>
#include <cstdlib>
#include <utility>

#include <fcntl.h>
#include <unistd.h>

#include "rejuv/sdk/memory_image.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/process.hpp"
#include "service_impl.hpp"

namespace rejuv::sdk {

void Service::Impl::prepare_pages_fd() {
  if (next_pages_fd < 0 && tracked_base != 0) {
    if (auto made = memory_image::make_record_file()) next_pages_fd = made->release();
  }
}

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

// A frozen image of generation handoff.generation (docs/design.md §7), on the standby stack: blocks on its resume
// socket, which every frozen copy of the generation shares.
//   Fork: one copy forks a spare (g stays restorable after it is resumed) and answers Copied{pid}.
//   Patch{g', pages} with the sealed pages and g''s resume socket: one copy forks a copy that applies the
//     pages (memory_image::apply_written) and serves g''s socket as g''s image, answering Copied there.
//   Resume{g, epoch} with a new channel and a new output pipe: the copy that reads it takes the channel at fd 3
//     and the pipe at fds 1-2, and jumps into the context the image was taken in (take_image), where it
//     continues as the live service.
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
    if (frame->kind != wire::FrameKind::Resume || nfds != 2) std::_Exit(3);
    resume.close();
    // A new channel and a new output pipe: nothing of the open files the image shares with the incarnation
    // it was taken from (whose owner, flags or queued bytes a compromised incarnation may have changed) is
    // used by the restored one. Only the time page (read-only) stays shared.
    sys::UniqueFd output(fds[1]);
    if (!sys::install_fd(sys::UniqueFd(fds[0]), wire::kChannelFd) || !sys::set_nonblocking(wire::kChannelFd, false) ||
        ::dup2(output.get(), STDOUT_FILENO) < 0 || ::dup2(output.get(), STDERR_FILENO) < 0) {
      std::_Exit(3);
    }
    output.reset();
    handoff.generation = g;
    handoff.epoch = wire::payload_as<wire::ResumeBody>(*frame).epoch;
    handoff.tracking = memory_image::tracking_writes();
    memory_image::resume_saved(image_context);
  }
}

}  // namespace

// Snapshot{g, base} (docs/design.md §7, docs/protocol.md "Checkpoint and rollback"): everything received before it
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
  // `err`: with pid 0, the errno of what failed (0 where nothing set one: no resume socket, workers that did not park).
  const auto answer = [&](wire::FrameKind kind, pid_t pid, int err = 0) -> SdkResult<void> {
    const wire::TakenBody body{.image_pid = pid, .reserved = static_cast<std::uint32_t>(err)};
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
  if (pid && *pid == 0) {
    // The image holds no pagemap: this one reads the live process's, and the incarnation a Resume makes of
    // the image gets its own from the kernel (resumed_image forgets the number). Kept, it would stay open in
    // every later incarnation and image of this line, one more per rollback, until RLIMIT_NOFILE refused
    // the fds of a Resume.
    if (pagemap_fd >= 0) ::close(pagemap_fd);
    memory_image::run_on_standby_stack(frozen_image, resume_fd);  // never returns
  }
  ::close(resume_fd);
  if (workers != nullptr) workers->unpark_all();
  if (auto a = answer(wire::FrameKind::Taken, pid ? *pid : 0, pid ? 0 : pid.error().error); !a) {
    return std::unexpected(a.error());
  }
  return false;
}

// In a copy of an image that a Resume woke (frozen_image), back in take_image's frame on the main stack:
// the restored incarnation, live on its new channel (fd 3).
SdkResult<bool> Service::Impl::resumed_image() {
  frames_received = 0;  // Idle counts frames on this channel (docs/protocol.md "Idle")
  idle_reported = 0;
  reader.forget();      // frames read ahead on the old channel belong to the old incarnation
  restored = CheckpointOutcome{.kind = CheckpointOutcome::Kind::Restored, .generation = Generation{handoff.generation},
                               .epoch = Epoch{handoff.epoch}};
  restored_pending = true;  // on_restored runs in the event loop, before the next frame (service.cpp run)
  tracked_base = handoff.tracking ? handoff.generation : 0;
  pagemap_fd = -1;  // closed in every image (take_image): the kernel sends this incarnation its own
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

}  // namespace rejuv::sdk
