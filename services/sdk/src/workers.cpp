#include "workers.hpp"

#include <sys/prctl.h>

#include <cerrno>
#include <system_error>

namespace rejuv::sdk {

bool WorkerContext::park_point() { return set_->park_point(); }

int WorkerSet::spawn(Body body) {
  workers_.push_back(Worker{.body = std::move(body), .thread = nullptr});
  const int e = start(workers_.back());
  if (e != 0) workers_.pop_back();
  return e;
}

int WorkerSet::start(Worker& w) {
  {
    const std::lock_guard lock(mutex_);
    ++running_;
  }
  try {
    w.thread = new std::thread([this, body = &w.body] {  // NOLINT(cppcoreguidelines-owning-memory): see header
      // Named, so that ps, top and the tests tell a worker from the process's other threads (a sanitizer's).
      (void)::prctl(PR_SET_NAME, Service::kWorkerThreadName, 0, 0, 0);
      WorkerContext ctx(this, incarnation_);
      (*body)(ctx);
      const std::lock_guard lock(mutex_);
      --running_;
      cv_.notify_all();
    });
  } catch (const std::system_error& e) {  // EAGAIN: the uid's max_processes counts threads too
    const std::lock_guard lock(mutex_);
    --running_;
    return e.code().value() != 0 ? e.code().value() : EAGAIN;
  }
  return 0;
}

bool WorkerSet::park_point() {
  std::unique_lock lock(mutex_);
  while (park_requested_ && !stopping_) {
    ++parked_;
    cv_.notify_all();
    cv_.wait(lock, [&] { return !park_requested_ || stopping_; });
    --parked_;
  }
  return !stopping_;
}

bool WorkerSet::park_all(std::chrono::milliseconds deadline) {
  std::unique_lock lock(mutex_);
  park_requested_ = true;
  if (cv_.wait_for(lock, deadline, [&] { return parked_ == running_; })) return true;
  park_requested_ = false;
  cv_.notify_all();
  return false;
}

void WorkerSet::unpark_all() {
  const std::lock_guard lock(mutex_);
  park_requested_ = false;
  cv_.notify_all();
}

void WorkerSet::stop_and_join() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
    cv_.notify_all();
  }
  for (Worker& w : workers_) {
    if (w.thread != nullptr && w.thread->joinable()) w.thread->join();
    delete w.thread;  // NOLINT(cppcoreguidelines-owning-memory)
    w.thread = nullptr;
  }
}

WorkerSet* WorkerSet::respawn_in_image(WorkerSet* old) {
  auto* fresh = new WorkerSet(old->incarnation_ + 1);  // NOLINT(cppcoreguidelines-owning-memory)
  fresh->workers_.reserve(old->workers_.size());
  for (const Worker& w : old->workers_) {
    fresh->workers_.push_back(Worker{.body = w.body, .thread = nullptr});
  }
  for (Worker& w : fresh->workers_) {
    if (fresh->start(w) != 0) return nullptr;  // the caller ends the process: nothing to clean up
  }
  return fresh;
}

}  // namespace rejuv::sdk
