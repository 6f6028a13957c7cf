// The background load (background_load.hpp).
#include "background_load.hpp"

#include <signal.h>
#include <sys/prctl.h>

#include <cstdint>
#include <cstring>
#include <algorithm>
#include <memory>
#include <vector>

#include "args.hpp"

namespace rejuv::cli {

namespace {

// A worker's life: every signal unblocked (the command blocks SIGINT and SIGTERM for its signalfd, and a
// fork inherits the mask: a Ctrl-C to the terminal's process group, or the SIGTERM of PR_SET_PDEATHSIG, must end
// it), then for ever: one frame of the working set written, the previous one read and summed, a slice copied,
// a buffer of a few hundred kB freed and allocated again.
[[noreturn]] void work(std::size_t working_set_mib) {
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  ::signal(SIGINT, SIG_DFL);
  ::signal(SIGTERM, SIG_DFL);
  ::prctl(PR_SET_NAME, "rejuv-load", 0, 0, 0);
  constexpr std::size_t kFrame = 4U << 20U;  // 4 MiB "frames"
  const std::size_t frames = std::max<std::size_t>(2, (working_set_mib << 20U) / kFrame);
  std::vector<std::unique_ptr<std::uint8_t[]>> set;
  for (std::size_t i = 0; i < frames; ++i) set.push_back(std::make_unique<std::uint8_t[]>(kFrame));
  std::uint64_t x = 0x9E3779B97F4A7C15ULL, sum = 0;
  for (std::size_t n = 0;; ++n) {
    std::uint8_t* frame = set[n % frames].get();
    const std::uint8_t* prev = set[(n + frames - 1) % frames].get();
    for (std::size_t i = 0; i < kFrame; i += 8) {  // write: a pseudo-random image
      x ^= x << 13U;
      x ^= x >> 7U;
      x ^= x << 17U;
      std::memcpy(frame + i, &x, 8);
    }
    for (std::size_t i = 0; i < kFrame; i += 64) sum += prev[i] * (i | 1U);  // read the last one back
    std::memcpy(set[(n + 2) % frames].get(), frame, kFrame / 4);             // copy a slice
    auto scratch = std::make_unique<std::uint8_t[]>(256U << 10U);            // allocator churn
    scratch[sum % (256U << 10U)] = static_cast<std::uint8_t>(sum);
    asm volatile("" : : "r"(scratch.get()), "r"(sum) : "memory");           // nothing optimised away
  }
}

}  // namespace

std::string LoadSpec::to_string() const { return "cpu:" + std::to_string(cpu_workers); }

Result<LoadSpec, std::string> parse_load(std::string_view text) {
  constexpr std::string_view kCpu = "cpu:";
  if (text.substr(0, kCpu.size()) != kCpu) {
    return fail("--load: expected cpu:N (N worker processes of a companion-like CPU and memory load), got '" +
                std::string(text) + "'");
  }
  const auto n = to_u64(text.substr(kCpu.size()), "--load");
  if (!n) return fail(n.error());
  if (*n < 1 || *n > 64) return fail("--load: cpu:N takes N from 1 to 64, got " + std::to_string(*n));
  return LoadSpec{.cpu_workers = static_cast<unsigned>(*n)};
}

Result<BackgroundLoad, std::string> BackgroundLoad::start(const LoadSpec& spec) {
  std::vector<sys::ChildProcess> workers;
  for (unsigned i = 0; i < spec.cpu_workers; ++i) {
    auto w = sys::fork_worker([mib = spec.working_set_mib]() -> int { work(mib); });
    if (!w) return fail("--load: cannot start a worker: " + w.error().to_string());  // `workers` killed and reaped
    workers.push_back(std::move(*w));
  }
  return BackgroundLoad(std::move(workers));
}

std::vector<pid_t> BackgroundLoad::pids() const {
  std::vector<pid_t> out;
  for (const sys::ChildProcess& w : workers_) out.push_back(w.pid());
  return out;
}

std::size_t BackgroundLoad::ended() {
  std::size_t n = 0;
  for (sys::ChildProcess& w : workers_) {
    if (!w.running()) {
      ++n;
      continue;
    }
    if (auto s = w.try_wait(); s && s->has_value()) ++n;
  }
  return n;
}

void BackgroundLoad::stop() noexcept {
  for (sys::ChildProcess& w : workers_) w.kill_and_reap();
  workers_.clear();
}

}  // namespace rejuv::cli
