// Moves between a service's cgroup leaves (docs/sandbox.md "A cgroup per service"), on a thread of its own:
// each new image into `images/` once the kernel knows its pid, each restored incarnation into `live/`. A move
// (a write to cgroup.procs) takes the kernel's cgroup threadgroup lock for writing, which waits for an RCU
// grace period when no move happened for a while — milliseconds, measured in docs/sandbox.md — and on the
// kernel's loop that would be an actuator gap. Moves run in the order asked (an image moved out and then
// restored ends in `live/`). One owner: the warden.
#pragma once

#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

#include "rejuv/sys/cgroup.hpp"

namespace rejuv::kernel {

class CgroupPlacer {
 public:
  CgroupPlacer() = default;
  CgroupPlacer(const CgroupPlacer&) = delete;
  CgroupPlacer& operator=(const CgroupPlacer&) = delete;
  ~CgroupPlacer();

  // Queued (the thread starts at the first); nothing where the group has no leaves (no cgroup). False if the
  // move could not be prepared (out of fds).
  bool place(const sys::ServiceCgroup& group, pid_t pid, sys::CgroupLeaf leaf);
  [[nodiscard]] bool idle() const;  // no move queued or running
  [[nodiscard]] std::uint64_t failed() const;  // moves refused (a process gone meanwhile: ESRCH)

 private:
  void run();

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<sys::CgroupMove> queue_;
  std::size_t running_ = 0;
  std::uint64_t failed_ = 0;
  bool stopping_ = false;
  std::thread worker_;  // last: started after the rest exists, joined first
};

}  // namespace rejuv::kernel
