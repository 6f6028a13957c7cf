// The service of bench/image and its smoke test: a static, single-threaded process the
// size of a flight service (≈ 370 KB of heap, 240 KB of it written every tick, or argv[1] pages) that can be imaged both ways, by fork (what
// the runtime does today) and by copy (rejuv/sdk/memory_image.hpp). Its channel is fd 3; one byte of
// command, an optional body, an optional fd:
//   't'            tick: counter + 1, every 512th word of the work area rewritten; answers 'a' + counter
//   'f' + fd       fork image: a child of the bench (clone(CLONE_PARENT)) frozen on fd; answers 'p' + pid
//   's' + fd       copy image: saves its context, answers 'l' + Layout + pid and waits until fd closes
//   'z' + fd       zygote: a child on the standby stack serving fd; answers 'p' + pid
//   'w'            start tracking writes (memory_image.hpp); answers 'w' + errno (0: tracking)
//   'd' + fd       image by written pages: saves its context, copies the pages written since the previous
//                  image into the memfd fd and goes on; answers 'D' + page count + Layout
// While it tracks writes, 's' answers the tracked layout and re-arms the tracking (the base image).
// A frozen fork image, a zygote and a holder serve their own socket:
//   'f' + fd       (zygote) fork a holder serving fd; answers 'p' + pid
//   'l' + Layout + fd   (holder) load the image in the memfd fd; answers 'k'
//   'g' + fd       (fork image, loaded holder) continue as the service on channel fd: answers 'r' + counter
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "image_messages.hpp"
#include "rejuv/sdk/memory_image.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::bench_image {
using namespace memory_image;  // NOLINT(google-build-using-namespace): the bench is built on it
namespace {

using sys::SeqPacket;
using sys::UniqueFd;

constexpr int kChannelFd = 3;
constexpr std::size_t kWorkWords = 30'000;  // the heap then is ≈ 370 KB, like rejuv_ekf2's
constexpr std::size_t kPageWords = 512;
std::size_t tick_stride = kPageWords;       // a tick writes one word every `tick_stride` (argv[1]: pages per tick)

std::uint64_t counter = 0;
std::vector<std::uint64_t>* work = nullptr;
Context saved{};
SeqPacket* channel = nullptr;  // fd 3 in every incarnation

void answer(const SeqPacket& to, char kind, const auto&... parts) {
  if (!send_message(to, kind, -1, parts...)) std::_Exit(4);
}

// Answers the pid a fork_sibling() gave this process (0 when it failed).
void answer_fork(const SeqPacket& to, const sys::SysResult<pid_t>& pid) {
  answer(to, 'p', static_cast<std::int32_t>(pid ? *pid : 0));
}

// Moves `fd` to the channel's number, as the live service had it.
void take_channel(UniqueFd fd) {
  if (::dup3(fd.get(), kChannelFd, O_CLOEXEC) != kChannelFd) std::_Exit(5);
}

// A frozen fork image: waits for 'g', then returns to be the service.
void frozen(SeqPacket resume) {
  Message m;
  if (!receive_message(resume, m) || m.kind != 'g' || !m.fd.valid()) std::_Exit(0);
  take_channel(std::move(m.fd));
  resume.close();
  answer(*channel, 'r', counter);
}

// Zygote and holders, on the standby stack.
void standby(int fd) {
  SeqPacket sock{UniqueFd(fd)};
  for (;;) {
    Message m;
    if (!receive_message(sock, m)) std::_Exit(0);
    if (m.kind == 'f' && m.fd.valid()) {
      auto pid = sys::fork_sibling();
      if (pid && *pid == 0) {  // the holder: serves the new socket
        sock = SeqPacket(std::move(m.fd));
        continue;
      }
      answer_fork(sock, pid);
    } else if (m.kind == 'l' && m.fd.valid() && m.body_size == sizeof(Layout)) {
      if (!load_self(m.at<Layout>(0), m.fd.get())) std::_Exit(6);
      m.fd.reset();
      answer(sock, 'k');
    } else if (m.kind == 'g' && m.fd.valid()) {
      sock.close();  // first: it may hold fd 3 (the zygote closed the service's channel)
      take_channel(std::move(m.fd));
      resume_saved(saved);
    } else {
      std::_Exit(7);
    }
  }
}

[[noreturn]] void serve() {
  for (;;) {
    Message m;
    if (!receive_message(*channel, m)) std::_Exit(0);
    switch (m.kind) {
      case 't':
        ++counter;
        for (std::size_t i = 0; i < work->size(); i += tick_stride) (*work)[i] += counter;
        answer(*channel, 'a', counter);
        break;
      case 'f': {
        auto pid = sys::fork_sibling();
        if (pid && *pid == 0) {
          frozen(SeqPacket(std::move(m.fd)));
          break;
        }
        answer_fork(*channel, pid);
        break;
      }
      case 'z': {
        auto pid = sys::fork_sibling();
        if (pid && *pid == 0) {
          ::close(kChannelFd);
          forget_tracking();
          run_on_standby_stack(standby, m.fd.release());
        }
        answer_fork(*channel, pid);
        break;
      }
      case 's': {
        if (REJUV_IMAGE_SAVE(saved) != 0) {
          // A holder, resumed: this frame is the image's (m.fd was handed to the wait below before the
          // copy, so nothing of the old process is closed here); the new channel is at fd 3 like the old one.
          answer(*channel, 'r', counter);
          break;
        }
        if (tracking_writes() && !copy_written_self(-1)) std::_Exit(8);
        answer(*channel, 'l', tracking_writes() ? tracked_layout() : layout_at(stack_pointer()),
               static_cast<std::int32_t>(::getpid()));
        std::array<std::byte, 1> wait{};
        (void)SeqPacket(std::move(m.fd)).receive(wait);  // the bench closes it once it has copied
        break;
      }
      case 'w': {
        auto tracked = track_writes_self();
        answer(*channel, 'w', static_cast<std::int32_t>(tracked ? 0 : tracked.error().error));
        break;
      }
      case 'd': {
        // Out of `m` first: the image is taken with this frame, and a resumed holder must not close the
        // number, which names nothing of its own.
        const int delta = m.fd.release();
        if (REJUV_IMAGE_SAVE(saved) != 0) {  // a holder, resumed (as after 's')
          answer(*channel, 'r', counter);
          break;
        }
        auto pages = copy_written_self(delta);
        ::close(delta);
        if (!pages) {
          std::fprintf(stderr, "image_service: %s\n", pages.error().to_string().c_str());
          std::_Exit(8);
        }
        answer(*channel, 'D', static_cast<std::uint32_t>(*pages), tracked_layout());
        break;
      }
      default:
        std::_Exit(7);
    }
  }
}

int run(int argc, char** argv) {
  if (argc > 1) {  // pages written per tick (the flight services write 9-15, docs/performance.md)
    const long pages = std::strtol(argv[1], nullptr, 10);
    if (pages < 1) return 2;
    tick_stride = std::max<std::size_t>(kPageWords, kWorkWords / static_cast<std::size_t>(pages));
  }
  if (!prepare_self()) return 2;
  work = new std::vector<std::uint64_t>(kWorkWords, 1);
  channel = new SeqPacket(UniqueFd(kChannelFd));
  serve();
}

}  // namespace
}  // namespace rejuv::bench_image

int main(int argc, char** argv) { return rejuv::bench_image::run(argc, argv); }
