// A service's registered worker threads (docs/design.md §7 "Threads"): parked before the fork that takes an image,
// resumed in the live process, re-spawned exactly once from their entry function in a restored image.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "rejuv/sdk/service.hpp"

namespace rejuv::sdk {

class WorkerSet {
 public:
  using Body = std::function<void(WorkerContext&)>;

  explicit WorkerSet(std::uint32_t incarnation) : incarnation_(incarnation) { workers_.reserve(Service::kMaxWorkers); }
  WorkerSet(const WorkerSet&) = delete;
  WorkerSet& operator=(const WorkerSet&) = delete;
  ~WorkerSet() { stop_and_join(); }

  [[nodiscard]] std::size_t size() const { return workers_.size(); }
  // 0, or the errno of a thread that could not be created (the worker is then not kept).
  [[nodiscard]] int spawn(Body body);

  // Asks every worker to park and waits until all are (or `deadline` passes: then they are released again
  // and the result is false: the service cannot be forked safely).
  [[nodiscard]] bool park_all(std::chrono::milliseconds deadline);
  void unpark_all();
  void stop_and_join();

  // In a restored image, whose memory holds `old` but none of its threads: a new set running every body
  // again. `old` is leaked on purpose (destroying a std::thread that seems to run terminates the process);
  // each resume starts from the frozen image, so the leak never grows. nullptr if a thread could not be
  // created (then the process must not go on).
  [[nodiscard]] static WorkerSet* respawn_in_image(WorkerSet* old);

  // WorkerContext::park_point.
  bool park_point();

 private:
  struct Worker {
    Body body;
    std::thread* thread = nullptr;  // raw: see respawn_in_image
  };
  int start(Worker& w);  // 0 or errno

  std::uint32_t incarnation_ = 0;
  std::vector<Worker> workers_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool park_requested_ = false;
  bool stopping_ = false;
  std::size_t parked_ = 0;
  std::size_t running_ = 0;
};

}  // namespace rejuv::sdk
