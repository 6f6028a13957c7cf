// Socket pairs made ahead (the kernel's end non-blocking), so that no socketpair() is on the critical path of
// a checkpoint (resume sockets) or a rollback (channels), and the service ends those passed on, closed after
// it. Refilled at safe points off the critical paths (rejuvenator.cpp, service_images). One owner: the image
// coordinator.
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/fd.hpp"

namespace rejuv::kernel {

class ChannelPool {
 public:
  using Pair = std::pair<sys::SeqPacket, sys::SeqPacket>;
  // One made ahead, or one made now; out of fds or memory (EMFILE, ENFILE, ENOMEM) as a value.
  [[nodiscard]] sys::SysResult<Pair> take() {
    if (!pairs_.empty()) {
      Pair pair = std::move(pairs_.back());
      pairs_.pop_back();
      return pair;
    }
    return make();
  }
  // An fd to close once the timed part is over.
  void close_later(sys::UniqueFd fd) { closing_.push_back(std::move(fd)); }
  // Off the critical paths: closes what waits to be closed and makes pairs up to `want`. A shortage is
  // returned once per shortage (for the log).
  [[nodiscard]] std::optional<sys::SysError> refill(std::size_t want) {
    closing_.clear();
    while (pairs_.size() < want) {
      auto pair = make();
      if (!pair) {
        if (short_) return std::nullopt;
        short_ = true;
        return pair.error();
      }
      short_ = false;
      pairs_.push_back(std::move(*pair));
    }
    return std::nullopt;
  }

 private:
  static sys::SysResult<Pair> make() {
    auto pair = sys::SeqPacket::pair(sys::Blocking::Yes);
    if (!pair) return fail(pair.error());
    if (auto ok = sys::set_nonblocking(pair->first.fd(), true); !ok) return fail(ok.error());
    return std::move(*pair);
  }
  std::vector<Pair> pairs_;
  std::vector<sys::UniqueFd> closing_;
  bool short_ = false;  // a shortage was reported and no pair made since
};

}  // namespace rejuv::kernel
