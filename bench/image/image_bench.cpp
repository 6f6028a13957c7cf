// Fork images vs copy images vs images by written pages, side by side in one run (docs/design.md §11): 8
// service-sized processes (the rejuvenated part of quad_square) checkpointed and rolled back `cycles` times
// each way, pinned to one CPU like a lockstep run. Every rollback is checked: each service answers with the
// counter it had at the checkpoint. Prints p50 / max of each and the ratios; the paper's module took ≈20 ms /
// ≈15 ms.
//
//   image_bench [--services N] [--cycles N] [--pages-per-tick N] [--only fork|copy|written]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <optional>
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

// Cycles of one way that images into holders: `checkpoint`, the holders loaded off the critical path, three
// ticks, the rollback into the holders (checked), a new holder per service forked off the critical path.
template <typename Checkpoint>
void holder_cycles(rejuv::bench_image::ImageDriver& d, int cycles, const char* how, Stat& cp, Stat& rb,
                   Checkpoint checkpoint) {
  for (int c = 0; c < cycles; ++c) {
    timed(cp, checkpoint);
    d.load_holders();
    for (int i = 0; i < 3; ++i) d.tick();
    timed(rb, [&] { d.rollback_by_copy(); });
    verify(d, how);
    d.reap();
    d.make_holders();
    d.tick();
    progress(how, c, cycles);
  }
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

// Which ways of imaging to measure (--only).
enum class Ways : std::uint8_t { All, Fork, Copy, Written };

struct BenchRequest {
  int services = 8;
  int cycles = 200;
  int pages_per_tick = 0;  // the service's default: its whole work area
  Ways ways = Ways::All;
  [[nodiscard]] bool runs(Ways w) const { return ways == Ways::All || ways == w; }
};

// The command line; an exit code (0 for --help, 2 for anything else not understood) after the usage line.
std::optional<int> parse_args(int argc, char** argv, BenchRequest& r) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const std::string next = i + 1 < argc ? argv[i + 1] : "";
    if ((a == "--services" || a == "--cycles" || a == "--pages-per-tick") && i + 1 < argc) {
      (a == "--services" ? r.services : a == "--cycles" ? r.cycles : r.pages_per_tick) = parse(argv[++i], a.c_str());
    } else if (a == "--only" && (next == "fork" || next == "copy" || next == "written")) {
      r.ways = next == "fork" ? Ways::Fork : next == "copy" ? Ways::Copy : Ways::Written;
      ++i;
    } else {
      std::fprintf(stderr, "usage: image_bench [--services N] [--cycles N] [--pages-per-tick N] [--only fork|copy|written]\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  return std::nullopt;
}

struct Timings {
  Stat fork_cp, fork_rb, copy_cp, copy_rb, written_cp, written_rb;
  std::string untracked;  // why the written pages could not be tracked ("" when they could)
};

// By fork: the image is forked at the checkpoint and resumed at the rollback.
void fork_cycles(rejuv::bench_image::ImageDriver& d, int cycles, Stat& cp, Stat& rb) {
  for (int c = 0; c < cycles; ++c) {
    timed(cp, [&] { d.checkpoint_by_fork(); });
    for (int i = 0; i < 3; ++i) d.tick();
    timed(rb, [&] { d.rollback_by_fork(); });
    verify(d, "by fork");
    d.reap();
    d.tick();
    progress("by fork", c, cycles);
  }
}

// One way after the other, so that neither inherits the other's page state.
Timings measure(rejuv::bench_image::ImageDriver& d, const BenchRequest& r) {
  Timings t;
  if (r.runs(Ways::Fork)) fork_cycles(d, r.cycles, t.fork_cp, t.fork_rb);
  // By copy: the image is read at the checkpoint, loaded into a holder off the critical path and resumed
  // at the rollback; a new holder is forked by the zygote off the critical path.
  if (r.runs(Ways::Copy)) holder_cycles(d, r.cycles, "by copy", t.copy_cp, t.copy_rb, [&] { d.checkpoint_by_copy(); });
  // By written pages: after a full base image, each checkpoint copies only the pages written since the
  // previous one (the service copies them itself and goes on), loaded into a holder off the critical path
  // like an image by copy; the rollback is the same as by copy.
  if (r.runs(Ways::Written)) t.untracked = d.start_tracking();
  if (r.runs(Ways::Written) && t.untracked.empty()) {
    d.checkpoint_by_copy();  // the base image (the services re-arm their tracking)
    holder_cycles(d, r.cycles, "by written pages", t.written_cp, t.written_rb, [&] { d.checkpoint_by_written(); });
  }
  return t;
}

void print_timings(const rejuv::bench_image::ImageDriver& d, const BenchRequest& r, const Timings& t) {
  const Stat read{d.read_us};
  std::printf("image by copy: %zu KB (service 0), read_process p50 %.0f us, max %.0f us\n",
              d.layout(0).bytes() / 1024, read.p50(), read.max());
  std::printf("                   p50 [ms]   max [ms]\n");
  std::printf("checkpoint, fork   %8.3f   %8.3f\n", t.fork_cp.p50(), t.fork_cp.max());
  std::printf("checkpoint, copy   %8.3f   %8.3f\n", t.copy_cp.p50(), t.copy_cp.max());
  std::printf("rollback,   fork   %8.3f   %8.3f\n", t.fork_rb.p50(), t.fork_rb.max());
  std::printf("rollback,   copy   %8.3f   %8.3f\n", t.copy_rb.p50(), t.copy_rb.max());
  if (!t.untracked.empty()) {
    std::printf("by written pages: not measured (%s)\n", t.untracked.c_str());
  } else if (!t.written_cp.ms.empty()) {
    const Stat pages{d.written_pages};
    std::printf("checkpoint, written %7.3f   %8.3f   (%.0f pages p50 per service, max %.0f)\n", t.written_cp.p50(),
                t.written_cp.max(), pages.p50(), pages.max());
    std::printf("rollback,   written %7.3f   %8.3f\n", t.written_rb.p50(), t.written_rb.max());
  }
  if (r.ways == Ways::All) {
    std::printf("ratio copy / fork (p50; < 1: copy faster): checkpoint %.2f, rollback %.2f\n",
                t.copy_cp.p50() / t.fork_cp.p50(), t.copy_rb.p50() / t.fork_rb.p50());
    if (!t.written_cp.ms.empty()) {
      std::printf("ratio written / fork (p50): checkpoint %.2f, rollback %.2f\n", t.written_cp.p50() / t.fork_cp.p50(),
                  t.written_rb.p50() / t.fork_rb.p50());
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  BenchRequest r;
  if (auto exit = parse_args(argc, argv, r)) return *exit;
  if (auto cpu = rejuv::sys::pin_to_one_cpu(std::nullopt); !cpu) {
    std::fprintf(stderr, "image_bench: %s\n", cpu.error().to_string().c_str());
    return 2;
  }
  rejuv::bench_image::ImageDriver d(REJUV_IMAGE_SERVICE, r.services, r.pages_per_tick);
  for (int i = 0; i < 20; ++i) d.tick();
  d.start_zygotes();
  d.make_holders();
  std::printf("image_bench: %d services, %d cycles each way, one CPU\n", r.services, r.cycles);
  const Timings t = measure(d, r);
  print_timings(d, r, t);
  return 0;
}
