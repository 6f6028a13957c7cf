// Fork images vs copy images, side by side in one run (DESIGN §11): 8 service-sized processes (the
// rejuvenated part of quad_square) checkpointed and rolled back `cycles` times each way, pinned to one CPU
// like a lockstep run. Every rollback is checked: each service answers with the counter it had at the
// checkpoint. Prints p50 / max of both and the ratios; the paper's module took ≈20 ms / ≈15 ms.
//
//   image_bench [--services N] [--cycles N] [--only fork|copy]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "image_driver.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

struct Stat {
  std::vector<double> ms;
  [[nodiscard]] double p50() const {
    std::vector<double> s = ms;
    std::sort(s.begin(), s.end());
    return s.empty() ? 0.0 : s[s.size() / 2];
  }
  [[nodiscard]] double max() const { return ms.empty() ? 0.0 : *std::max_element(ms.begin(), ms.end()); }
};

template <typename F>
void timed(Stat& s, F&& f) {
  const auto t0 = Clock::now();
  f();
  s.ms.push_back(ms_since(t0));
}

void verify(const rejuv::bench_image::ImageDriver& d, const char* how) {
  for (std::size_t i = 0; i < d.size(); ++i) {
    rejuv::bench_image::ImageDriver::require(d.counter(i) == d.saved_counter(i),
                                           std::string(how) + ": a service came back with another counter");
  }
}

void progress(const char* how, int c, int cycles) {
  if ((c + 1) % 50 == 0 || c + 1 == cycles) std::fprintf(stderr, "  %s: %d/%d cycles\n", how, c + 1, cycles);
}

int parse(const char* v, const char* flag) {
  char* end = nullptr;
  const long n = std::strtol(v, &end, 10);
  if (end == v || *end != '\0' || n < 1 || n > 100000) {
    std::fprintf(stderr, "image_bench: %s wants a whole number from 1 to 100000, not '%s'\n", flag, v);
    std::exit(2);
  }
  return static_cast<int>(n);
}

}  // namespace

int main(int argc, char** argv) {
  int services = 8;
  int cycles = 200;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--services" || a == "--cycles") && i + 1 < argc) {
      (a == "--services" ? services : cycles) = parse(argv[++i], a.c_str());
    } else if (a == "--only" && i + 1 < argc && (std::string(argv[i + 1]) == "fork" || std::string(argv[i + 1]) == "copy")) {
      only = argv[++i];
    } else {
      std::fprintf(stderr, "usage: image_bench [--services N] [--cycles N] [--only fork|copy]\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (auto cpu = rejuv::sys::pin_to_one_cpu(std::nullopt); !cpu) {
    std::fprintf(stderr, "image_bench: %s\n", cpu.error().to_string().c_str());
    return 2;
  }
  rejuv::bench_image::ImageDriver d(REJUV_IMAGE_SERVICE, services);
  for (int i = 0; i < 20; ++i) d.tick();
  d.start_zygotes();
  d.make_holders();
  Stat fork_cp;
  Stat fork_rb;
  Stat copy_cp;
  Stat copy_rb;
  std::printf("image_bench: %d services, %d cycles each way, one CPU\n", services, cycles);
  // One way after the other, so that neither inherits the other's page state.
  for (int c = 0; c < cycles && only != "copy"; ++c) {
    // By fork: the image is forked at the checkpoint and resumed at the rollback.
    timed(fork_cp, [&] { d.checkpoint_by_fork(); });
    for (int i = 0; i < 3; ++i) d.tick();
    timed(fork_rb, [&] { d.rollback_by_fork(); });
    verify(d, "by fork");
    d.reap();
    d.tick();
    progress("by fork", c, cycles);
  }
  for (int c = 0; c < cycles && only != "fork"; ++c) {
    // By copy: the image is read at the checkpoint, loaded into a holder off the critical path and resumed
    // at the rollback; a new holder is forked by the zygote off the critical path.
    timed(copy_cp, [&] { d.checkpoint_by_copy(); });
    d.load_holders();
    for (int i = 0; i < 3; ++i) d.tick();
    timed(copy_rb, [&] { d.rollback_by_copy(); });
    verify(d, "by copy");
    d.reap();
    d.make_holders();
    d.tick();
    progress("by copy", c, cycles);
  }
  const Stat read{d.read_us};
  std::printf("image by copy: %zu KB (service 0), read_process p50 %.0f us, max %.0f us\n",
              d.layout(0).bytes() / 1024, read.p50(), read.max());
  std::printf("                   p50 [ms]   max [ms]\n");
  std::printf("checkpoint, fork   %8.3f   %8.3f\n", fork_cp.p50(), fork_cp.max());
  std::printf("checkpoint, copy   %8.3f   %8.3f\n", copy_cp.p50(), copy_cp.max());
  std::printf("rollback,   fork   %8.3f   %8.3f\n", fork_rb.p50(), fork_rb.max());
  std::printf("rollback,   copy   %8.3f   %8.3f\n", copy_rb.p50(), copy_rb.max());
  if (only.empty()) {
    std::printf("ratio copy / fork (p50; < 1: copy faster): checkpoint %.2f, rollback %.2f\n",
                copy_cp.p50() / fork_cp.p50(), copy_rb.p50() / fork_rb.p50());
  }
  return 0;
}
