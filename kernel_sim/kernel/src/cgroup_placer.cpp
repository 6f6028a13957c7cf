#include "cgroup_placer.hpp"

namespace rejuv::kernel {

CgroupPlacer::~CgroupPlacer() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

bool CgroupPlacer::place(const sys::ServiceCgroup& group, pid_t pid, sys::CgroupLeaf leaf) {
  if (!group.valid() || pid <= 0) return true;
  auto move = group.prepare_move(pid, leaf);
  if (!move) return false;
  {
    const std::lock_guard lock(mutex_);
    queue_.push_back(std::move(*move));
    if (!worker_.joinable()) worker_ = std::thread([this] { run(); });
  }
  wake_.notify_one();
  return true;
}

bool CgroupPlacer::idle() const {
  const std::lock_guard lock(mutex_);
  return queue_.empty() && running_ == 0;
}

std::uint64_t CgroupPlacer::failed() const {
  const std::lock_guard lock(mutex_);
  return failed_;
}

void CgroupPlacer::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    const sys::CgroupMove move = std::move(queue_.front());
    queue_.pop_front();
    ++running_;
    lock.unlock();
    const bool ok = move.run().has_value();
    lock.lock();
    --running_;
    failed_ += ok ? 0 : 1;
  }
}

}  // namespace rejuv::kernel
