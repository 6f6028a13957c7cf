// The kernel clock (docs/design.md §6; the paper's §IV-B: time must not go back with a rollback): the one writer of
// the time page from which every service reads now(), the SR mode and the rollback epoch
// (rejuv/clock/time_page.hpp). The page changes on three events, each written here and nowhere else:
//   advance      time moves on (a lockstep step's t, the realtime clock, the realtime clock's sync);
//   show_mode    the capability system's mode changed (a mode switch, a rollback's RB, a cold restart's SC);
//   begin_epoch  a rollback or a cold restart has put new incarnations in place.
// The mode itself is owned by the capability system (cap::CapSystem::apply_mode); the page mirrors it.
#pragma once

#include "rejuv/clock/time_page.hpp"

namespace rejuv::kernel {

class KernelClock {
 public:
  // The page at t = 0, epoch 0, in `mode`.
  KernelClock(clock::TimePageWriter page, SrMode mode) : page_(std::move(page)) {
    page_.write(clock::TimeSample{.now = Nanos{0}, .mode = mode, .epoch = Epoch{0}});
  }

  [[nodiscard]] Nanos now() const { return page_.current().now; }
  [[nodiscard]] SrMode mode() const { return page_.current().mode; }
  [[nodiscard]] Epoch epoch() const { return page_.current().epoch; }
  // The epoch the incarnations a rollback resumes are told (their Resume) before it begins.
  [[nodiscard]] Epoch next_epoch() const { return Epoch{epoch().value() + 1}; }

  void advance(Nanos t) { page_.set_now(t); }
  void show_mode(SrMode mode) { page_.write(clock::TimeSample{.now = now(), .mode = mode, .epoch = epoch()}); }
  // Epochs are counted one by one (a service compares them for equality): the new one is next_epoch().
  void begin_epoch() { page_.write(clock::TimeSample{.now = now(), .mode = mode(), .epoch = next_epoch()}); }

  // The read-only fd every service gets at wire::kTimePageFd.
  [[nodiscard]] const sys::UniqueFd& read_only_fd() const { return page_.read_only_fd(); }

 private:
  clock::TimePageWriter page_;
};

}  // namespace rejuv::kernel
