// The service of bench/image and its smoke test: a static, single-threaded process the
// size of a flight service (≈ 370 KB of heap, 240 KB of it written every tick) that can be imaged both ways, by fork (what
// the runtime does today) and by copy (rejuv/image/memory_image.hpp). Its channel is fd 3; one byte of
// command, an optional body, an optional fd:
//   't'            tick: counter + 1, every 512th word of the work area rewritten; answers 'a' + counter
//   'f' + fd       fork image: a child of the bench (clone(CLONE_PARENT)) frozen on fd; answers 'p' + pid
//   's' + fd       copy image: saves its context, answers 'l' + Layout + pid and waits until fd closes
//   'z' + fd       zygote: a child on the standby stack serving fd; answers 'p' + pid
// A frozen fork image, a zygote and a holder serve their own socket:
//   'f' + fd       (zygote) fork a holder serving fd; answers 'p' + pid
//   'l' + Layout + fd   (holder) load the image in the memfd fd; answers 'k'
//   'g' + fd       (fork image, loaded holder) continue as the service on channel fd: answers 'r' + counter
#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "memory_image.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/process.hpp"

namespace {

using rejuv::bench_image::Layout;
using rejuv::sys::SeqPacket;
using rejuv::sys::UniqueFd;

constexpr int kChannelFd = 3;
constexpr std::size_t kWorkWords = 30'000;  // the heap then is ≈ 370 KB, like rejuv_ekf2's

std::uint64_t counter = 0;
std::vector<std::uint64_t>* work = nullptr;
rejuv::bench_image::Context saved{};
SeqPacket* channel = nullptr;  // fd 3 in every incarnation

struct Message {
  char kind = 0;
  std::array<std::byte, 64> body{};
  std::size_t body_size = 0;
  UniqueFd fd;
};

bool receive(const SeqPacket& from, Message& m) {
  std::array<std::byte, 80> buf{};
  auto got = from.receive(buf, 1);
  if (!got || got->closed || got->size == 0) return false;
  m.kind = static_cast<char>(buf[0]);
  m.body_size = got->size - 1;
  std::memcpy(m.body.data(), buf.data() + 1, std::min(m.body_size, m.body.size()));
  m.fd = got->fds.empty() ? UniqueFd() : std::move(got->fds.front());
  return true;
}

template <typename... T>
void answer(const SeqPacket& to, char kind, const T&... parts) {
  std::array<std::byte, 80> buf{};
  buf[0] = static_cast<std::byte>(kind);
  std::size_t at = 1;
  ((std::memcpy(buf.data() + at, &parts, sizeof(parts)), at += sizeof(parts)), ...);
  if (!to.send(std::span<const std::byte>(buf.data(), at))) std::_Exit(4);
}

// Moves `fd` to the channel's number, as the live service had it.
void take_channel(UniqueFd fd) {
  if (::dup3(fd.get(), kChannelFd, O_CLOEXEC) != kChannelFd) std::_Exit(5);
}

// A frozen fork image: waits for 'g', then returns to be the service.
void frozen(SeqPacket resume) {
  Message m;
  if (!receive(resume, m) || m.kind != 'g' || !m.fd.valid()) std::_Exit(0);
  take_channel(std::move(m.fd));
  resume.close();
  answer(*channel, 'r', counter);
}

// Zygote and holders, on the standby stack.
void standby(int fd) {
  SeqPacket sock{UniqueFd(fd)};
  for (;;) {
    Message m;
    if (!receive(sock, m)) std::_Exit(0);
    if (m.kind == 'f' && m.fd.valid()) {
      auto pid = rejuv::sys::fork_sibling();
      if (pid && *pid == 0) {  // the holder: serves the new socket
        sock = SeqPacket(std::move(m.fd));
        continue;
      }
      answer(sock, 'p', static_cast<std::int32_t>(pid ? *pid : 0));
    } else if (m.kind == 'l' && m.fd.valid() && m.body_size == sizeof(Layout)) {
      Layout layout;
      std::memcpy(&layout, m.body.data(), sizeof(layout));
      if (!rejuv::bench_image::load_self(layout, m.fd.get())) std::_Exit(6);
      m.fd.reset();
      answer(sock, 'k');
    } else if (m.kind == 'g' && m.fd.valid()) {
      sock.close();  // first: it may hold fd 3 (the zygote closed the service's channel)
      take_channel(std::move(m.fd));
      rejuv::bench_image::resume_saved(saved);
    } else {
      std::_Exit(7);
    }
  }
}

[[noreturn]] void serve() {
  for (;;) {
    Message m;
    if (!receive(*channel, m)) std::_Exit(0);
    switch (m.kind) {
      case 't':
        ++counter;
        for (std::size_t i = 0; i < work->size(); i += 512) (*work)[i] += counter;
        answer(*channel, 'a', counter);
        break;
      case 'f': {
        auto pid = rejuv::sys::fork_sibling();
        if (pid && *pid == 0) {
          frozen(SeqPacket(std::move(m.fd)));
          break;
        }
        answer(*channel, 'p', static_cast<std::int32_t>(pid ? *pid : 0));
        break;
      }
      case 'z': {
        auto pid = rejuv::sys::fork_sibling();
        if (pid && *pid == 0) {
          ::close(kChannelFd);
          rejuv::bench_image::run_on_standby_stack(standby, m.fd.release());
        }
        answer(*channel, 'p', static_cast<std::int32_t>(pid ? *pid : 0));
        break;
      }
      case 's': {
        if (REJUV_IMAGE_SAVE(saved) != 0) {
          // A holder, resumed: this frame is the image's; the new channel is at fd 3 like the old one was.
          (void)m.fd.release();  // the image's number for its done socket, nothing of this process
          answer(*channel, 'r', counter);
          break;
        }
        answer(*channel, 'l', rejuv::bench_image::layout_at(rejuv::bench_image::stack_pointer()),
               static_cast<std::int32_t>(::getpid()));
        std::array<std::byte, 1> wait{};
        (void)SeqPacket(std::move(m.fd)).receive(wait);  // the bench closes it once it has copied
        break;
      }
      default:
        std::_Exit(7);
    }
  }
}

}  // namespace

int main() {
  if (!rejuv::bench_image::prepare_self()) return 2;
  work = new std::vector<std::uint64_t>(kWorkWords, 1);
  channel = new SeqPacket(UniqueFd(kChannelFd));
  serve();
}
