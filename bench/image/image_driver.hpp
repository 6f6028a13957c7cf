// Drives image_service processes through checkpoints and rollbacks, both ways (bench/image and
// its smoke test): by fork, as the runtime images its services today, and by copy into
// holders forked from a zygote (rejuv/sdk/memory_image.hpp). The driver plays the kernel's part.
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "image_messages.hpp"
#include "rejuv/sdk/memory_image.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::bench_image {
using namespace memory_image;  // NOLINT(google-build-using-namespace): the bench is built on it

using sys::ChildProcess;
using sys::SeqPacket;
using sys::UniqueFd;

class ImageDriver {
 public:
  // Everything the driver does either succeeds or ends the program with what failed (a bench and a test
  // fixture: there is nothing to recover).
  static void require(bool ok, const std::string& what) {
    if (!ok) {
      std::fprintf(stderr, "image driver: %s\n", what.c_str());
      std::exit(2);
    }
  }

  // `pages_per_tick` 0: the service's default (it writes its whole work area, ≈ 60 pages).
  ImageDriver(const std::string& executable, int services, int pages_per_tick = 0) {
    for (int i = 0; i < services; ++i) {
      auto pair = SeqPacket::pair();
      require(pair.has_value(), "socketpair");
      std::vector<std::string> args;
      if (pages_per_tick > 0) args.push_back(std::to_string(pages_per_tick));
      sys::SpawnSpec spec{.executable = executable, .args = args, .env = {}, .fds = {{3, pair->second.fd()}},
                          .seccomp = nullptr, .uid = {}, .session = sys::Session::OwnProcessGroup,
                          .isolation = sys::Isolation::None, .limits = {}};
      auto child = sys::spawn(spec);
      require(child.has_value(), "spawn " + executable);
      Unit u;
      u.live = std::move(*child);
      u.channel = std::move(pair->first);
      const int memfd = ::memfd_create("rejuv-image", MFD_CLOEXEC);
      require(memfd >= 0 && ::ftruncate(memfd, kImageBytes) == 0, "memfd");
      u.image = UniqueFd(memfd);
      void* map = ::mmap(nullptr, kImageBytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_POPULATE, memfd, 0);
      require(map != MAP_FAILED, "mmap image");
      u.bytes = std::span(static_cast<std::byte*>(map), kImageBytes);
      const int deltafd = ::memfd_create("rejuv-written-pages", MFD_CLOEXEC);
      require(deltafd >= 0 && ::ftruncate(deltafd, kMaxWrittenBytes) == 0, "memfd");
      u.delta = UniqueFd(deltafd);
      void* dmap = ::mmap(nullptr, kMaxWrittenBytes, PROT_READ, MAP_SHARED, deltafd, 0);
      require(dmap != MAP_FAILED, "mmap written pages");
      u.delta_bytes = std::span(static_cast<const std::byte*>(dmap), kMaxWrittenBytes);
      units_.push_back(std::move(u));
    }
  }
  ImageDriver(const ImageDriver&) = delete;
  ImageDriver& operator=(const ImageDriver&) = delete;
  ~ImageDriver() {
    for (Unit& u : units_) {
      ::munmap(u.bytes.data(), u.bytes.size());
      ::munmap(const_cast<std::byte*>(u.delta_bytes.data()), u.delta_bytes.size());  // NOLINT(cppcoreguidelines-pro-type-const-cast)
    }
  }

  [[nodiscard]] std::size_t size() const { return units_.size(); }
  [[nodiscard]] std::uint64_t counter(std::size_t i) const { return units_[i].counter; }
  [[nodiscard]] std::uint64_t saved_counter(std::size_t i) const { return units_[i].saved_counter; }
  [[nodiscard]] const Layout& layout(std::size_t i) const { return units_[i].layout; }
  [[nodiscard]] pid_t live_pid(std::size_t i) const { return units_[i].live.pid(); }
  [[nodiscard]] pid_t holder_pid(std::size_t i) const { return units_[i].holder.pid(); }
  [[nodiscard]] pid_t zygote_pid(std::size_t i) const { return units_[i].zygote.pid(); }

  void tick() {
    for (Unit& u : units_) require(send_message(u.channel, 't', -1), "send 't'");
    for (Unit& u : units_) {
      const Message a = expect(u.channel, 'a');
      u.counter = a.at<std::uint64_t>(0);
    }
  }

  // ---- by fork ----
  void checkpoint_by_fork() {
    for (Unit& u : units_) u.fork_resume = send_socket(u.channel, 'f');
    for (Unit& u : units_) {
      u.fork_image = adopt(expect(u.channel, 'p'));
      u.saved_counter = u.counter;
    }
  }
  void rollback_by_fork() { rollback_to(&Unit::fork_image, &Unit::fork_resume); }

  // ---- by copy ----
  void start_zygotes() {
    for (Unit& u : units_) {
      u.zygote_sock = send_socket(u.channel, 'z');
      u.zygote = adopt(expect(u.channel, 'p'));
    }
  }
  // Off the critical path: a holder per service, forked by its zygote.
  void make_holders() {
    for (Unit& u : units_) {
      u.holder_sock = send_socket(u.zygote_sock, 'f');
      u.holder = adopt(expect(u.zygote_sock, 'p'));
    }
  }
  void checkpoint_by_copy() {
    std::vector<SeqPacket> done;
    done.reserve(units_.size());
    for (Unit& u : units_) done.push_back(send_socket(u.channel, 's'));
    for (std::size_t i = 0; i < units_.size(); ++i) {
      Unit& u = units_[i];
      const Message a = expect(u.channel, 'l');
      u.layout = a.at<Layout>(0);
      const auto pid = a.at<std::int32_t>(sizeof(Layout));
      require(pid == u.live.pid(), "the layout of another process");
      const auto t0 = std::chrono::steady_clock::now();
      auto read = read_process(pid, u.layout, u.bytes);
      read_us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
      require(read.has_value(), read ? "" : read.error().to_string());
      done[i].close();  // the service goes on
      u.saved_counter = u.counter;
    }
  }
  // Off the critical path: each holder reads the newest image.
  void load_holders() {
    for (Unit& u : units_) {
      require(send_message(u.holder_sock, 'l', u.image.get(), u.layout), "send 'l'");
      (void)expect(u.holder_sock, 'k');
    }
  }
  void rollback_by_copy() { rollback_to(&Unit::holder, &Unit::holder_sock); }

  // ---- by written pages ----
  // Every service starts tracking its writes; "" when all do, else why not (the kernel lacks async
  // userfaultfd write-protection or PAGEMAP_SCAN). The next checkpoint_by_copy() is the base image.
  [[nodiscard]] std::string start_tracking() {
    for (Unit& u : units_) require(send_message(u.channel, 'w', -1), "send 'w'");
    std::string why;
    for (Unit& u : units_) {
      const int error = expect(u.channel, 'w').at<std::int32_t>(0);
      if (error != 0 && why.empty()) why = std::strerror(error);
    }
    return why;
  }
  // Each service copies the pages it wrote since the previous image into its memfd and goes on; the driver
  // patches them into its copy of the image (the same buffer load_holders() hands to the holders).
  void checkpoint_by_written() {
    for (Unit& u : units_) require(send_message(u.channel, 'd', u.delta.get()), "send 'd'");
    for (Unit& u : units_) {
      const Message a = expect(u.channel, 'D');
      const auto pages = a.at<std::uint32_t>(0);
      require(a.at<Layout>(sizeof(std::uint32_t)) == u.layout, "the layout changed since the base image");
      require(pages <= kMaxWrittenPages, "more written pages than records");
      for (std::uint32_t i = 0; i < pages; ++i) {
        std::uint64_t address = 0;
        std::memcpy(&address, u.delta_bytes.data() + i * sizeof(std::uint64_t), sizeof(address));
        const std::optional<std::size_t> at = offset_in_image(u.layout, address);
        require(at.has_value(), "a written page outside the image");
        std::memcpy(u.bytes.data() + *at, u.delta_bytes.data() + kWrittenPagesAt + std::size_t{i} * kPageBytes,
                    kPageBytes);
      }
      written_pages.push_back(pages);
      u.saved_counter = u.counter;
    }
  }
  std::vector<double> written_pages;  // per service and checkpoint_by_written

  std::vector<double> read_us;  // each read_process of checkpoint_by_copy
  // The killed incarnations, reaped off the measured paths.
  void reap() {
    for (ChildProcess& p : dying_) p.kill_and_reap();
    dying_.clear();
  }

 private:
  static constexpr std::size_t kImageBytes = std::size_t{8} << 20;

  struct Unit {
    ChildProcess live;
    SeqPacket channel;
    std::uint64_t counter = 0;
    std::uint64_t saved_counter = 0;
    ChildProcess fork_image;
    SeqPacket fork_resume;
    ChildProcess zygote;
    SeqPacket zygote_sock;
    ChildProcess holder;
    SeqPacket holder_sock;
    Layout layout{};
    UniqueFd image;
    std::span<std::byte> bytes;
    UniqueFd delta;  // the pages a service wrote since its previous image (checkpoint_by_written)
    std::span<const std::byte> delta_bytes;
  };

  static Message expect(const SeqPacket& from, char kind) {
    Message m;
    require(receive_message(from, m) && m.kind == kind, std::string("no '") + kind + "' answer");
    return m;
  }
  static ChildProcess adopt(const Message& a) {
    auto child = ChildProcess::adopt_child(a.at<std::int32_t>(0));
    require(child.has_value(), "adopt the new process");
    return std::move(*child);
  }
  // Sends `kind` with one end of a new socket pair on `to` (a resume socket, a done socket, a new channel);
  // returns the driver's end.
  static SeqPacket send_socket(const SeqPacket& to, char kind) {
    auto pair = SeqPacket::pair();
    require(pair.has_value(), "socketpair");
    require(send_message(to, kind, pair->second.fd()), std::string("send '") + kind + "'");
    return std::move(pair->first);
  }
  // Kills the live services, resumes each `image` (a fork image or a loaded holder) through its `socket`
  // with a new channel, and waits for every one to answer with its counter.
  void rollback_to(ChildProcess Unit::*image, SeqPacket Unit::*socket) {
    retire_live();
    for (Unit& u : units_) u.channel = send_socket(u.*socket, 'g');
    for (Unit& u : units_) {
      u.counter = expect(u.channel, 'r').at<std::uint64_t>(0);
      u.live = std::move(u.*image);
      (u.*socket).close();
    }
  }
  void retire(ChildProcess& p) {  // as the kernel kills: at the victim's own priority (finish_retiring)
    (void)p.signal(SIGKILL);
    dying_.push_back(std::move(p));
  }
  void retire_live() {
    for (Unit& u : units_) retire(u.live);
  }

  std::vector<Unit> units_;
  std::vector<ChildProcess> dying_;
};

}  // namespace rejuv::bench_image
